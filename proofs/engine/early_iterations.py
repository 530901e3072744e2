"""A division by zero in a loop's first iterations: the model is ill-defined, not unknown.

Past a loop, a refuted "no division by 0" obligation only shows a state the invariant allows,
which no run may reach: by itself it says "strengthen the invariant". The program with each
loop replaced by its first `UNROLL` iterations (`skip ∪ body ∪ body;body`) has a subset of the
loop's runs and needs no invariant; a division by zero it refutes without any incomplete
rule (exact, from a state the assumptions allow) happens on a real run, so the claim itself
is ill-defined, as the README documents for a division outside loops.
"""

from __future__ import annotations

from dataclasses import replace

from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Havoc,
    Loop,
    Program,
    Seq,
    Test,
    choice,
    seq,
    skip,
)
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.verdicts import ObligationResult

UNROLL = 2  # iterations: a count, so the verdict never depends on the clock


def unrolled(program: Program, times: int = UNROLL) -> Program:
    """`program` with every loop replaced by zero to `times` iterations of its (unrolled) body."""
    if isinstance(program, Loop):
        body = unrolled(program.body, times)
        return choice(skip(), *(seq(*[body] * k) for k in range(1, times + 1)))
    if isinstance(program, Seq):
        return seq(*(unrolled(p, times) for p in program.parts))
    if isinstance(program, Choice):
        alternatives = zip(program.labels, program.alternatives)
        return choice(*((label, unrolled(p, times)) for label, p in alternatives))
    if isinstance(program, (Assign, Havoc, Test, ODE)):
        return program
    raise TypeError(f"unknown program {type(program).__name__}")


def has_loop(program: Program) -> bool:
    if isinstance(program, Loop):
        return True
    if isinstance(program, Seq):
        return any(has_loop(p) for p in program.parts)
    if isinstance(program, Choice):
        return any(has_loop(p) for p in program.alternatives)
    return False


def loop_division_open(results: list[ObligationResult]) -> bool:
    """A division obligation refuted past an incomplete rule (the case this module settles)."""
    return any(r.kind == "defined" and "division" in r.path and r.verdict == "refuted" and r.rule
               for r in results)


def division_by_zero_on_a_run(theorem: Theorem, discharge) -> ObligationResult | None:
    """The first division obligation of the unrolled theorem that is refuted exactly (no
    incomplete rule on its path), or None. `discharge(obligations)` returns their results."""
    from certiloop.proofs.core.vcgen import generate

    if not has_loop(theorem.program):
        return None
    try:
        early = replace(theorem, program=unrolled(theorem.program))
        obligations = [ob for ob in generate(early) if ob.kind == "defined" and "division" in ob.path]
    except Exception:  # noqa: BLE001 - only a sharper message is at stake; the verdict stands
        return None
    return next((r for r in discharge(obligations) if r.verdict == "refuted" and not r.rule), None)


def ill_defined_reason(found: ObligationResult) -> str:
    shown = ", ".join(f"{k} = {v}" for k, v in (found.counterexample or {}).items())
    at = f" ({shown})" if shown else ""
    return (f"ill-defined: {found.path}: a division in the claim itself, and it can be by zero{at} "
            f"within the first {UNROLL} iterations of its loop")
