"""Ghost constants (Theorem.ghosts): a fresh constant with a fact the core first proves
satisfiable under the assumptions, then assumes; and the engine's eigenvalue ghosts for linear
flows with parameters (proofs/engine/eigen.py).

Independent witness for every `proved`: scipy integrates the flow from random parameters and
starts that satisfy the assumptions."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from certiloop.models.kyx import read_entries
from certiloop.models.lang.programs import assign, havoc, loop, ode, seq, test
from certiloop.models.lang.terms import INT, TRUE, And, Box, ModelError, Real, Var, cmp
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine.eigen import ghost_options
from certiloop.proofs.engine.prover import Prover

x, y, a, b, g = (Real(n) for n in ("x", "y", "a", "b", "g"))


def prove(theorem: Theorem):
    with Prover(jobs=1) as prover:
        return prover.prove(theorem)


# ---------------------------------------------------------------------------- the core rule


@pytest.mark.parametrize("where", ["assumptions", "guarantee", "statement", "constant"])
def test_a_ghost_must_be_a_fresh_name(where):
    """A ghost named like a symbol of the claim would let its fact speak about that symbol:
    `x = 0` as a ghost fact would prove [x := 1] x = 0."""
    assumptions = g > 0 if where == "assumptions" else TRUE
    guarantee = g > 0 if where == "guarantee" else x >= 0
    program = assign(x, g) if where == "statement" else assign(x, 1)
    constants = (g,) if where == "constant" else ()
    with pytest.raises(ModelError, match="the ghost `g` must be a fresh name"):
        Theorem("t", assumptions, program, guarantee, constants=constants, ghosts=(("g", g > 0),))


def test_a_fact_mentions_no_later_ghost():
    """A red team's false claim, proved before: `a = b` was shown to have a solution with b
    any value, then `b = a + 1` re-bound b, and both facts together were a contradiction."""
    with pytest.raises(ModelError, match="mentions the later ghost `b`"):
        Theorem("two", TRUE, assign(x, 1), cmp("==", x, 0),
                ghosts=(("a", cmp("==", a, b)), ("b", cmp("==", b, a + 1))))
    later_fine = Theorem("two", TRUE, assign(x, 1), x >= 0, ghosts=(("a", a > 0), ("b", cmp("==", b, a + 1))))
    assert prove(later_fine).verdict == "proved"


@pytest.mark.parametrize("fact, message", [
    (lambda: And(g > 0, Box(assign(y, g), y > 0)), "holds a modality"),
    (lambda: cmp("==", Var("g", INT), 1), "two sorts"),
])
def test_a_fact_is_first_order_and_well_sorted(fact, message):
    with pytest.raises(ModelError, match=message):
        Theorem("t", g >= 0, ode([(x, -x)], invariants=[x >= 0]), x >= 0,
                ghosts=(("h", And(Real("h") > 0, fact())),))


def test_the_eigenvalue_ghost_avoids_every_name_of_the_theorem():
    """A scenario (or abbreviation) naming `eig` once made the engine's ghost clash."""
    t = replace(spring("c^2 > 4*k"), scenarios=(Real("eig") > 0,))
    assert {o.ghosts[0][0] for o in ghost_options(t)} == {"eig2"}


def test_a_ghost_may_appear_in_the_annotations():
    flow = ode([(x, -x)], invariants=[x * g >= 0])
    t = Theorem("t", And(x >= 0), flow, x >= 0, ghosts=(("g", g > 0),))
    assert t.ghosts[0][0] == "g"


def test_the_ghost_must_exist_first():
    """A fact no value satisfies would make every later obligation vacuous: the first
    obligation is that one exists, and here it cannot be proved."""
    t = Theorem("t", TRUE, assign(x, 1), cmp("==", x, 0), ghosts=(("g", g * g < 0),))
    first = generate(t)[0]
    goal = first.formula.args[1] if first.formula.op == "implies" else first.formula
    assert "ghost g" in first.path and goal.op == "exists"
    result = prove(t)
    assert result.verdict != "proved"
    assert result.obligations[0].verdict != "proved"


def test_the_existence_is_proved_from_the_assumptions():
    """`l^2 = a` exists where a >= 0 is assumed, and not without it."""
    claim = dict(program=assign(x, 1), guarantee=x >= 0, ghosts=(("g", cmp("==", g * g, a)),))
    assert prove(Theorem("with", a >= 0, **claim)).verdict == "proved"
    result = prove(Theorem("without", TRUE, **claim))
    assert result.verdict != "proved" and result.obligations[0].verdict != "proved"


# ---------------------------------------------------------------------------- eigenvalue ghosts

# a spring-damper released at rest: overdamped (real eigenvalues) it never crosses the rest
# position, underdamped it does
SPRING = """ArchiveEntry "{name}"
  Definitions Real k; Real c; End.
  ProgramVariables Real x; Real y; End.
  Problem x = 0 & k > 0 & c > 0 & {damping}
    -> [ {{ x := *; ?x > 0; y := 0; {{x' = y, y' = -k*x - c*y}} }}* ] x >= 0
  End.
End."""


