"""The C printer of extraction: `extract_c(theorem)` writes a model's control step as C99."""

from certiloop.kernel.extract.c.emit import extract_c

__all__ = ["extract_c"]
