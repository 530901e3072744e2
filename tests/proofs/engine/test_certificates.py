"""SOS certificates (proofs/engine/certificates.py): an SDP proposes `V <= c`, the core decides.

Each true theorem here is proved only thanks to a synthesised certificate (not proved with the
proposer disabled) and checked by an independent witness: scipy integrates the flow from
initial states (a grid of the initial box, corners included) and the guarantee must hold along
it. Near misses that scipy shows false must not prove; perturbed certificates (rounding
garbage) are refused by the core's exact check; the proposer gives [] for what it cannot handle.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from certiloop.models import And, Reals, Theorem, ode
from certiloop.proofs.core.odes import OdeStep
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine import Prover, certificates
from certiloop.proofs.engine.certificates import certificate_atoms, certificate_steps

x, y, z, w, v, a = Reals("x y z w v a")
HALF = Fraction(1, 2)


def box(b):
    """|x| <= 1/2, |y| <= b."""
    return And(x <= HALF, x >= -HALF, y <= b, y >= -b)


def verdict(pre, program, post) -> str:
    with Prover(jobs=1) as p:
        return p.prove(Theorem("t", pre, program, post), search=False).verdict


def max_x(rhs, b, T=8.0, y_max=None) -> float:
    """The largest x along the flows from a 5 x 9 grid of the box (corners included), each
    stopped where it leaves the domain y <= y_max if one is given."""
    best = -np.inf
    leaves = None
    if y_max is not None:
        def leaves(_t, s):
            return s[1] - float(y_max)
        leaves.terminal = True
    for x0 in np.linspace(-0.5, 0.5, 5):
        for y0 in np.linspace(-float(b), float(b), 9):
            sol = solve_ivp(lambda _t, s: rhs(*s), (0.0, T), [x0, y0], method="DOP853",
                            rtol=1e-9, atol=1e-12, dense_output=True, events=leaves)
            assert sol.success
            best = max(best, sol.sol(np.linspace(0.0, sol.t[-1], 801))[0].max())
    return best


DAMPED = (ode({x: y, y: -2 * x - y}), lambda x, y: [y, -2 * x - y])
DUFFING = (ode({x: y, y: -x - x**3 - y}), lambda x, y: [y, -x - x**3 - y])
QUADRATIC = (ode({x: -x + x * y, y: -y - x**2}), lambda x, y: [-x + x * y, -y - x**2])
# reversed Van der Pol: stable only inside its limit cycle, so no V decreases everywhere
VDP = (ode({x: -y, y: x + (x**2 - 1) * y}), lambda x, y: [-y, x + (x**2 - 1) * y])

# (system, b of the initial box); the guarantee is x <= 1
TRUE_CASES = [
    pytest.param(DAMPED, Fraction(1), id="damped oscillator, V of degree 2"),  # scipy: max x = 0.76
    pytest.param(DUFFING, Fraction(1), id="damped Duffing oscillator, V of degree 4"),  # max x = 0.81
    # a level set of the linearisation's V, kept by dbx with the SDP's cofactor g
    pytest.param(VDP, HALF, id="reversed Van der Pol, level set and cofactor"),  # max x = 0.66
    # near the limit (scipy: max x = 0.96), degree 2 fails; an 8-term quartic V proves it
    pytest.param(DAMPED, Fraction(3, 2), id="damped oscillator, V of degree 4", marks=pytest.mark.slow),
    pytest.param(QUADRATIC, Fraction(6, 5), id="quadratic field, V of degree 2", marks=pytest.mark.slow),
]
FALSE_CASES = [  # the same systems from a slightly bigger box: some flow passes x = 1
    pytest.param(DAMPED, Fraction(2), id="damped oscillator"),  # scipy: max x = 1.17
    pytest.param(DUFFING, Fraction(3, 2), id="damped Duffing oscillator"),  # scipy: max x = 1.004
    pytest.param(VDP, Fraction(3, 2), id="reversed Van der Pol"),  # scipy: max x = 1.51
]


@pytest.mark.parametrize("case, b", TRUE_CASES)
def test_proved_only_with_a_certificate_and_witnessed(case, b, monkeypatch):
    system, rhs = case
    assert verdict(box(b), system, x <= 1) == "proved"
    assert max_x(rhs, b) <= 1
    monkeypatch.setattr(certificates, "certificate_steps", lambda theorem, ode: [])
    assert verdict(box(b), system, x <= 1) != "proved"


@pytest.mark.parametrize("case, b", FALSE_CASES)
def test_near_miss_is_not_proved_and_really_false(case, b):
    system, rhs = case
    assert verdict(box(b), system, x <= 1) != "proved"
    assert max_x(rhs, b) > 1


@pytest.mark.slow
@settings(max_examples=12, deadline=None)
@given(st.integers(1, 3), st.integers(-3, 3), st.integers(-3, 3), st.integers(1, 3),
       st.sampled_from([Fraction(1, 4), Fraction(1, 2)]))
def test_whatever_a_certificate_proves_holds_along_the_flow(p, q, s, u, r):
    """Random linear systems x' = -p x + q y, y' = s x - u y (mostly stable, mostly
    beyond the Darboux polynomials) from the disc of radius r: if x <= 1 is proved, scipy
    agrees from points of the disc's boundary (an independent witness)."""
    system = ode({x: -p * x + q * y, y: s * x - u * y})
    if verdict(x**2 + y**2 <= r * r, system, x <= 1) != "proved":
        return
    for angle in np.linspace(0.0, 2 * np.pi, 24, endpoint=False):
        start = [float(r) * np.cos(angle), float(r) * np.sin(angle)]
        sol = solve_ivp(lambda _t, z: [-p * z[0] + q * z[1], s * z[0] - u * z[1]], (0.0, 10.0), start,
                        rtol=1e-10, atol=1e-12, dense_output=True)
        assert sol.sol(np.linspace(0.0, 10.0, 1001))[0].max() <= 1 + 1e-9


