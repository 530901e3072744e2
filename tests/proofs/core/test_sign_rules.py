"""Rules that keep a sign: nonzero (a polynomial that never vanishes inside the domain and
the links proved before it keeps the sign it starts with, so `p >= 0` is invariant even where
p' has no sign) and the strict barrier for `p >= 0` (p = 0 -> p' > 0).

Every proof here is witnessed by scipy integrating the flow from sampled starts; every false
twin must not prove, and is shown false by integration or by an exact point."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from certiloop.models import And, Iff, Reals, Theorem, ode
from certiloop.proofs.core.odes import OdeStep, atom_premise
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine import Prover

x, y = Reals("x y")
# x' = y, y' = x: y^2 - x^2 is a first integral, and its level sets y^2 - x^2 = c > 0 have two
# branches, y > 0 and y < 0; a flow stays on the branch it starts on. y' = x has no sign, so
# neither dI nor a Darboux cofactor shows y >= 0.
SADDLE = {x: y, y: x}


def verdict(pre, program, post) -> str:
    with Prover(jobs=1) as p:
        return p.prove(Theorem("t", pre, program, post), search=False).verdict


def min_along(rhs, start, T=2.0, coord=1) -> float:
    sol = solve_ivp(lambda _t, s: rhs(*s), (0.0, T), np.asarray(start, float), method="DOP853",
                    rtol=1e-10, atol=1e-12, dense_output=True)
    assert sol.success
    return float(sol.sol(np.linspace(0.0, T, 401))[coord].min())


def test_premise_is_that_p_never_vanishes_and_quotients_are_refused():
    saddle = ode(SADDLE)
    for atom, nonzero in ((y >= 0, y != 0), (x <= 0, x != 0), (x + y > 1, x + y != 1)):
        premise = atom_premise(atom, saddle, "nonzero")
        assert check_valid(Iff(premise, nonzero), 100_000).status == "unsat", (atom, premise)
    with pytest.raises(ValueError, match="polynomial"):
        atom_premise(x / y >= 0, saddle, "nonzero")  # x/y need not be continuous where y = 0


def test_sign_kept_on_one_branch_of_a_level_set_and_witnessed():
    """From y >= 1, x = 0 the flow keeps y^2 - x^2 >= 1 (annotated, a Darboux identity), hence
    y != 0, hence y >= 0: proved by the planner's nonzero link, checked by integration."""
    prog = ode(SADDLE, invariants=[y**2 - x**2 >= 1])
    assert verdict(And(x == 0, y >= 1), prog, y >= 0) == "proved"
    for y0 in (1.0, 1.5, 3.0):
        assert min_along(lambda x, y: [y, x], [0.0, y0]) >= 0.99


def test_without_the_separating_invariant_the_sign_claim_is_not_proved():
    """The weaker level y^2 - x^2 >= -1 lets the flow through y = 0: from (x, y) = (-1, 1/2)
    y' = x < 0 pushes y below 0, and the claim is false."""
    prog = ode(SADDLE, invariants=[y**2 - x**2 >= -1])
    assert verdict(And(x == -1, y == 0.5), prog, y >= 0) != "proved"
    assert min_along(lambda x, y: [y, x], [-1.0, 0.5], T=1.0) < -0.1  # really false


def test_a_flow_through_zero_is_not_proved_by_a_forced_nonzero_link():
    """x' = 1 from x = -1 crosses x = 0 at t = 1: the link's premise `-x != 0` is false at
    x = 0 (an exact counterexample), so the planned chain proves nothing."""
    rise = ode({x: 1, y: 0})
    premise = atom_premise(x <= 0, rise, "nonzero")
    answer = check_valid(premise, 1_000_000)
    assert answer.status == "sat" and answer.model["x"] == 0
    obs = generate(Theorem("t", x == -1, rise, x <= 0), {rise.key: (OdeStep(x <= 0, "nonzero"),)})
    with Prover(jobs=1) as p:
        assert any(r.verdict != "proved" for r in p._discharge(obs, None, p.budget))
    assert -1 + 1.5 > 0  # x(1.5) = 1/2 violates x <= 0


def test_the_domain_separates_the_signs():
    """[x' = 1 & x != 0] x <= 0 from x = -1/2 holds in dL: the flow must stay in the domain,
    so it stops before x = 0; the nonzero premise uses exactly that domain."""
    steps = (OdeStep(x <= 0, "nonzero"),)
    walled = ode({x: 1, y: 0}, x != 0)
    obs = generate(Theorem("t", x == -0.5, walled, x <= 0), {walled.key: steps})
    with Prover(jobs=1) as p:
        assert all(r.verdict == "proved" for r in p._discharge(obs, None, p.budget))


# --------------------------------------------------------------------------- barrier for >=
# x' = -x - y^3, y' = x - y: on the unit circle d/dt(x^2 + y^2) = -2 + 2x^3 y < 0, yet inside
# it need not be negative and outside it is positive in places; at radius 4 the flow leaves.
SPIRAL = {x: -x - y**3, y: x - y}


