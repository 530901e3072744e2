"""Darboux polynomials of nonlinear polynomial ODEs (proofs/engine/darboux_search.py).

The search proposes `p > 0`, `p >= 0`, `p = c`, ...; the core proves each by its exact Darboux
identity or drops it. Each true theorem here is proved only thanks to the search (not proved
with the search disabled) and checked by an independent witness: scipy integrates the flow from
initial states (a grid of the initial box, corners included) and the guarantee must hold along
it. Every polynomial the search returns satisfies p' = g*p identically (sympy), and the core
refuses a perturbed one.
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
from certiloop.models.lang.terms import cmp
from certiloop.proofs.core.odes import cofactors, darboux_identity
from certiloop.proofs.core.symbolic import SympyTable, from_sympy
from certiloop.proofs.engine import Prover, darboux_search
from certiloop.proofs.engine.darboux_search import darboux_polynomials, lie, search_atoms

x, y, z = Reals("x y z")
X, Y, Z = sympy.symbols("X Y Z")


def verdict(pre, program, post) -> str:
    with Prover(jobs=1) as p:
        return p.prove(Theorem("t", pre, program, post), search=False).verdict


def always(rhs, starts, holds, T: float = 10.0, bound: float = 1e3) -> bool:
    """scipy: the guarantee holds at 2,001 times along the flow from every start until T or
    until |state| reaches `bound` (some of these flows blow up in finite time, and far out a
    float cannot tell x^2 + 1 from x^2); False as soon as it fails at one."""
    def far(_t, s):
        return np.max(np.abs(s)) - bound
    far.terminal = True
    for s0 in starts:
        sol = solve_ivp(lambda _t, s: rhs(*s), (0.0, T), s0, method="DOP853", rtol=1e-10, atol=1e-12,
                        dense_output=True, events=far)
        states = sol.sol(np.linspace(0.0, sol.t[-1], 2001))
        if not np.all(holds(*states)):
            return False
        assert sol.success
    return True


def grid(*ranges, k: int = 5) -> list[list[float]]:
    """A k^n grid of the box, corners included."""
    axes = [np.linspace(float(lo), float(hi), k) for lo, hi in ranges]
    return [list(p) for p in np.array(np.meshgrid(*axes)).reshape(len(ranges), -1).T]


LV = ode({x: x * (1 - y), y: y * (x - 1)})  # Lotka-Volterra: x and y are Darboux polynomials
LV_RHS = lambda x, y: [x * (1 - y), y * (x - 1)]  # noqa: E731
QUAD = ode({x: 2 * x - 2 * x * y, y: -x**2 + 2 * y + y**2})  # x^2 - 3y^2, cofactor 2y + 4
QUAD_RHS = lambda x, y: [2 * x - 2 * x * y, -x**2 + 2 * y + y**2]  # noqa: E731
CYCLE = ode({x: -y + x * (x**2 + y**2 - 1), y: x + y * (x**2 + y**2 - 1)})  # x^2+y^2-1, cofactor 2(x^2+y^2)
CYCLE_RHS = lambda x, y: [-y + x * (x**2 + y**2 - 1), x + y * (x**2 + y**2 - 1)]  # noqa: E731
ENERGY = ode({x: y, y: -x - x**2})  # first integral x^2/2 + x^3/3 + y^2/2, of degree 3
ENERGY_RHS = lambda x, y: [y, -x - x**2]  # noqa: E731
ROCK = ode({x: x * y - x * z, y: y * z - y * x, z: z * x - z * y})  # x, y, z and x + y + z
ROCK_RHS = lambda x, y, z: [x * y - x * z, y * z - y * x, z * x - z * y]  # noqa: E731
H = Fraction(1, 2)

CASES = [  # (pre, system, post, rhs, starts, witness)
    pytest.param(And(x >= H, x <= 2, y >= H, y <= 2), LV, x + y >= 0, LV_RHS, grid((H, 2), (H, 2)),
                 lambda x, y: x + y >= 0, id="Lotka-Volterra from a box: x >= 0, y >= 0"),
    pytest.param(And(x == 1, y == 2), LV, x + y > 0, LV_RHS, [[1.0, 2.0]], lambda x, y: x + y > 0,
                 id="Lotka-Volterra from a point: x > 0, y > 0"),
    pytest.param(And(x == 1, y == 0), QUAD, x**2 + 1 > 3 * y**2, QUAD_RHS, [[1.0, 0.0]],
                 lambda x, y: x**2 + 1 > 3 * y**2, id="quadratic Darboux polynomial, cofactor 2y + 4"),
    pytest.param(And(x >= 2, x <= 3, y >= -H, y <= H), QUAD, x**2 + 1 >= 3 * y**2, QUAD_RHS,
                 grid((2, 3), (-H, H)), lambda x, y: x**2 + 1 >= 3 * y**2, id="quadratic, from a box",
                 marks=pytest.mark.slow),
    pytest.param(And(x == 2, y == 0), CYCLE, x**2 + y**2 >= H, CYCLE_RHS, [[2.0, 0.0]],
                 lambda x, y: x**2 + y**2 >= 0.5, id="outside a limit cycle: cofactor 2(x^2+y^2)"),
    pytest.param(And(x == Fraction(1, 4), y == 0), ENERGY, x <= 1, ENERGY_RHS, [[0.25, 0.0]],
                 lambda x, y: x <= 1, id="a cubic first integral at its start value"),
    pytest.param(And(x >= 0, x <= Fraction(1, 4), y == 0), ENERGY, x <= 1, ENERGY_RHS,
                 grid((0, Fraction(1, 4)), (0, 0)), lambda x, y: x <= 1,
                 id="a cubic first integral below its range over the initial box"),
    pytest.param(And(x == 1, y == 2, z == 3), ROCK, x <= 6, ROCK_RHS, [[1.0, 2.0, 3.0]],
                 lambda x, y, z: x <= 6, id="3 variables: x + y + z = 6, y > 0, z > 0"),
]


@pytest.mark.parametrize("pre, system, post, rhs, starts, witness", CASES)
def test_proved_only_with_the_search_and_witnessed(pre, system, post, rhs, starts, witness, monkeypatch):
    assert verdict(pre, system, post) == "proved"
    assert always(rhs, starts, witness)
    monkeypatch.setattr(darboux_search, "search_atoms", lambda theorem, ode: [])
    import certiloop.proofs.engine.odeplan as odeplan

    monkeypatch.setattr(odeplan, "search_atoms", lambda theorem, ode: [])
    assert verdict(pre, system, post) != "proved"


def test_near_misses_are_not_proved_and_really_false():
    """Starts on the wrong side of the Darboux polynomial: the claim is false (scipy) and
    the search's atoms, dropped for failing at the start, prove nothing."""
    assert verdict(And(x == 1, y == 1), QUAD, x**2 + 1 > 3 * y**2) != "proved"  # 2 > 3 at the start
    assert not always(QUAD_RHS, [[1.0, 1.0]], lambda x, y: x**2 + 1 > 3 * y**2, T=0.1)
    assert verdict(And(x == H, y == 0), CYCLE, x**2 + y**2 >= H) != "proved"  # inside: spirals to 0
    assert not always(CYCLE_RHS, [[0.5, 0.0]], lambda x, y: x**2 + y**2 >= 0.5)
    assert verdict(And(x == 1, y == -1), LV, x + y >= 1) != "proved"
    assert not always(LV_RHS, [[1.0, -1.0]], lambda x, y: x + y >= 1, T=1.0)


