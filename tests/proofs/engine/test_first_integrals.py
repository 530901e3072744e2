"""First integrals with parameters (proofs/engine/first_integrals.py): a spring whose
stiffness k is a parameter keeps k*x^2 + y^2, which no search over QQ finds.

The search only proposes; each proof is witnessed by scipy integrating the flow for sample
values of the parameter, and each false twin is shown false the same way and not proved."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from certiloop.models import And, Iff, Reals, Theorem, ode
from certiloop.proofs.core.solver import check_here
from certiloop.proofs.engine import Prover
from certiloop.proofs.engine.first_integrals import integral_atoms

x, y, c, k = Reals("x y c k")
SPRING = {x: y, y: -k * x, c: y}  # c - x is conserved too


def flow(kv, start, T=6.0):
    rhs = lambda _t, s: [s[1], -kv * s[0], s[1]]  # noqa: E731
    sol = solve_ivp(rhs, (0.0, T), np.asarray(start, float), rtol=1e-10, atol=1e-12, dense_output=True)
    return sol.sol(np.linspace(0.0, T, 401))


def verdict(theorem: Theorem) -> str:
    with Prover(jobs=1) as p:
        return p.prove(theorem).verdict


def means(a, b) -> bool:
    return check_here(Iff(a, b), 1_000_000, 60.0).status == "unsat"


def test_a_fixed_start_gives_each_integral_its_value():
    theorem = Theorem("t", And(k > 0, x == 1, y == 0, c == 0), ode(SPRING), y * y <= k)
    (system,) = [theorem.program]
    atoms = integral_atoms(theorem, system)
    assert any(means(a, k * x**2 + y**2 == k) for a in atoms), atoms
    assert any(means(a, c - x == -1) for a in atoms), atoms


def test_an_assumption_on_the_start_gives_an_inequality():
    # at c = 0 the assumption x > 1 is (x - c) > 1: the integral x - c stays above 1
    theorem = Theorem("t", And(k > 0, c == 0, x > 1), ode(SPRING), x > c)
    atoms = integral_atoms(theorem, theorem.program)
    assert any(means(a, x - c > 1) for a in atoms), atoms


def test_no_parameter_or_no_polynomial_field_gives_nothing():
    assert integral_atoms(Theorem("t", x == 1, ode({x: y, y: -x}), x <= 1), ode({x: y, y: -x})) == []
    bad = ode({x: y, y: -x / k})
    assert integral_atoms(Theorem("t", x == 1, bad, x <= 1), bad) == []


@pytest.mark.parametrize("kv", [0.5, 2.0])
def test_the_spring_is_proved_and_witnessed(kv):
    theorem = Theorem("t", And(k > 0, x == 1, y == 0, c == 0), ode(SPRING), And(y * y <= k, x - c <= 1))
    assert verdict(theorem) == "proved"
    path = flow(kv, [1.0, 0.0, 0.0])
    assert (path[1] ** 2 <= kv + 1e-7).all() and (path[0] - path[2] <= 1 + 1e-7).all()


def test_false_twins_are_not_proved_and_fail_along_the_flow():
    twin = Theorem("t", And(k > 0, x == 1, y == 0, c == 0), ode(SPRING), y * y <= k / 2)
    assert verdict(twin) != "proved"
    assert (flow(2.0, [1.0, 0.0, 0.0])[1] ** 2 > 1.0 + 1e-3).any()
    shifted = Theorem("t", And(k > 0, c == 0, x > 1), ode(SPRING), x > c + 2)
    assert verdict(shifted) != "proved"
    path = flow(1.0, [1.5, 0.0, 0.0])
    assert (path[0] - path[2] < 2).all()  # x - c stays 1.5: never above 2
