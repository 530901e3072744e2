"""Red team for the sign rules (nonzero, the strict barrier for `p >= 0`) and for the planner
appending the guarantee's atoms to an annotated chain (proofs/core/odes.py `atom_premise`,
proofs/core/vcgen.py `_ode_cuts`, proofs/engine/odeplan.py `candidates` / `rule_options`).

Every FALSE claim is shown false independently of certiloop: by the explicit solution checked
with exact arithmetic (Fraction / sympy), or by scipy integrating the flow. Every TRUE claim is
witnessed the same way.

Found by this file, and fixed (the tests now pass unmarked):
* a barrier link on an annotated atom with a division, `1/x >= 0`, after the planner dropped the
  earlier annotation `x > 0` that made the atom well-defined: the "well-defined: differential
  invariants" obligation still assumes the dropped `x > 0`, and the barrier premise
  `1/x = 0 -> 1 + 1/x^2 > 0` is valid only by z3's reading of 1/0. The flow x' = -(1 + x^2)
  from x = 1 is x = tan(pi/4 - t) and goes negative at t = pi/4 (same hole for `1/x > 0`, which
  the old barrier already allowed; the `>=` extension widened it). Fixed: vcgen checks each
  link defined against the links that really precede it in the chain;
* an array over the reals read at an ODE variable, `a[x]`, is a constant to the Lie
  derivative, so `a[x] > 0` "is" a Darboux identity under x' = 1 (not from the new rules).
  Fixed: lie_derivative refuses an array read whose index the flow moves.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import sympy
from scipy.integrate import solve_ivp

from certiloop.models import And, Array, Box, Implies, Not, Reals, Theorem, assign, loop, ode, seq, test
from certiloop.models.lang.terms import REAL, ModelError
from certiloop.proofs.core.odes import OdeStep
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine import Prover

x, y, t, c = Reals("x y t c")
Y0 = [y == 0]  # an annotation that is trivially invariant: it makes the planner build a chain


def verdict(pre, program, post, search=False) -> str:
    with Prover(jobs=1) as p:
        return p.prove(Theorem("redteam", pre, program, post), search=search).verdict


def planned_all_proved(pre, prog, post, steps) -> bool:
    """Do all obligations of the theorem with the ODE's chain forced to `steps` prove?"""
    obs = generate(Theorem("forced", pre, prog, post), {prog.key: tuple(steps)})
    with Prover(jobs=1) as p:
        return all(r.verdict == "proved" for r in p._discharge(obs, None, p.budget))


def trajectory(rhs, start, T, n=801):
    sol = solve_ivp(lambda _t, s: rhs(*s), (0.0, T), np.asarray(start, float), method="DOP853",
                    rtol=1e-10, atol=1e-12, dense_output=True)
    assert sol.success
    return sol.sol(np.linspace(0.0, T, n))


# --------------------------------------------------------------------------- found: division
TAN = {x: -(1 + x**2)}  # from x = 1: x = tan(pi/4 - t), zero at t = pi/4, negative after


def _tan_is_false_witness():
    s = sympy.Symbol("s", real=True)
    sol = sympy.tan(sympy.pi / 4 - s)
    assert sympy.simplify(sympy.diff(sol, s) + 1 + sol**2) == 0 and sol.subs(s, 0) == 1
    assert sol.subs(s, sympy.pi / 2) == -1  # exact: x(pi/2) = -1 < 0, and no pole before 3pi/4
    xs = trajectory(lambda x: [-(1 + x**2)], [1.0], 1.2)[0]
    assert xs.min() < -0.4 and np.isfinite(xs).all()


@pytest.mark.parametrize("atom", [1 / x >= 0, 1 / x > 0], ids=[">=", ">"])
@pytest.mark.parametrize("first", [x > 0, x > 5], ids=["dropped-premise", "dropped-init"])
def test_division_atom_after_a_dropped_annotation_is_not_proved(atom, first):
    _tan_is_false_witness()
    assert verdict(x == 1, ode(TAN, invariants=[first, atom]), x >= 0) != "proved"


