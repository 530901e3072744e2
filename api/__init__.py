"""certiloop's Python API: what the `certiloop` command calls, for notebooks, scripts and CI.

    from certiloop.api import falsify, gate, load, prove

    result = prove("textbook.train")            # a library name, "path/to/file.py:name" or a Theorem
    result.verdict                               # "proved", "refuted" or "unknown"
    [o.path for o in result.obligations if o.verdict != "proved"]

    found = falsify("textbook.train_no_lookahead", max_examples=300, seed=0)
    found.found, found.run                       # a violating run, confirmed by the exact replay

    entries = gate(["textbook"])                 # each model against the verdict its author expects
    all(e.passed for e in entries)

Budgets are deterministic (z3 resource units, `rlimit`), so the same call gives the same
verdict on any machine. Heavy modules (z3, sympy, hypothesis) load on first use.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from certiloop.api.loading import Unsupported, load, load_all, project_models

if TYPE_CHECKING:
    from certiloop.api.gate_run import GateEntry
    from certiloop.falsify.search import Falsification
    from certiloop.models.lang.theorem import Theorem
    from certiloop.proofs.engine.prover import Prover, TheoremResult

__all__ = ["Unsupported", "falsify", "gate", "load", "load_all", "project_models", "prove"]


def _theorem(model: "str | Theorem") -> "Theorem":
    return load(model) if isinstance(model, str) else model


def prove(model: "str | Theorem", *, rlimit: int | None = None, jobs: int | None = 1,
          executor: str | None = None, prover: "Prover | None" = None, smtlib_dir=None,
          on_start=None, on_result=None) -> "TheoremResult":
    """Prove one model: its obligations discharged, and if one is not proved, a search for a run
    that violates the guarantee. `prover`: an open `Prover` to reuse (its workers and budget);
    else one with `jobs` workers and `rlimit` z3 units per obligation (default: the CLI's)."""
    from certiloop.proofs.engine.budget import Budget
    from certiloop.proofs.engine.prover import Prover

    theorem = _theorem(model)
    if prover is not None:
        return prover.prove(theorem, on_start=on_start, on_result=on_result, smtlib_dir=smtlib_dir)
    budget = Budget() if rlimit is None else Budget(rlimit=rlimit)
    with Prover(jobs=jobs, budget=budget, executor=executor) as own:
        return own.prove(theorem, on_start=on_start, on_result=on_result, smtlib_dir=smtlib_dir)


def falsify(model: "str | Theorem", *, max_examples: int = 2000, seed: int = 0,
            **options: Any) -> "Falsification":
    """Search for a run that violates the guarantee (hypothesis and a batch simulator); a run is
    reported only once replayed exactly. `options`: the other fields of
    `certiloop.falsify.search.Options` (max_steps, families, database, ...)."""
    from certiloop.falsify.search import Options
    from certiloop.falsify.search import falsify as search

    return search(_theorem(model), Options(max_examples=max_examples, seed=seed, **options))


def gate(models: "list[str] | None" = None, *, rlimit: int | None = None, jobs: int | None = None,
         falsify_examples: int = 300, cross_check: bool = False, cache=None) -> "list[GateEntry]":
    """Check each model (default: the project's `[tool.certiloop] models`, else the library)
    against the verdict its author expects, as `certiloop gate` does; `cache`: a
    `certiloop.proofs.engine.cache.Cache` or None (prove everything)."""
    from certiloop.api.gate_run import GateOptions, run_gate
    from certiloop.proofs.engine.budget import Budget
    from certiloop.proofs.engine.prover import Prover

    theorems = load_all(models or project_models(), keep_unsupported=True)
    budget = Budget() if rlimit is None else Budget(rlimit=rlimit)
    opts = GateOptions(falsify_examples=falsify_examples, cross_check=cross_check)
    provers: list = []

    def start_prover():
        provers.append(Prover(jobs=jobs, budget=budget).__enter__())
        return provers[-1]

    try:
        return run_gate(theorems, start_prover, budget.rlimit, opts, cache)
    finally:
        for p in provers:
            p.__exit__(None, None, None)
