"""Imported once by the worker server: loads the engine (through verdict_of, the one place
that names it) so that every case's process starts with it in memory."""

from .harness import verdict_of

verdict_of(None)
