"""The trusted core: the code whose bugs could turn a false claim into `proved` (see README.md)."""