def test_division_atom_alone_is_refused_as_undefined():
    _tan_is_false_witness()
    assert verdict(x == 1, ode(TAN, invariants=[1 / x >= 0]), x >= 0) != "proved"


def test_division_atom_with_its_guard_kept_proves_only_the_true_part():
    """With the domain x > 0 the flow stops at x = 0: [x' = -(1+x^2) & x > 0] x >= 0 is true."""
    assert verdict(x == 1, ode(TAN, x > 0, invariants=[1 / x >= 0]), x >= 0) == "proved"
    assert trajectory(lambda x: [-(1 + x**2)], [1.0], math.pi / 4 - 1e-3)[0].min() > 0


# --------------------------------------------------------------------------- found: real-indexed array
def test_array_read_at_an_ode_variable_is_not_constant():
    """Was proved (dbx with cofactor 0); now refused with a clear error."""
    a = Array("a", REAL)
    # witness: a(r) = 1 - 2r (continuous, even), x(t) = t: a(x(0)) = 1 > 0, a(x(1)) = -1 < 0
    arr = lambda r: 1 - 2 * r  # noqa: E731
    assert arr(Fraction(0)) > 0 and arr(Fraction(1)) < 0
    with pytest.raises(ModelError, match="derivative along the flow is unknown"):
        verdict(And(x == 0, a[x] > 0), ode({x: 1, y: 0}, invariants=[a[x] > 0]), a[x] > 0)
    # an array read at a value the flow does not move stays a constant, as before
    assert verdict(And(x == 0, a[y] > 0), ode({x: 1, y: 0}, invariants=[a[y] > 0]), a[y] > 0) == "proved"


# --------------------------------------------------------------------------- false: through the planner
# name: (pre, program, post, a point of the (exact) run where post fails, explained)
RISE = ode({x: 1, y: 0}, invariants=Y0)  # x(t) = x0 + t exactly
FALSE = {
    "tangency -x^2 >= 0 under x' = 1": (x == 0, RISE, -(x**2) >= 0, lambda: -Fraction(1) ** 2 < 0),
    "x^3 >= 0 under x' = -1": (x == 0, ode({x: -1, y: 0}, invariants=Y0), x**3 >= 0,
                               lambda: Fraction(-1) ** 3 < 0),
    "double root (x-1)^2 <= 0 under x' = 1": (x == 1, RISE, (x - 1) ** 2 <= 0, lambda: Fraction(2) ** 2 > 0),
    "open domain x > -2": (x == -1, ode({x: 1, y: 0}, x > -2, invariants=Y0), x <= 0,
                           lambda: Fraction(-1 + 2) > 0),
    "open disk domain x^2 < 1": (x == 0, ode({x: 1, y: 0}, x**2 < 1, invariants=Y0), x <= Fraction(1, 2),
                                 lambda: Fraction(3, 4) ** 2 < 1 and Fraction(3, 4) > Fraction(1, 2)),
    "guarded c > 0 -> x <= 0, x' = c": (And(x == -1, c == 1), ode({x: c, y: 0}, invariants=Y0),
                                       Implies(c > 0, x <= 0), lambda: Fraction(-1 + 1 * 2) > 0),
    "earlier link x < 0 unproved": (x == -1, ode({x: 1, y: 0}, invariants=[x < 0]), x <= 0,
                                    lambda: Fraction(-1 + 2) > 0),
    "guarantee is not the ODE's post": (x == -1, seq(RISE, assign(x, x - 10)), x <= 0,
                                        lambda: Fraction(-1 + 12 - 10) > 0),
    "!(x = 0)": (x == -1, RISE, Not(x == 0), lambda: Fraction(-1 + 1) == 0),
    "!(x > 0)": (x == -1, RISE, Not(x > 0), lambda: Fraction(-1 + 2) > 0),
    "equality x = 0": (x == 0, RISE, x == 0, lambda: Fraction(0 + 1) != 0),
    "nested modality": (x == -1, test(x <= 0), Box(RISE, x <= 0), lambda: Fraction(-1 + 2) > 0),
    "two ODEs": (x == -1, seq(RISE, RISE), x <= 0, lambda: Fraction(-1 + 1 + 1) > 0),
    "ODE in a loop": (x == -1, loop(seq(assign(x, x + 0), RISE)), x <= 0, lambda: Fraction(-1 + 2) > 0),
    # x' = t, t' = 1 from x = 0, t = -1: x(s) = -s + s^2/2, x(3) = 3/2
    "time-dependent x' = t": (And(x == 0, t == -1), ode({x: t, t: 1}, invariants=[t >= -1]), x <= 0,
                              lambda: -3 + Fraction(9, 2) > 0),
}


