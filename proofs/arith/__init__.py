"""Arithmetic helpers outside the trusted core: projection search, SMT-LIB export, cvc5."""
