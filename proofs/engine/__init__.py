"""Scheduling obligations over workers, deterministic budgets and the result cache
(outside the trusted core: it can only call it).

The names are loaded on first use (PEP 562): `certiloop --help` reads the budget defaults
from `engine.budget` without importing z3 and sympy through the prover."""

from importlib import import_module

_WHERE = {"Budget": "budget", "discharge_one": "discharge", "Prover": "prover",
          "TheoremResult": "prover", "confirm_run": "prover", "write_smtlib": "prover"}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(import_module(f"{__name__}.{_WHERE[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