@pytest.mark.parametrize("name", list(FALSE))
def test_false_claim_is_not_proved(name):
    pre, prog, post, witness = FALSE[name]
    assert witness()
    assert verdict(pre, prog, post) != "proved"


def test_finite_time_blowup_false_claim_is_not_proved():
    """x' = 1 + x^2 from -1: x = tan(t - pi/4) > 0 after pi/4, long before the pole at 3pi/4."""
    xs = trajectory(lambda x: [1 + x**2], [-1.0], 1.2)[0]
    assert xs.max() > 0.4
    assert math.tan(1.2 - math.pi / 4) > 0.4
    assert verdict(x == -1, ode({x: 1 + x**2}, invariants=[x >= -1]), x <= 0) != "proved"


def test_saddle_weak_level_strict_sign_is_not_proved():
    """y > 0 from (-1, 1/2) under x' = y, y' = x: y' = x < 0 pushes y below 0."""
    ys = trajectory(lambda x, y: [y, x], [-1.0, 0.5], 1.0)[1]
    assert ys.min() < -0.1
    prog = ode({x: y, y: x}, invariants=[y**2 - x**2 >= -1])
    for post in (y > 0, Not(y <= 0), y >= 0):
        assert verdict(And(x == -1, y == 0.5), prog, post) != "proved"


# --------------------------------------------------------------------------- false: the core, chains forced
# a chain chosen by hand (the core must be sound for every chain): each has a link whose rule
# does not apply, so some obligation must stay open. The last entry: a point of the exact run
# x(s) = x0 + v*s (v = x's constant rate) where the post fails.
F = Fraction
FORCED = {
    "barrier -x^2 >= 0, tangent at 0": (x == 0, ode({x: 1, y: 0}), -(x**2) >= 0,
                                        [OdeStep(-(x**2) >= 0, "barrier")], lambda: -(F(0 + 1) ** 2) < 0),
    "barrier x^3 >= 0 under x' = -1": (x == 0, ode({x: -1, y: 0}), x**3 >= 0,
                                       [OdeStep(x**3 >= 0, "barrier")], lambda: F(0 - 1) ** 3 < 0),
    "nonzero x^3 >= 0 under x' = -1": (x == 0, ode({x: -1, y: 0}), x**3 >= 0,
                                       [OdeStep(x**3 >= 0, "nonzero")], lambda: F(0 - 1) ** 3 < 0),
    "barrier -x >= 0, open domain": (x == -1, ode({x: 1, y: 0}, x > -2), x <= 0,
                                     [OdeStep(x <= 0, "barrier")], lambda: F(-1 + 2) > 0),
    "nonzero -x >= 0, open domain": (x == -1, ode({x: 1, y: 0}, x > -2), x <= 0,
                                     [OdeStep(x <= 0, "nonzero")], lambda: F(-1 + 2) > 0),
    "nonzero equality": (x == 0, ode({x: 1, y: 0}), x == 0, [OdeStep(x == 0, "nonzero")],
                         lambda: F(0 + 1) != 0),
    "nonzero !=": (x == -1, ode({x: 1, y: 0}), x != 0, [OdeStep(x != 0, "nonzero")], lambda: F(-1 + 1) == 0),
    "nonzero guarded": (And(x == -1, c == 1), ode({x: c, y: 0}), Implies(c > 0, x <= 0),
                        [OdeStep(Implies(c > 0, x <= 0), "nonzero")], lambda: F(-1 + 1 * 2) > 0),
    "nonzero after an unproved link": (x == -1, ode({x: 1, y: 0}), x <= 0,
                                       [OdeStep(x < 0, "dI"), OdeStep(x <= 0, "nonzero")],
                                       lambda: F(-1 + 2) > 0),
    "barrier after an unproved link": (x == -1, ode({x: 1, y: 0}), x <= 0,
                                       [OdeStep(x < F(-1, 2), "dI"), OdeStep(x <= 0, "barrier")],
                                       lambda: F(-1 + 2) > 0),
    "nonzero, start outside its sign": (x == 1, ode({x: 1, y: 0}, x > 0), x <= 0,
                                        [OdeStep(x <= 0, "nonzero")], lambda: F(1 + 0) > 0),
}