def spring(damping: str) -> Theorem:
    (entry,) = read_entries(SPRING.format(name=f"spring, {damping}", damping=damping))
    assert entry.error is None, entry.error
    return entry.theorem


def lowest_position(rng, k: float, c: float) -> float:
    sol = solve_ivp(lambda _t, s: [s[1], -k * s[0] - c * s[1]], (0, 40), [1.0, 0.0], rtol=1e-10, atol=1e-13,
                    dense_output=True)
    return float(sol.sol(np.linspace(0, 40, 4001))[0].min())


def test_an_overdamped_spring_is_proved_with_an_eigenvalue_ghost():
    t = spring("c^2 > 4*k")
    options = ghost_options(t)
    assert [o.ghosts[0][0] for o in options] == ["eig", "eig"]
    result = prove(t)
    assert result.verdict == "proved", result
    assert any("ghost eig" in r.path for r in result.obligations)
    rng = np.random.default_rng(0)
    for _ in range(30):  # the witness: overdamped springs released at rest stay at x >= 0
        k = rng.uniform(0.01, 5)
        c = np.sqrt(4 * k) * rng.uniform(1.01, 3)
        assert lowest_position(rng, k, c) >= -1e-9


def test_an_underdamped_spring_is_not_proved():
    rng = np.random.default_rng(1)
    assert lowest_position(rng, 1.0, 0.5) < -0.1  # it does cross
    t = spring("c^2 < 4*k")
    assert prove(t).verdict != "proved"


def test_no_ghost_for_rational_or_complex_eigenvalues():
    """Rational eigenvalues are Darboux search's; complex ones have no real eigenvector."""
    rational = Theorem("r", x >= 0, ode([(x, y), (y, 2 * x + y)]), x >= 0)  # eigenvalues 2, -1
    complex_ = Theorem("c", x >= 0, ode([(x, y), (y, -x)]), x >= 0)
    irrational = Theorem("i", x >= 0, ode([(x, y), (y, 2 * x)]), x >= 0)  # +-sqrt(2)
    assert ghost_options(rational) == [] and ghost_options(complex_) == []
    (first, second) = ghost_options(irrational)
    assert {str(first.ghosts[0][1]), str(second.ghosts[0][1])} == {
        "-2 + eig^2 = 0 & 2*eig <= 0", "-2 + eig^2 = 0 & 2*eig >= 0"}


def test_a_ghost_hint_that_is_wrong_fails_to_prove():
    """The wrong root's forms, or a fact that is not an eigenvalue's, only fail to prove."""
    root = Real("l")
    flow = ode([(x, y), (y, a * x + b * y)], invariants=[a * x + root * y <= 0, x >= 0])
    claim = loop(seq(havoc(x), test(x > 0), assign(y, 0), flow), x >= 0)
    underdamped = And(cmp("==", x, 0), b * b + 4 * a < 0, a < 0, b <= 0)
    wrong = Theorem("wrong", underdamped, claim, x >= 0,
                    ghosts=(("l", And(cmp("==", root * root - b * root - a, 0), 2 * root <= b)),))
    assert prove(wrong).verdict != "proved"


# ---------------------------------------------------------------------------- equilibria as witnesses

EQUILIBRIUM = """ArchiveEntry "{name}"
  Definitions Real c; End.
  ProgramVariables Real x; End.
  Problem {assume} -> \\exists f (x = f -> [{{x' = {rate}}}] x = f) End.
End."""


def equilibrium(assume: str, rate: str):
    (entry,) = read_entries(EQUILIBRIUM.format(name=f"{assume}: {rate}", assume=assume, rate=rate))
    assert entry.error is None, entry.error
    return entry.theorem


@pytest.mark.parametrize("assume, rate, root", [
    ("c <= 0", "c + x^2", lambda c: -np.sqrt(-c)),
    ("true", "x^3 - c", np.cbrt),  # a real root for every c
])
def test_an_equilibrium_is_the_witness(assume, rate, root):
    result = prove(equilibrium(assume, rate))
    assert result.verdict == "proved", result
    assert "a ghost with" in result.reason
    f = {"c + x^2": lambda x, c: c + x * x, "x^3 - c": lambda x, c: x ** 3 - c}[rate]
    for c in (-4.0, -0.25, 0.0) if assume != "true" else (-3.0, 0.0, 2.0):
        assert abs(f(root(c), c)) < 1e-12  # the witness: a value where the flow stands still


def test_no_equilibrium_no_proof():
    """With c > 0, x' = c + x^2 > 0 moves every start: the claim is false, and the ghost
    with c + s^2 = 0 cannot be shown to exist."""
    result = prove(equilibrium("c > 0", "c + x^2"))
    assert result.verdict != "proved"


def test_export_refuses_a_ghost():
    from certiloop.models.kyx import NotExpressible, to_kyx

    t = Theorem("t", x >= 0, ode([(x, -x)], invariants=[x * g >= 0]), x >= 0, ghosts=(("g", g > 0),))
    with pytest.raises(NotExpressible, match="ghost constant `g`"):
        to_kyx(t)
