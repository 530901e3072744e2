"""Each proof rule yields the obligations the dL calculus says it should."""

from fractions import Fraction

from hypothesis import given
from hypothesis import strategies as st

from certiloop.models import (
    And,
    Box,
    Diamond,
    Reals,
    Theorem,
    assign,
    branch,
    choice,
    havoc,
    loop,
    ode,
    seq,
)
from certiloop.models import test as guard
from certiloop.proofs.core.exact import truth
from certiloop.proofs.core.odes import holds_along, lie_derivative, polynomial_solution
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine.prover import discharge_one

x, y, v, a, t, e, s, tau = Reals("x y v a t e s tau")


def obligations(program, pre=True, post=None, **kw):
    return generate(Theorem("t", pre, program, post if post is not None else x >= 0, **kw))


def verdicts(program, pre=True, post=None):
    return [discharge_one(o).verdict for o in obligations(program, pre, post)]


def test_assignment_substitutes():
    (ob,) = obligations(assign(x, y + 1), y >= 0)
    assert str(ob.formula) == "y >= 0 -> y + 1 >= 0"


def test_nondeterministic_assignment_makes_a_fresh_symbol():
    (ob,) = obligations(havoc(x))
    assert "x@" in str(ob.formula)
    assert verdicts(havoc(x)) == ["refuted"]
    assert verdicts(seq(havoc(x), guard(x >= 1))) == ["proved"]


def test_choice_splits_into_labelled_paths():
    prog = choice(branch("up", assign(x, 1)), branch("down", assign(x, -1)))
    obs = obligations(prog)
    assert [o.path for o in obs] == ["up / postcondition", "down / postcondition"]
    assert [discharge_one(o).verdict for o in obs] == ["proved", "refuted"]


def test_loop_gives_init_step_use_and_keeps_constant_facts():
    prog = loop(assign(x, x + y), invariant=x >= 0)
    obs = obligations(prog, And(x >= 0, y >= 0))
    assert [o.path.split(" / ")[0] for o in obs] == ["loop init", "loop step", "loop use"]
    # y is not written by the loop, so y >= 0 is still known inside it
    assert all(discharge_one(o).verdict == "proved" for o in obs)


def test_loop_invariant_that_is_not_inductive_fails_only_the_step():
    prog = loop(assign(x, x - 1), invariant=x >= 0)
    res = [discharge_one(o).verdict for o in obligations(prog, x >= 5)]
    assert res == ["proved", "refuted", "proved"]


def test_ode_solution_checks_the_domain_along_the_whole_flow():
    # x' = v, v' = a: with a > 0 and v < 0 the position dips and comes back. A domain
    # x >= 0 must hold at the dip, not just at both ends.
    sol = polynomial_solution(ode({x: v, v: a}), s)
    assert str(sol["x"]) in ("x + s*v + 1/2*a*s^2", "x + v*s + 1/2*a*s^2", "x + s*v + a*s^2/2")
    along = holds_along(x >= 0, sol, tau, s)
    dips = {"x": Fraction(1), "v": Fraction(-4), "a": Fraction(4), "tau": Fraction(1)}
    # x(s) = 1 - 4s + 2s^2: x(0) = 1, x(1) = -1... choose tau where both ends are >= 0
    dips["tau"] = Fraction(2)  # x(2) = 1 - 8 + 8 = 1 >= 0 but x(1) = -1
    assert truth(along, dips) is False
    ok = dict(dips, v=Fraction(-1))  # x(s) = 1 - s + 2s^2 > 0 everywhere
    assert truth(along, ok) is True


@given(st.fractions(-5, 5, max_denominator=4), st.fractions(-5, 5, max_denominator=4),
       st.fractions(-5, 5, max_denominator=4), st.fractions(0, 4, max_denominator=4))
def test_holds_along_matches_dense_sampling(x0, v0, a0, duration):
    sol = polynomial_solution(ode({x: v, v: a}), s)
    exact = truth(holds_along(x >= 0, sol, tau, s), {"x": x0, "v": v0, "a": a0, "tau": duration})
    samples = [duration * Fraction(k, 400) for k in range(401)]
    sampled = all(x0 + v0 * q + a0 * q * q / 2 >= 0 for q in samples)
    if exact:
        assert sampled  # exact says it holds everywhere, so it holds at every sample
    elif sampled:
        # sampling can miss a dip narrower than the grid, never the other way round
        assert not exact


def test_non_polynomial_ode_uses_differential_weakening():
    prog = ode({x: x * y}, x >= 0)
    (ob,) = obligations(prog)
    assert "ODE dW" in ob.path
    assert verdicts(prog) == ["proved"]


def test_differential_invariant_and_cut():
    # x' = v, v' = a with a >= 0: v >= 0 is a dI; x >= 0 is a dI only after cutting v >= 0
    prog = ode({x: v, v: a}, a >= 0, invariants=[v >= 0, x >= 0])
    obs = obligations(prog, And(x >= 0, v >= 0))
    assert [o.path for o in obs] == [
        "ODE dI 1 init / holds initially",
        "ODE dI 1 / derivative condition",
        "ODE dI 2 init / holds initially",
        "ODE dI 2 / derivative condition",
        "ODE dC/dW / postcondition",
    ]
    assert all(discharge_one(o).verdict == "proved" for o in obs)
    without_cut = ode({x: v, v: a}, a >= 0, invariants=[x >= 0])
    assert "refuted" in verdicts(without_cut, And(x >= 0, v >= 0))


def test_lie_derivative():
    assert str(lie_derivative(x * x + v * v, ode({x: v, v: -x}))) == "0"
    # remembered per term and equations: the same term along another flow (or domain) is
    # derived again, and asking twice gives the same derivative
    for _ in range(2):
        assert str(lie_derivative(x * x + v * v, ode({x: v, v: x}))) == "4*x*v"
        assert str(lie_derivative(x * x + v * v, ode({x: v, v: -x}, x >= 0))) == "0"
        assert str(lie_derivative(x * x + v * v, ode({x: 1, v: 0}))) == "2*x"


def test_box_and_diamond_in_formulas():
    # [x := x + 1] x > y  and  <x := *> x > y  are first-order after expansion
    prog = assign(y, 0)
    assert verdicts(prog, x >= 0, Box(assign(x, x + 1), x > y)) == ["proved"]
    assert verdicts(prog, True, Diamond(havoc(x), x > y)) == ["proved"]
    assert verdicts(prog, True, Box(havoc(x), x > y)) == ["refuted"]


def test_time_triggered_ode_with_clock():
    plant = seq(assign(t, 0), ode({x: v, t: 1}, t <= e))
    prog = seq(guard(x + v * e >= 0), guard(v <= 0), plant)
    assert verdicts(prog, And(x >= 0, e > 0)) == ["proved"]
