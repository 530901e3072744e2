"""Scheduling obligations over workers, budgets and the result cache (outside the trusted core)."""

from certiloop.proofs.engine.prover import Prover, TheoremResult, discharge_one, write_smtlib

__all__ = ["Prover", "TheoremResult", "discharge_one", "write_smtlib"]
