"""Case analysis on abs/min/max guards (proofs/checker/cases.py): the cases together are
equivalent to the obligation, a false obligation stays unproved, and an obligation z3 finds
hard as a whole is proved case by case."""

from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models.lang.terms import And, Iff, Implies, Or, Real
from certiloop.proofs.checker.cases import MAX_GUARDS, case_formulas, guards
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vcgen import Obligation
from certiloop.proofs.engine.budget import Budget
from certiloop.proofs.engine.discharge import discharge_one

x, y, z = Real("x"), Real("y"), Real("z")


def absolute(t, bound):
    """|t| < bound as the .kyx reader writes it."""
    return Or(And(t >= 0, t < bound), And(t < 0, -t < bound))


atoms = st.sampled_from([x >= 0, y < 1, x + y <= 2, z > -1, x * y >= 1, z == 0])
pieces = st.one_of(atoms, st.builds(absolute, st.sampled_from([x, y - z, x - 1]), st.sampled_from([1, 2])))


@settings(max_examples=80, deadline=None)
@given(st.lists(pieces, min_size=1, max_size=4), st.lists(pieces, min_size=1, max_size=2))
def test_the_cases_together_are_the_obligation(hypotheses, goals):
    formula = Implies(And(*hypotheses), And(*goals))
    cases = case_formulas(formula)
    if cases is None:
        assert not guards(formula)
        return
    assert len(cases) == 2 ** min(len(guards(formula)), MAX_GUARDS)
    assert check_valid(Iff(And(*cases), formula), 2_000_000).status == "unsat"


def test_a_false_obligation_is_not_proved_by_cases():
    ob = Obligation("o1", "t", Implies(absolute(x, 1), absolute(x, Real("h"))), "t", {})
    assert discharge_one(ob, Budget()).verdict != "proved"
    ob = Obligation("o1", "t", Implies(absolute(x - y, 2), And(x - y < 1)), "t", {})
    assert discharge_one(ob, Budget()).verdict != "proved"


def lane_step(bound_after=None):
    """The shape of KeYmaera X's STTT example 10 (lane keeping): from |y - ly| + v^2/(2b) plus a
    margin below lw and a step bounded by c (v - a c/2), |y' - ly| + v'^2/(2b) < bound_after
    (default lw, where it holds: the margin covers the step). (hypotheses, goal)"""
    y1, y6, ly, v1, v6, a, c, b, lw, A, ep = (Real(n) for n in "y1 y6 ly v1 v6 a c b lw A ep".split())
    bound = lw if bound_after is None else bound_after(lw)
    margin = (A / b + 1) * (A / 2 * ep * ep + ep * v1)
    hyps = And(b > 0, A > 0, ep > 0, v1 >= 0, v6 >= 0, 0 <= c, c <= ep, a <= A, a >= -b,
               v6 == v1 + a * c, -c * (v6 - a / 2 * c) <= y6 - y1, y6 - y1 <= c * (v6 - a / 2 * c),
               Or(And(y1 - ly >= 0, y1 - ly + v1 * v1 / (2 * b) + margin < lw),
                  And(y1 - ly < 0, -(y1 - ly) + v1 * v1 / (2 * b) + margin < lw)))
    goal = Or(And(y6 - ly >= 0, y6 - ly + v6 * v6 / (2 * b) < bound),
              And(y6 - ly < 0, -(y6 - ly) + v6 * v6 / (2 * b) < bound))
    return hyps, goal


def test_cases_prove_what_the_whole_does_not_within_the_budget():
    hyps, goal = lane_step()
    result = discharge_one(Obligation("o1", "lane", Implies(hyps, goal), "t", {}), Budget())
    assert result.verdict == "proved" and result.backend == "z3 (4 cases)", result.backend