@pytest.mark.parametrize("name", list(FORCED))
def test_forced_chain_does_not_prove_a_false_claim(name):
    pre, prog, post, steps, witness = FORCED[name]
    assert witness()  # the claim is false along the exact run
    assert not planned_all_proved(pre, prog, post, steps)


def test_forced_nonzero_refuses_a_quotient():
    with pytest.raises(ValueError, match="polynomial"):  # annotated: the rule refuses it
        planned_all_proved(x == 1, ode(TAN, x > 0, invariants=[1 / x >= 0]), x >= 0,
                           [OdeStep(1 / x >= 0, "nonzero")])
    with pytest.raises(ValueError, match="polynomial"):  # planned, not annotated: the rule refuses it too
        planned_all_proved(x == 1, ode(TAN), x >= 0, [OdeStep(1 / x >= 0, "nonzero")])


# --------------------------------------------------------------------------- true: the rules should prove
SADDLE = {x: y, y: x}


def test_true_sign_on_a_branch_via_a_negated_guarantee():
    """`!(y < 0)` is read as `y >= 0` and proved by nonzero after y^2 - x^2 >= 1."""
    prog = ode(SADDLE, invariants=[y**2 - x**2 >= 1])
    assert verdict(And(x == 0, y >= 1), prog, Not(y < 0)) == "proved"
    assert verdict(And(x == 0, y >= 1), prog, y > 0) == "proved"
    for y0 in (1.0, 2.0):
        assert trajectory(lambda x, y: [y, x], [0.0, y0], 2.0)[1].min() >= 0.99


def test_true_disconnected_domain_keeps_the_side():
    """[x' = 1 & x^2 > 1] x <= 0 from x = -2: the flow cannot cross [-1, 1] inside the domain;
    exactly x(t) = -2 + t, in the domain only for t < 1, where x < -1."""
    assert verdict(x == -2, ode({x: 1, y: 0}, x**2 > 1, invariants=Y0), x <= 0) == "proved"
    assert all(Fraction(-2) + s < -1 for s in (Fraction(0), Fraction(1, 2), Fraction(99, 100)))


def test_true_barrier_for_nonstrict_forced():
    """x >= 0 under x' = 1 - x*y, y' = -y from x = 0, y = 1: at x = 0, x' = 1 > 0."""
    prog = ode({x: 1 - x * y, y: -y})
    assert planned_all_proved(And(x == 0, y == 1), prog, x >= 0, [OdeStep(x >= 0, "barrier")])
    xs = trajectory(lambda x, y: [1 - x * y, -y], [0.0, 1.0], 5.0)[0]
    assert xs.min() >= -1e-12


def test_true_nonzero_forced_in_a_walled_domain():
    prog = ode({x: 1 + x**2}, x < 0)
    assert planned_all_proved(x == -1, prog, x <= 0, [OdeStep(x <= 0, "nonzero")])
    # x = tan(t - pi/4) < 0 for t < pi/4, when it would leave the domain
    xs = trajectory(lambda x: [1 + x**2], [-1.0], math.pi / 4 - 1e-3)[0]
    assert xs.max() < 0
