"""No run passes a point where the flow divides by zero (proofs/core/odes.py `runs_along`).

sympy simplifies before the solution is read: x' = x/x has the closed form x0 + t and the
domain x/x >= 1 becomes 1 >= 1. Along x = -1 + t both are undefined at t = 1, so no run gets
there; the prover refuted both true claims below with a "run" through x = 0, and the falsifier
confirmed such runs exactly (red teams). Truth is by hand: x(t) = -1 + t, and a run of
duration t needs its right-hand side and domain defined on all of [0, t]."""

from __future__ import annotations

from fractions import Fraction

import pytest

from certiloop.models.kyx import KyxError, read_entries
from certiloop.models.lang.programs import ode
from certiloop.models.lang.terms import Reals
from certiloop.proofs.core.exact import truth
from certiloop.proofs.core.odes import runs_along
from certiloop.proofs.core.wp import flow_solution
from certiloop.proofs.engine import Prover

x, y, tau = Reals("x y tau")


def verdict(problem: str) -> str:
    (e,) = read_entries(f'ArchiveEntry "e" ProgramVariables Real x, y; End. Problem {problem} End. End.')
    if e.error:
        raise KyxError(e.error)
    with Prover(jobs=1) as p:
        return p.prove(e.theorem).verdict


@pytest.mark.parametrize("flow, runs", [
    (ode({x: 1}, x / x >= 1), False),           # the domain divides by x
    (ode({x: x / x}), False),                   # the right-hand side does
    (ode({x: (x - 1) / ((x - 1) * y), y: 0}), True),  # 0/0 at x = 1 only, reached at t = 2 exactly
    (ode({x: 1}, x * x / x <= 100), False),     # x^2/x: sympy's x, degree 1
])
def test_a_run_through_a_zero_denominator_is_no_run(flow, runs):
    s, sol = flow_solution(flow)
    along = runs_along(flow, sol, tau, s)
    start = {"x": Fraction(-1), "y": Fraction(1)}
    assert truth(along, {**start, "tau": Fraction(1, 2)}) is True  # x stays below 0 until t = 1
    assert truth(along, {**start, "tau": Fraction(2)}) is False  # through x = 0 (or to x = 1)
    assert truth(along, {**start, "tau": Fraction(3, 2)}) is runs


@pytest.mark.parametrize("claim", [
    "x = -1 -> [{x' = 1 & x/x >= 1}] x < 1/2",
    "x = -1 -> [{x' = x/x}] x < 1/2",
    "x = -1 -> [{x' = 1 & x^3/x <= 100}] x < 1/2",
])
def test_true_claims_are_not_refuted_by_a_run_through_the_pole(claim):
    assert verdict(claim) != "refuted"


@pytest.mark.parametrize("claim", [
    "x = -1 -> <{x' = 1 & x/x >= 1}> x > 1/2",
    "x = -1 -> <{x' = x/x}> x > 1/2",
])
def test_false_diamonds_through_the_pole_are_not_proved(claim):
    assert verdict(claim) != "proved"


def test_runs_that_keep_away_from_the_pole_are_still_runs():
    # x = 1 + t never reaches 0: the domain holds, and x < 2 fails at t = 1 on a real run
    assert verdict("x = 1 -> [{x' = 1 & x/x >= 1}] x < 2") == "refuted"
    assert verdict("x = 1 -> [{x' = x/x & x > 0}] x >= 1") == "proved"
