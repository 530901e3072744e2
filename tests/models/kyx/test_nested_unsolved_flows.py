"""Flows without a polynomial solution inside a claim's formulas (proofs/core/vcgen.py): a
diamond over one is proved by fewer runs (the flow's run of duration 0), a negated one is the
box it becomes, and a diamond whose postcondition the core must execute (`<a>[b]P`, b such a
flow or a loop) is proved by the run of a that stays put. Before, each was "not supported".

Truth comes from closed forms (x' = -x: x = x0 e^-t), checked at the test, never from the
engine. The mutants named at their tests were run, and each made its test fail."""

from __future__ import annotations

import math

import pytest

from certiloop.models.kyx import KyxError, read_entries
from certiloop.proofs.engine import Prover


def verdict(problem: str) -> str:
    (e,) = read_entries(f'ArchiveEntry "e" ProgramVariables Real x, y, t; End. Problem {problem} End. End.')
    if e.error:
        raise KyxError(e.error)
    with Prover(jobs=1) as p:
        return p.prove(e.theorem).verdict


def decay(x0: float, t: float) -> float:
    return x0 * math.exp(-t)


@pytest.mark.parametrize("claim, why", [
    ("x = 1 -> <{x' = -x}> x >= 1", "the run of duration 0 ends at x = 1"),
    ("x = 1 -> <{x' = -x}>[{x' = -x}] x > 0", "x = e^-t > 0 from every state the first flow reaches"),
    ("x = 1 -> !<{x' = -x}> x > 1", "x = e^-t never exceeds 1"),
    ("x = 1 -> \\forall y (y > 0 -> <{x' = -x}>[{x' = -x}] x*y > 0)", "as the second, times y > 0"),
    ("x = 1 -> <x := 2*x;>[{x' = -x}] x > 0", "the assignment, then x = 2e^-t"),
])
def test_true_claims_are_proved(claim, why):
    assert all(decay(1.0, t) > 0 and decay(1.0, t) <= 1 for t in (0, 0.5, 3, 30))
    assert verdict(claim) == "proved", why


@pytest.mark.parametrize("claim", [
    "x = 1 -> <{x' = -x}> x > 1",                   # x = e^-t <= 1 all along
    "x = 1 -> <{x' = -x}>[{x' = -x}] x > 1/2",       # every run from any e^-s goes below 1/2
    # no run: the domain is false where the flow starts. The mutant that skips the domain of
    # the run that stays put proves it (the box holds from x = -1).
    "x = -1 -> <{x' = -x & x > 0}>[{x' = -x}] x < 0",
    # no run: the test fails at x = 0. The mutant that skips the test proves it.
    "x = 0 -> <?x > 0;>[{x' = -x}] x > -1",
])
def test_false_claims_are_not_proved(claim):
    assert decay(1.0, 1.0) < 1 and decay(1.0, 1.0) < 1 / 2 + 0.5 and decay(1.0, 2.0) < 1 / 2
    assert verdict(claim) != "proved"


def test_a_true_diamond_the_run_that_stays_cannot_show_is_unknown_not_refuted():
    # x = e^-t < 1 for every t > 0: true, but only a run of positive duration shows it
    assert decay(1.0, 0.1) < 1
    assert verdict("x = 1 -> <{x' = -x}> x < 1") == "unknown"


def test_a_diamond_needing_a_witness_before_an_executed_postcondition_is_refused():
    with pytest.raises(Exception, match="needs a witness"):
        verdict("x = 1 -> <x := *;>[{x' = -x}] x > 0")
