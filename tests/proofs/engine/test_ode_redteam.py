"""Red team for the ODE rules (proofs/core/odes.py, vcgen's cut chains, the invariant planner
proofs/engine/odeplan.py), by a second reader: FALSE properties close to true ones, aimed at
each rule's side conditions. None may prove; each is shown false by an independent witness
(scipy integrating the flow, or the explicit solution in the comment and checked here).

What each case attacks:
* tangency of higher order: at p = 0 the first derivative is 0 and a naive "p = 0 -> p' >= 0"
  barrier would accept p >= 0 (x' = y, y' = -1 from the origin: x = -t²/2);
* a parameter the ODE changes, treated as a constant (x' = -a, a' = 1; x >= a with x' = 0);
* conjunctions of which one conjunct is not inductive, in both orders;
* != and strict inequalities crossed by the flow, in one and two dimensions;
* domains: reached and left closed, a strict post on the closed boundary;
* Darboux shapes with the wrong sign or a cofactor that is not one;
* disjunctions and divisions in the claim, a loop around an ODE, a decaying rotation.
"""

from __future__ import annotations

import math

import pytest

from certiloop.models import And, Or, Reals, Theorem, loop, ode
from certiloop.proofs.engine import Prover
from proofs.core.test_ode_rules import holds_along  # noqa: E402  (the author's scipy witness)

x, y, z, a, b = Reals("x y z a b")


def verdict(pre, program, post) -> str:
    with Prover(jobs=1) as p:
        return p.prove(Theorem("redteam", pre, program, post)).verdict


# name: (pre, program, post, rhs, a start where pre holds, post numerically, horizon)
CASES = {
    "higher-order tangency x' = y, y' = -1 from the origin": (
        And(x >= 0, y == 0), ode({x: y, y: -1}), x >= 0,
        lambda x, y: [y, -1.0], [0.0, 0.0], lambda x, y: x >= -1e-12, 1.0),
    "higher-order tangency with the annotation the rule would like": (
        And(x >= 0, y == 0), ode({x: y, y: -1}, invariants=[x >= 0]), x >= 0,
        lambda x, y: [y, -1.0], [0.0, 0.0], lambda x, y: x >= -1e-12, 1.0),
    "a parameter the ODE changes: x' = -a, a' = 1": (
        And(x == 1, a == 0), ode({x: -a, a: 1}), x > 0,
        lambda x, a: [-a, 1.0], [1.0, 0.0], lambda x, a: x > 0, 3.0),
    "x >= a while a grows": (
        x >= a, ode({x: 0, a: 1}), x >= a, lambda x, a: [0.0, 1.0], [0.0, 0.0],
        lambda x, a: x >= a - 1e-12, 1.0),
    "one conjunct not inductive (x >= 0 and y >= 0, x' = y, y' = -1)": (
        And(x >= 0, y >= 0), ode({x: y, y: -1}), And(x >= 0, y >= 0),
        lambda x, y: [y, -1.0], [1.0, 0.0], lambda x, y: x >= 0 and y >= -1e-12, 1.0),
    "the same, conjuncts annotated in the other order": (
        And(x >= 0, y >= 0), ode({x: y, y: -1}, invariants=[And(y >= 0, x >= 0)]), And(x >= 0, y >= 0),
        lambda x, y: [y, -1.0], [1.0, 0.0], lambda x, y: x >= 0 and y >= -1e-12, 1.0),
    "!= crossed: x' = 1 from -1": (
        x != 0, ode({x: 1}), x != 0, lambda x: [1.0], [-1.0], lambda x: x < 0, 3.0),
    "!= of a product crossed in 2-D": (
        x * y != 0, ode({x: 1, y: 1}), x * y != 0, lambda x, y: [1.0, 1.0], [-1.0, 2.0],
        lambda x, y: x < 0, 3.0),
    "strict > reached in finite time: x' = x^2 - 1 from 1/2": (
        x == 0.5, ode({x: x**2 - 1}), x > 0, lambda x: [x * x - 1], [0.5], lambda x: x > 0, 2.0),
    "equilibrium just missed: x' = -x^2 - 1 from 0": (
        x == 0, ode({x: -(x**2) - 1}), x >= 0, lambda x: [-x * x - 1], [0.0], lambda x: x >= -1e-12, 0.5),
    "domain reached and left closed: post strict on the boundary": (
        x == 0, ode({x: 1}, x <= 1), x < 1, lambda x: [1.0], [0.0],
        lambda x: x < 1 - 1e-6 or x > 1 + 1e-6, 1.0),
    "domain lower bound below the claim": (
        x == 1, ode({x: -1}, x >= -1), x > 0, lambda x: [-1.0], [1.0], lambda x: x > 0 or x < -1, 2.0),
    "Darboux with the wrong sign of a positive cofactor": (
        x < 0, ode({x: x}), x > -1, lambda x: [x], [-0.5], lambda x: x > -1, 2.0),
    "almost Darboux: x' = -x + y with y < 0 constant": (
        And(x > 0, y < 0), ode({x: -x + y}), x > 0, lambda x, y: [-x + y, 0.0], [0.5, -1.0],
        lambda x, y: x > 0, 3.0),
    "disjunction the flow leaves: x > 1 or x < -1 under x' = -x": (
        Or(x > 1, x < -1), ode({x: -x}), Or(x > 1, x < -1), lambda x: [-x], [2.0],
        lambda x: x > 1 or x < -1, 3.0),
    "a division in the claim: 1/x > 0 while x' = -1 from 1": (
        x == 1, ode({x: -1}), x > 0, lambda x: [-1.0], [1.0], lambda x: x > 0, 2.0),
    "a decaying rotation keeps no circle": (
        x**2 + y**2 >= 1, ode({x: -y - x / 10, y: x - y / 10}), x**2 + y**2 >= 1,
        lambda x, y: [-y - x / 10, x - y / 10], [1.0, 0.0], lambda x, y: x * x + y * y >= 1 - 1e-9, 3.0),
    "a circle kept, a half-plane not: x^2 + y^2 = 1 and y >= 0": (
        And(x**2 + y**2 == 1, y >= 0), ode({x: -y, y: x}), And(x**2 + y**2 == 1, y >= 0),
        lambda x, y: [-y, x], [0.0, 1.0], lambda x, y: y >= -1e-9, 3.0),
    "exponential growth never reaches a bound, but a linear one does": (
        And(x == 0, z == 1), ode({x: 1, z: z}), x <= 2, lambda x, z: [1.0, z], [0.0, 1.0],
        lambda x, z: x <= 2, 3.0),
    # the same attacks on flows without a polynomial solution: no exact run refutes them, so
    # only the rules (dI, dbx, barrier, cut chains, the planner's invariants) decide
    "higher-order tangency, no solution: x' = y, y' = -1 - x^2": (
        And(x >= 0, y == 0), ode({x: y, y: -1 - x**2}, invariants=[x >= 0]), x >= 0,
        lambda x, y: [y, -1 - x * x], [0.0, 0.0], lambda x, y: x >= -1e-12, 1.0),
    "a parameter the ODE changes, no solution: x' = -a, a' = 1 + x^2": (
        And(x == 1, a == 0), ode({x: -a, a: 1 + x**2}), x > 0,
        lambda x, a: [-a, 1 + x * x], [1.0, 0.0], lambda x, a: x > 0, 3.0),
    "one conjunct not inductive, no solution: x' = y, y' = -1 - y^2": (
        And(x >= 0, y >= 0), ode({x: y, y: -1 - y**2}), And(x >= 0, y >= 0),
        lambda x, y: [y, -1 - y * y], [1.0, 0.0], lambda x, y: x >= 0 and y >= -1e-12, 1.0),
    "!= crossed, no solution: x' = 1 + x^2 from -1 (x = tan(t - pi/4))": (
        x != 0, ode({x: 1 + x**2}, invariants=[x != 0]), x != 0, lambda x: [1 + x * x], [-1.0],
        lambda x: x < 0, 1.0),
    "domain reached closed, no solution: x' = 1 + x^2 inside x <= 1": (
        x == 0, ode({x: 1 + x**2}, x <= 1, invariants=[x < 1]), x < 1, lambda x: [1 + x * x], [0.0],
        lambda x: x < 1 - 1e-6 or x > 1 + 1e-6, math.pi / 4),
    "a bounded product that is not: x*z <= 1 with x' = 1, z' = 0": (
        And(x == 0, z == 1), ode({x: 1, z: 0}), x * z <= 1, lambda x, z: [1.0, 0.0], [0.0, 1.0],
        lambda x, z: x * z <= 1, 3.0),
}