# ----------------------------------------------------------------- what the search returns


def field(*exprs, gens=(X, Y)):
    return [sympy.Poly(e, *gens, domain=sympy.QQ) for e in exprs]


@pytest.mark.parametrize("exprs, gens, expected", [
    ((X * (1 - Y), Y * (X - 1)), (X, Y), {X, Y}),
    ((-Y + X * (X**2 + Y**2 - 1), X + Y * (X**2 + Y**2 - 1)), (X, Y), {X**2 + Y**2 - 1}),
    ((2 * X - 2 * X * Y, -X**2 + 2 * Y + Y**2), (X, Y), {X, X**2 - 3 * Y**2}),
    ((Y, -X - X**2), (X, Y), {2 * X**3 + 3 * X**2 + 3 * Y**2}),
    ((X * Y - X * Z, Y * Z - Y * X, Z * X - Z * Y), (X, Y, Z), {X, Y, Z, X + Y + Z}),
])
def test_known_darboux_polynomials_are_found(exprs, gens, expected):
    found = {p.as_expr() for p, _ in darboux_polynomials(field(*exprs, gens=gens), list(gens))}
    assert expected <= found


def test_a_first_integral_is_proposed_once_whatever_its_constant():
    """p and p - 50 are both first integrals of x' = -(y+5)^2, y' = 8(x-20)(y+5) (p - 50
    comes as a factor of the Darboux polynomial (y + 5)(p - 50)); one is kept."""
    found = darboux_polynomials(field(-Y**2 - 10 * Y - 25, 8 * X * Y + 40 * X - 160 * Y - 800), [X, Y])
    assert [(p.as_expr(), g.as_expr()) for p, g in found] == [
        (Y + 5, 8 * X - 160), (8 * X**2 - 320 * X + Y**2 + 10 * Y, 0)]