def spiral(_t, s):
    return [-s[0] - s[1] ** 3, s[0] - s[1]]


def test_a_closed_disk_is_kept_by_the_strict_barrier_and_witnessed():
    prog = ode(SPIRAL, invariants=[x**2 + y**2 <= 1])
    with Prover(jobs=1) as p:
        result = p.prove(Theorem("t", x**2 + y**2 <= 0.5, prog, x**2 + y**2 <= 1), search=False)
    assert result.verdict == "proved"
    assert any(o.path.startswith("ODE barrier 1") for o in result.obligations)
    rng = np.random.default_rng(5)
    for _ in range(8):
        r, th = 0.5**0.5 * rng.uniform(0, 1), rng.uniform(0, 2 * np.pi)
        sol = solve_ivp(spiral, (0, 4), [r * np.cos(th), r * np.sin(th)], rtol=1e-10, atol=1e-12,
                        dense_output=True)
        xs, ys = sol.sol(np.linspace(0, 4, 401))
        assert (xs**2 + ys**2).max() <= 1 + 1e-9


def test_a_disk_the_flow_leaves_is_not_proved():
    """Radius 4: at (-2.8, 2.8) d/dt(x^2 + y^2) = -31.36 + 2*(-7.84)*(1 - 7.84) > 0; the
    boundary premise fails there and integration shows the flow outside the disk."""
    prog = ode(SPIRAL, invariants=[x**2 + y**2 <= 16])
    assert verdict(And(x == -2.8, y == 2.8), prog, x**2 + y**2 <= 16) != "proved"
    sol = solve_ivp(spiral, (0, 0.05), [-2.8, 2.8], rtol=1e-10, atol=1e-12, dense_output=True)
    xs, ys = sol.sol(np.linspace(0, 0.05, 101))
    assert (xs**2 + ys**2).max() > 16


# --------------------------------------------------------------------------- properties
# x' = c0 + c1 x + c2 x^2 + c3 x^3 (y rides along, y' = 0): whatever a forced barrier or nonzero
# link proves about `x - a >= 0` from x = x0 must hold along the flow, integrated by scipy (up to
# T = 1, or until |x| passes 1e6: a blow-up ends the run; inside a domain, until it is left).
coefficient = st.integers(-3, 3)
point = st.fractions(-2, 2, max_denominator=4)


def _forced_all_proved(pre, prog, atom, method) -> bool:
    obs = generate(Theorem("t", pre, prog, atom), {prog.key: (OdeStep(atom, method),)})
    with Prover(jobs=1) as p:
        return all(r.verdict == "proved" for r in p._discharge(obs, None, p.budget))


def _run(cs, x0, stay=lambda x: True, T=1.0):
    """x along the flow from x0 until T, a blow-up, or the first sample outside `stay`."""
    rhs = lambda _t, s: [cs[0] + cs[1] * s[0] + cs[2] * s[0] ** 2 + cs[3] * s[0] ** 3]  # noqa: E731
    blow = lambda _t, s: abs(s[0]) - 1e6  # noqa: E731
    blow.terminal = True
    sol = solve_ivp(rhs, (0.0, T), [float(x0)], method="DOP853", rtol=1e-10, atol=1e-12,
                    dense_output=True, events=blow)
    xs = sol.sol(np.linspace(0.0, sol.t[-1], 401))[0]
    inside = [stay(v) for v in xs]
    return xs[: inside.index(False)] if False in inside else xs


@given(st.lists(coefficient, min_size=4, max_size=4), point, st.fractions(0, 2, max_denominator=4))
@settings(max_examples=30)
def test_whatever_the_barrier_proves_about_a_half_line_holds_along_the_flow(cs, a, above):
    x0 = a + above
    prog = ode({x: cs[0] + cs[1] * x + cs[2] * x**2 + cs[3] * x**3, y: 0})
    if _forced_all_proved(x == x0, prog, x - a >= 0, "barrier"):
        assert sum(c * a**k for k, c in enumerate(cs)) > 0  # the premise: x' > 0 at x = a
        assert (_run(cs, x0) >= float(a) - 1e-7).all()


@given(st.lists(coefficient, min_size=4, max_size=4), point, st.fractions(-1, 1, max_denominator=4),
       st.fractions(0, 2, max_denominator=4))
@settings(max_examples=30)
def test_whatever_nonzero_proves_inside_a_domain_holds_along_the_flow(cs, a, gap, above):
    """Domain x >= b: where b > a it excludes x = a and the link is proved from any start in
    it; where b <= a it does not, and the link must not be proved (x = a is in the domain)."""
    b, x0 = a + gap, a + gap + above
    prog = ode({x: cs[0] + cs[1] * x + cs[2] * x**2 + cs[3] * x**3, y: 0}, x >= b)
    proved = _forced_all_proved(x == x0, prog, x - a >= 0, "nonzero")
    assert proved == (b > a)
    if proved:
        assert (_run(cs, x0, stay=lambda v: v >= float(b) - 1e-12) >= float(a)).all()