@pytest.mark.parametrize("name", list(CASES))
def test_false_near_miss_is_not_proved(name):
    pre, prog, post, rhs, start, post_num, horizon = CASES[name]
    assert verdict(pre, prog, post) != "proved", name
    assert not holds_along(rhs, [start], post_num, horizon), "the witness must show it false"


def test_loop_around_an_ode_that_loses_the_claim():
    # (x' = -1)* from x = 1: after one run of length 2, x = -1 < 0 (explicit solution x = 1 - t)
    assert verdict(x == 1, loop(ode({x: -1})), x >= 0) != "proved"
    assert not holds_along(lambda x: [-1.0], [[1.0]], lambda x: x >= 0, 2.0)  # one run of the body


def test_loop_with_a_wrong_invariant_annotation():
    # invariant x >= 0 is not kept by x' = -1 (x = x0 - t); the post is weaker than it
    assert verdict(x == 1, loop(ode({x: -1}), invariant=x >= 0), x >= -5) != "proved"
    assert not holds_along(lambda x: [-1.0], [[1.0]], lambda x: x >= -5, 10.0)  # ten time units reach -9


def test_time_dependent_rate_sign_change():
    # x' = (1 - t) x with t' = 1 from x = 1, t = 0 keeps x > 0 (x = exp(t - t²/2) > 0): TRUE,
    # and its sibling x' = (1 - t), which crosses 0 at t = 1 + sqrt(3), is FALSE
    t = Reals("t")[0]
    assert verdict(And(x == 1, t == 0), ode({x: (1 - t) * x, t: 1}), x > 0) == "proved"
    assert verdict(And(x == 1, t == 0), ode({x: 1 - t, t: 1}), x > 0) != "proved"
    assert holds_along(lambda x, t: [(1 - t) * x, 1.0], [[1.0, 0.0]], lambda x, t: x > 0, 3.0)
    assert not holds_along(lambda x, t: [1 - t, 1.0], [[1.0, 0.0]], lambda x, t: x > 0, 3.0)  # 0 at 1 + √3
