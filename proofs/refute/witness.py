"""A witness run for the vacuity check: one concrete run of the program, from a state that
satisfies the assumptions, through one iteration of each top-level loop.

The vacuity obligations prove that every part of the program has a run from every state it
can start in; the witness shows it on an example that the interpreter replays — and shows
that the assumptions can be met at all (a theorem whose assumptions are contradictory
proves anything).
"""

from __future__ import annotations

from certiloop.models.lang.programs import Choice, Loop, Program, Seq, seq
from certiloop.models.lang.terms import FALSE, And, Implies
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vcgen import Names
from certiloop.proofs.core.verdicts import judge
from certiloop.proofs.core.wp import expand_modalities, unroll
from certiloop.proofs.engine.budget import Budget
from certiloop.proofs.refute.bmc import Encoder
from certiloop.proofs.refute.unroll import Refutation, Replay, index_sort, search_family

INNER_DEPTH = 2  # iterations of inner loops the witness may take (small families suffice)


def _once(p: Program) -> Program:
    """The program with each top-level loop run exactly once (inner loops stay loops)."""
    if isinstance(p, Loop):
        return p.body
    if isinstance(p, Seq):
        return seq(*(_once(q) for q in p.parts))
    if isinstance(p, Choice):
        return Choice(tuple(_once(q) for q in p.alternatives), p.labels)
    return p


def find_witness(theorem: Theorem, budget: Budget) -> tuple[Refutation | None, str]:
    """(a run re-checked exactly, "") or (None, why there is none)."""
    names = Names()
    pre = expand_modalities(theorem.assumptions, names)
    program = unroll(_once(theorem.program), INNER_DEPTH)
    encoder = Encoder(names)
    run, _final = encoder.run(program, {})
    no_run = Implies(And(pre, *run), FALSE)  # valid iff there is no such run; a counterexample is a run
    sort = index_sort(theorem)
    if sort is not None:  # a small concrete family: plain arithmetic, no quantifiers for z3
        for size in range(1, INNER_DEPTH + 1):
            model = search_family(no_run, sort, size, budget)
            if model is not None:
                return _reconstruct(model, encoder, pre, program)
        return None, (f"no witness run over a family of at most {INNER_DEPTH} elements: the assumptions "
                      "cannot be met, or every run blocks within one step")
    answer = check_valid(no_run, budget.rlimit, budget.wall_s)
    if answer.status == "unsat":
        return None, ("no run at all: the assumptions cannot be met, or every run blocks within "
                      f"one step (inner loops up to {INNER_DEPTH} iterations)")
    if answer.status == "unknown":
        return None, f"no witness run found: {answer.reason}"
    if judge("witness", "", no_run, answer, 0.0).verdict != "refuted":
        return None, "the solver's witness run does not re-check exactly"
    return _reconstruct(answer.model or {}, encoder, pre, program)


def _reconstruct(model, encoder, pre, program) -> tuple[Refutation | None, str]:
    replay = Replay(model, encoder.record, pre, FALSE)  # every end state "violates" false
    initial = {k: v for k, v in model.items() if "@" not in k}
    trace = replay.run(program, initial)
    if trace is None:
        return None, "the witness run could not be reconstructed step by step"
    return Refutation(1, replay.start, trace, "", "exact", 0.0, replay.raw_start), ""
