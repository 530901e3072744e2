"""The progress rule for `p >= 0` (proofs/core/odes.py): p = 0 -> (f = 0 | p' > 0 | p' = 0 & p'' > 0),
with p and the field f polynomials. It proves what the strict barrier (p = 0 -> p' > 0) cannot:
a boundary the flow touches and leaves again (p' = 0, p'' > 0), and an equilibrium on the
boundary. Every proof here is witnessed by scipy integrating the flow; every false twin must not
prove, and is shown false by an exact point of its polynomial solution."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from certiloop.models import And, Iff, Implies, Not, Or, Reals, Theorem, ode
from certiloop.proofs.core.odes import OdeStep, atom_premise
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine import Prover

x, y = Reals("x y")


def valid(f) -> bool:
    return check_valid(f, 2_000_000).status == "unsat"


def forced(pre, prog, atom, method="progress") -> bool:
    """Every obligation of the one-link chain `atom` by `method` is proved."""
    obs = generate(Theorem("t", pre, prog, atom), {prog.key: (OdeStep(atom, method),)})
    with Prover(jobs=1) as p:
        return all(r.verdict == "proved" for r in p._discharge(obs, None, p.budget))


def path(rhs, start, T):
    blow = lambda _t, s: max(abs(v) for v in s) - 1e6  # noqa: E731
    blow.terminal = True
    sol = solve_ivp(lambda _t, s: rhs(*s), (0.0, T), np.asarray(start, float), method="DOP853",
                    rtol=1e-10, atol=1e-12, dense_output=True, events=blow)
    return sol.sol(np.linspace(0.0, sol.t[-1], 801))


def test_the_premise_is_the_progress_formula():
    prog = ode({x: y, y: x - y})
    premise = atom_premise(y >= 0, prog, "progress")
    # p = y, p' = x - y, p'' = y - (x - y); at rest: y = 0 and x - y = 0
    expected = Implies(y == 0, Or(And(y == 0, x - y == 0), x - y > 0, And(x - y == 0, 2 * y - x > 0)))
    assert valid(Iff(premise, expected))


# x' = y, y' = x^5 - x*y (Dumortier, Llibre, Artes, Qualitative Theory of Planar Differential
# Systems, Ex. 5.2): q = x*y + 4*x^3*y - x^5 >= 0 is kept, then y <= 0, and together they keep
# x + y <= 1. On q = 0 the flow has points with q' = 0 (the strict barrier fails there) where
# q'' > 0, and the origin, an equilibrium.
FIELD = {x: y, y: x**5 - x * y}
Q = x * y + 4 * x**3 * y - x**5


def test_a_touching_boundary_and_an_equilibrium_are_proved_and_witnessed():
    start = And(x > -1, x < Fraction(-1, 2), y < Fraction(-1, 2), y >= -1)
    prog = ode(FIELD, invariants=[Q >= 0, y <= 0])
    with Prover(jobs=1) as p:
        result = p.prove(Theorem("t", start, prog, Not(x + y > 1)), search=False)
    assert result.verdict == "proved"
    assert any("ODE progress" in r.path for r in result.obligations)
    # the strict barrier alone does not give q >= 0: its premise fails at the origin
    assert not valid(atom_premise(Q >= 0, ode(FIELD), "barrier"))
    rhs = lambda x, y: [y, x**5 - x * y]  # noqa: E731
    for x0, y0 in [(-0.99, -0.99), (-0.75, -0.75), (-0.51, -0.99), (-0.99, -0.51), (-0.6, -1.0)]:
        xs, ys = path(rhs, [x0, y0], 5.0)
        assert (xs * ys + 4 * xs**3 * ys - xs**5).min() >= -1e-9
        assert ys.max() <= 1e-9 and (xs + ys).max() <= 1


@pytest.mark.parametrize("claim, start, prog, at_one", [
    # -x^3 >= 0 from x = 0 under x' = 1: p' = p'' = 0 there, p''' < 0 (the weak p'' >= 0 would prove it)
    ("cube", x == 0, ode({x: 1}), lambda: -Fraction(1) ** 3),
    # -x^2 >= 0 under x' = 1, y' = 0: y' = 0 is not rest (one component of f = 0 would prove it)
    ("square", And(x == 0, y == 0), ode({x: 1, y: 0}), lambda: -Fraction(1) ** 2),
    # y >= 0 under x' = 1, y' = x from (-1, 0): y' < 0 at once
    ("leaving", And(x == -1, y == 0), ode({x: 1, y: x}), lambda: Fraction(-1, 2)),
])
def test_false_twins_are_not_proved_and_are_false(claim, start, prog, at_one):
    atom = {"cube": -x**3 >= 0, "square": -x**2 >= 0, "leaving": y >= 0}[claim]
    assert not forced(start, prog, atom)
    with Prover(jobs=1) as p:
        assert p.prove(Theorem(claim, start, prog, atom)).verdict != "proved"
    # the polynomial solution at t = 1 (x = t, or x = t - 1 and y = t^2/2 - t) violates the atom
    assert at_one() < 0


def test_what_the_rule_does_not_cover_is_refused():
    with pytest.raises(ValueError, match="closed"):
        atom_premise(y > 0, ode(FIELD), "progress")
    with pytest.raises(ValueError, match="polynomial"):
        atom_premise(x / (1 + y**2) >= 0, ode(FIELD), "progress")
    with pytest.raises(ValueError, match="polynomial"):
        atom_premise(y >= 0, ode({x: 1, y: x / (1 + x**2)}), "progress")


# --------------------------------------------------------------------------- property
# y' = s*(x - r)^2 + (y - a)*h(x, y) and x' = e + (affine in x - r, y - a): on the boundary y = a,
# y' = s*(x - r)^2 vanishes at x = r, where the strict barrier always fails, and (r, a) is an
# equilibrium when e = 0. Whatever the forced progress link proves about y >= a from a start in
# it must hold along the flow scipy integrates (up to T = 1, or until a coordinate passes 1e6).
small = st.integers(-2, 2)


@given(st.integers(-1, 2), st.sampled_from([0, 0, 1, -1]), st.lists(small, min_size=3, max_size=3),
       st.lists(small, min_size=3, max_size=3), st.fractions(-1, 1, max_denominator=2),
       st.fractions(-1, 1, max_denominator=2), st.fractions(-1, 1, max_denominator=4),
       st.fractions(0, 1, max_denominator=4))
@settings(max_examples=30)
def test_whatever_progress_proves_about_a_half_plane_holds_along_the_flow(s, e, cx, h, r, a, x0, above):
    def fx(u, v):
        return e + cx[0] * (u - r) + cx[1] * (v - a) + cx[2] * (u - r) * (v - a)

    def fy(u, v):
        return s * (u - r) ** 2 + (v - a) * (h[0] + h[1] * u + h[2] * v)

    y0 = a + above
    proved = forced(And(x == x0, y == y0), ode({x: fx(x, y), y: fy(x, y)}), y - a >= 0)
    if s > 0 and e == 0:  # y' > 0 on the boundary but at x = r, which is at rest: the premise holds
        assert proved
    if s < 0:  # y' < 0 on the boundary beside x = r: the premise fails there
        assert not proved
    if proved:
        xs, ys = path(lambda u, v: [float(fx(u, v)), float(fy(u, v))], [float(x0), float(y0)], 1.0)
        assert ys.min() >= float(a) - 1e-7, (s, e, cx, h, r, a, x0, y0)


def test_the_strict_barrier_fails_where_progress_holds():
    # the property's family at s = 1, e = 0: the barrier's premise fails at the resting point
    prog = ode({x: y, y: x * x + y * (1 + x)})
    assert forced(And(x == 0, y == 0), prog, y >= 0)
    assert not forced(And(x == 0, y == 0), prog, y >= 0, "barrier")