def test_nothing_for_affine_parametric_or_non_polynomial_fields():
    a = Reals("a")[0]
    affine = ode({x: -x + y, y: -2 * y})
    assert search_atoms(Theorem("t", x > 0, affine, x > 0), affine) == []
    parametric = ode({x: a * x * y, y: -y})
    assert search_atoms(Theorem("t", x > 0, parametric, x > 0), parametric) == []
    divided = ode({x: x / (1 + y**2), y: -y})
    assert search_atoms(Theorem("t", x > 0, divided, x > 0), divided) == []


def test_no_darboux_polynomial_gives_nothing_cheaply():
    """Van der Pol has no Darboux polynomial of degree <= 3: the search returns [] (its size is
    bounded by counts, so this is also a bound on its work)."""
    assert darboux_polynomials(field(Y, -X + (1 - X**2) * Y), [X, Y]) == []


def test_deterministic_same_candidates_same_order():
    theorem = Theorem("t", And(x == 1, y == 2, z == 3), ROCK, x <= 6)
    darboux_search._cache.clear()
    first = [a.key for a in search_atoms(theorem, ROCK)]
    darboux_search._cache.clear()
    assert [a.key for a in search_atoms(theorem, ROCK)] == first
    assert [str(a) for a in search_atoms(theorem, ROCK)][:4] == ["x > 0", "y > 0", "z > 0", "x + y + z = 6"]


def test_atoms_follow_the_range_over_the_initial_box():
    """The start's sign when the box decides it, both signs when it does not; a first
    integral gets the enclosure of its values (interval arithmetic, so wider, never narrower)."""
    def atoms(pre, system):
        return [str(a) for a in search_atoms(Theorem("t", pre, system, x > 0), system)]

    assert atoms(And(x >= H, x <= 2, y >= H, y <= 2), LV) == ["x > 0", "y > 0"]
    assert atoms(And(x >= 0, x <= 2, y <= -1), LV) == ["x >= 0", "y < 0"]
    assert atoms(x**2 + y**2 <= 1, LV) == ["x >= 0", "x <= 0", "y >= 0", "y <= 0"]
    # 2x^3 + 3x^2 + 3y^2 over x in [0, 1/4], y = 0: [0, 2/64 + 3/16]
    assert atoms(And(x >= 0, x <= Fraction(1, 4), y == 0), ENERGY) == [
        "2*x^3 + 3*x^2 + 3*y^2 >= 0", "2*x^3 + 3*x^2 + 3*y^2 <= 7/32"]


# ----------------------------------------------------------------- the exact check decides


def _planted(p, A, B1, B2):
    """f = A*(-p_y, p_x) + p*(B1, B2): p' = p*(B1 p_x + B2 p_y), so p is Darboux."""
    return [A * -sympy.diff(p, Y) + p * B1, A * sympy.diff(p, X) + p * B2]


small = st.integers(-2, 2)


def poly_of(cs, degree):
    monomials = [X**i * Y**j for i in range(degree + 1) for j in range(degree + 1 - i)]
    return sum(c * m for c, m in zip(cs, monomials))


@settings(max_examples=25, deadline=None)
@given(st.lists(small, min_size=6, max_size=6), st.lists(small, min_size=3, max_size=3),
       st.lists(small, min_size=3, max_size=3), st.lists(small, min_size=3, max_size=3))
def test_every_returned_polynomial_is_darboux_and_a_perturbed_one_is_refused(pc, ac, b1, b2):
    p = poly_of(pc, 2)
    if sympy.Poly(p, X, Y).total_degree() < 1:
        return
    exprs = [sympy.expand(e) for e in _planted(p, poly_of(ac, 1), poly_of(b1, 1), poly_of(b2, 1))]
    if any(e == 0 for e in exprs):
        return
    system = ode({x: term_of(exprs[0]), y: term_of(exprs[1])})
    for q, g in darboux_polynomials(field(*exprs), [X, Y]):
        # exactly p' = g p, by sympy on expressions (independent of the search's Poly arithmetic)
        qe, ge = q.as_expr(), g.as_expr()
        assert sympy.expand(sympy.diff(qe, X) * exprs[0] + sympy.diff(qe, Y) * exprs[1] - ge * qe) == 0
        assert lie(q, field(*exprs)) == g * q
        term, cofactor = term_of(qe), term_of(ge)
        assert darboux_identity(term, cofactor, system)
        exact, _ = cofactors(cmp(">=", term, 0), system)
        assert exact is not None
        # a perturbed polynomial with the same cofactor is refused by the core
        for delta in (1, X, Y):
            rest = sympy.diff(delta, X) * exprs[0] + sympy.diff(delta, Y) * exprs[1] - ge * delta
            if sympy.expand(rest) != 0:
                assert not darboux_identity(term_of(qe + delta), cofactor, system)
                break


def term_of(e: sympy.Expr):
    """The model term for a sympy expression in X, Y (read as the model's x, y)."""
    table = SympyTable()
    return from_sympy(sympy.sympify(e).xreplace({X: table.symbol(x), Y: table.symbol(y)}), table)
