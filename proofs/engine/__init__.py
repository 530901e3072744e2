"""Scheduling obligations over workers, deterministic budgets and the result cache
(outside the trusted core: it can only call it)."""

from certiloop.proofs.engine.budget import Budget
from certiloop.proofs.engine.discharge import discharge_one
from certiloop.proofs.engine.prover import Prover, TheoremResult, confirm_run, write_smtlib

__all__ = ["Budget", "Prover", "TheoremResult", "confirm_run", "discharge_one", "write_smtlib"]