DOMAIN_RHS = lambda x, y: [y, -2 * x - y + y**2]  # noqa: E731


def test_the_domain_is_assumed_where_the_flow_runs(monkeypatch):
    """x' = y, y' = -2x - y + y^2: V' = 2y^2 (y - 1) for V = 2x^2 + y^2, nonpositive only
    where y <= 1, the domain; the SDP uses it (S-procedure) and proves x <= 1 from the box
    |x|, |y| <= 1/2 (scipy: flows stopped where they leave the domain keep x <= 0.6)."""
    system = ode({x: y, y: -2 * x - y + y**2}, y <= 1)
    assert verdict(box(HALF), system, x <= 1) == "proved"
    assert max_x(DOMAIN_RHS, HALF, y_max=1) <= 1
    monkeypatch.setattr(certificates, "certificate_steps", lambda theorem, ode: [])
    assert verdict(box(HALF), system, x <= 1) != "proved"


@pytest.mark.slow
def test_a_looser_domain_is_not_proved_and_really_false():
    """The same field in the domain y <= 2 from |y| <= 1: scipy finds x = 1.06 > 1 before
    the flow leaves the domain."""
    loose = ode({x: y, y: -2 * x - y + y**2}, y <= 2)
    assert verdict(box(1), loose, x <= 1) != "proved"
    assert max_x(DOMAIN_RHS, 1, y_max=2) > 1


# ----------------------------------------------------------------- the exact check decides

CERTIFICATE = y**2 + 2 * x**2 + x * y <= 1  # what the SDP gives the damped oscillator from x^2+y^2 <= 1/4


def derivative_proved(atom, system) -> bool:
    """The core's dI premise for the atom alone (V' <= 0 everywhere), discharged by z3."""
    theorem = Theorem("t", x**2 + y**2 <= Fraction(1, 4), system, x <= 1)
    obs = [o for o in generate(theorem, {system.key: (OdeStep(atom),)}) if "derivative" in o.path]
    with Prover(jobs=1) as p:
        return all(r.verdict == "proved" for r in p._discharge(obs, None, p.budget))


def exactly_decreasing(p_xx, p_xy, p_yy) -> bool:
    """-V' >= 0 for V = p_xx x^2 + p_xy xy + p_yy y^2 under the damped oscillator, by sympy:
    -V' is a quadratic form, nonnegative iff its matrix is positive semidefinite."""
    X, Y = sympy.symbols("X Y")
    V = p_xx * X**2 + p_xy * X * Y + p_yy * Y**2
    dV = sympy.expand(sympy.diff(V, X) * Y + sympy.diff(V, Y) * (-2 * X - Y))
    M = sympy.Matrix([[-dV.coeff(X, 2), -dV.coeff(X, 1).coeff(Y, 1) / 2],
                      [-dV.coeff(X, 1).coeff(Y, 1) / 2, -dV.coeff(Y, 2)]])
    return bool(M.is_positive_semidefinite)


def test_the_certificate_and_garbage_near_it(monkeypatch):
    system, rhs = DAMPED
    assert derivative_proved(CERTIFICATE, system) and exactly_decreasing(2, 1, 1)
    garbage = x**2 + x * y + y**2 <= 1  # one coefficient rounded badly: V' is indefinite
    assert not derivative_proved(garbage, system) and not exactly_decreasing(1, 1, 1)
    # and V really grows along the flow from a point where -V' = 2x^2 + 3xy + y^2 < 0
    sol = solve_ivp(lambda _t, s: rhs(*s), (0.0, 0.05), [1.0, -1.5], rtol=1e-10, atol=1e-12)
    V = sol.y[0] ** 2 + sol.y[0] * sol.y[1] + sol.y[1] ** 2
    assert V[-1] > V[0]
    # fed to the planner in place of the SDP's answer, garbage proves nothing
    monkeypatch.setattr(certificates, "certificate_steps", lambda theorem, ode: [OdeStep(garbage)])
    assert verdict(x**2 + y**2 <= Fraction(1, 4), system, x <= 1) != "proved"


