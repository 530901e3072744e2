"""Generated from the proved models by `certiloop extract`; do not edit. Regenerate everything with
`python -m certiloop.studies regenerate` (a test fails when any file here is stale)."""