def test_the_level_set_needs_its_own_cofactor():
    """Under reversed Van der Pol the SDP gives V <= 1 with V = 13/10 x^2 - 4/5 xy + y^2 and
    g = -1/2 + x^2 + y^2 - xy/2: V' is positive far away, so dI fails; dbx with g proves it
    (-V' >= g (1 - V) everywhere); a perturbed g does not."""
    system = VDP[0]
    theorem = Theorem("t", box(HALF), system, x <= 1)
    [step] = certificate_steps(theorem, system)
    assert step.method == "dbx" and str(step.atom) == "y^2 + 13*x^2/10 + (-4)*x*y/5 <= 1"

    def premise(step):
        obs = [o for o in generate(theorem, {system.key: (step,)}) if "derivative" in o.path]
        with Prover(jobs=1) as p:
            return all(r.verdict == "proved" for r in p._discharge(obs, None, p.budget))

    assert premise(step)
    assert not premise(OdeStep(step.atom))
    assert not premise(OdeStep(step.atom, "dbx", step.cofactor + 2 * x * y))


@settings(max_examples=8, deadline=None)
@given(st.fractions(1, 3, max_denominator=4), st.fractions(-2, 2, max_denominator=4),
       st.fractions(Fraction(1, 2), 2, max_denominator=4))
def test_a_perturbed_certificate_counts_only_if_exactly_valid(p_xx, p_xy, p_yy):
    atom = p_xx * x**2 + p_xy * x * y + p_yy * y**2 <= 1
    if derivative_proved(atom, DAMPED[0]):
        assert exactly_decreasing(p_xx, p_xy, p_yy)


# ----------------------------------------------------------------- the proposer itself


def test_proposals_are_deterministic_and_only_wanted_when_the_rest_fails(monkeypatch):
    system = DAMPED[0]
    theorem = Theorem("t", x**2 + y**2 <= Fraction(1, 4), system, x <= 1)
    first = [str(a) for a in certificate_atoms(theorem, system)]
    monkeypatch.setattr(certificates, "_cache", {})
    assert [str(a) for a in certificate_atoms(theorem, system)] == first
    assert first[0] == str(CERTIFICATE)
    calls = []
    monkeypatch.setattr(certificates, "certificate_steps", lambda th, o: calls.append(o) or [])
    assert verdict(x > 0, ode({x: -x}), x > 0) == "proved"  # solved: no search
    assert verdict(box(HALF), QUADRATIC[0], x <= 1) == "proved"  # the first search suffices
    assert calls == []


def test_negations_are_pushed_in():
    """KeYmaera X's guarantees read !(p <= 0) and !(a | b): the same certificate as x <= 1."""
    from certiloop.models import Not, Or

    system = DAMPED[0]
    plain = certificate_atoms(Theorem("t", x**2 + y**2 <= Fraction(1, 4), system, x <= 1), system)
    for post in (Not(x - 1 > 0), Not(Or(x > 1, y > 3))):
        got = certificate_atoms(Theorem("t", x**2 + y**2 <= Fraction(1, 4), system, post), system)
        assert [str(a) for a in got] == [str(a) for a in plain]


@pytest.mark.parametrize("pre, system, post", [
    (x**2 <= 1, ode({x: -x / (1 + y**2), y: -y}), x <= 2),  # not polynomial
    (And(x**2 <= 1, a >= 1), ode({x: -a * x}), x <= 2),  # a parameter
    (x**2 <= 1, ode({x: -x, y: -y, z: -z, w: -w, v: -v}), x <= 2),  # five variables
    (x**2 <= 1, ode({x: -(x**5)}), x <= 2),  # degree 5
    (a <= 1, ode({x: -x}), x <= 2),  # no initial set in x
    (And(x**2 <= 1, a <= 1), ode({x: -x}), a <= 2),  # no guarantee in x
    (x**2 <= 4, ode({x: y, y: -2 * x - y}), x <= 1),  # false at the start: infeasible
])
def test_nothing_proposed_out_of_reach(pre, system, post):
    assert certificate_atoms(Theorem("t", pre, system, post), system) == []


@pytest.mark.parametrize("error", ["solver", "other"])
def test_a_failing_solver_proposes_nothing(error, monkeypatch):
    import cvxpy

    def fail(*args, **kwargs):
        raise cvxpy.error.SolverError("no") if error == "solver" else RuntimeError("boom")

    monkeypatch.setattr(certificates, "_cache", {})
    monkeypatch.setattr(cvxpy.Problem, "solve", fail)
    system = DAMPED[0]
    assert certificate_atoms(Theorem("t", x**2 + y**2 <= Fraction(1, 4), system, x <= 1), system) == []
