"""The one-point rule (proofs/core/onepoint.py) is an exact equivalence: each rewritten formula is
checked equivalent to its original by z3 on linear claims (a decidable fragment, and z3's
answer there does not go through the rewrite), and by exact evaluation at points where no
quantifier is left; wrong rewrites (a symbol defined in terms of itself, an integer defined by a
real, a definition under a negation) are refused."""

from fractions import Fraction

from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models.lang.terms import And, Exists, ForAll, Iff, Implies, Int, Not, Or, Real, cmp, free_vars
from certiloop.proofs.core.exact import truth
from certiloop.proofs.core.onepoint import eliminate_defined
from certiloop.proofs.core.solver import check_here

t, r, h, v, a, x, y = (Real(n) for n in "t r h v a x y".split())


def equivalent(f, g) -> bool:
    return check_here(Iff(f, g), 2_000_000, 60.0).status == "unsat"


def quantifiers(f) -> int:
    return (f.op in ("forall", "exists")) + sum(quantifiers(g) for g in f.args)


def test_a_defined_symbol_becomes_its_definition():
    f = ForAll(r, Implies(And(cmp(">=", t, 0), cmp("==", r, v * t)), cmp(">=", r, a)))
    g = eliminate_defined(f)
    assert quantifiers(g) == 0 and "r" not in free_vars(g)
    for point in ({"t": Fraction(2), "v": Fraction(3), "a": Fraction(5)},
                  {"t": Fraction(2), "v": Fraction(3), "a": Fraction(7)},
                  {"t": Fraction(-1), "v": Fraction(3), "a": Fraction(7)}):
        expected = not (point["t"] >= 0) or point["v"] * point["t"] >= point["a"]
        assert truth(g, point) is expected


def test_cases_split_into_one_quantifier_each_and_nested_quantifiers_meet_the_split():
    # ACAS X's shape: two cases, each defining r and h; ∀t ∀r ∀h nested
    cases = Or(And(cmp("<", t, 1), cmp("==", r, v * t), cmp("==", h, a * t)),
               And(cmp(">=", t, 1), cmp("==", r, v), cmp("==", h, a * t - a)))
    f = ForAll(t, ForAll(r, ForAll(h, Implies(cases, cmp("<=", r + h, x)))))
    g = eliminate_defined(f)
    assert quantifiers(g) == 1 and g.payload == (t,)  # only ∀t is left
    assert equivalent(f, g)


def test_exists_with_a_definition():
    f = Exists(y, And(cmp("==", y, x + 1), cmp(">", y, a)))
    g = eliminate_defined(f)
    assert quantifiers(g) == 0
    assert equivalent(f, g)


def test_chained_definitions_reach_each_other():
    f = ForAll([r, h], Implies(And(cmp("==", r, h + 1), cmp("==", h, 2 * x)), cmp(">", r, a)))
    g = eliminate_defined(f)
    assert quantifiers(g) == 0
    assert equivalent(f, g)


def test_what_is_not_a_definition_is_left_alone():
    n = Int("n")
    untouched = [
        ForAll(r, Implies(cmp("==", r, r * x + 1), cmp(">", r, 0))),  # r on both sides
        ForAll(n, Implies(cmp("==", n, x), cmp(">", n, 0))),  # an integer defined by a real
        ForAll(r, Implies(Not(cmp("==", r, x)), cmp(">", r, 0))),  # under a negation
        ForAll(r, Implies(cmp(">", r, 0), cmp("==", r, x))),  # in the conclusion
        ForAll(r, Or(cmp("==", r, x), cmp(">", r, 0))),  # ∀ over a disjunction
    ]
    for f in untouched:
        assert eliminate_defined(f).same(f), f


def test_the_case_split_is_bounded():
    many = And(*[Or(cmp("<", t, k), cmp("==", r, k * t)) for k in range(5)])  # 32 cases
    f = ForAll(r, Implies(many, cmp(">=", r, 0)))
    assert eliminate_defined(f).same(f)


_ATOMS = st.sampled_from(["eq", "lt", "ge"])


@st.composite
def linear_claims(draw):
    """∀/∃ over r and h with random linear cases, some defining r or h."""
    syms = {"t": t, "x": x, "a": a}

    def term():
        c1, c2, c0 = (draw(st.integers(-2, 2)) for _ in range(3))
        s1, s2 = (syms[draw(st.sampled_from(sorted(syms)))] for _ in range(2))
        return c1 * s1 + c2 * s2 + c0

    def literal(var):
        kind = draw(_ATOMS)
        lhs = var if draw(st.booleans()) else r + h
        return cmp({"eq": "==", "lt": "<", "ge": ">="}[kind], lhs, term())

    cases = Or(*[And(*[literal(draw(st.sampled_from([r, h]))) for _ in range(draw(st.integers(1, 3)))])
                 for _ in range(draw(st.integers(1, 3)))])
    goal = cmp(draw(st.sampled_from(["<=", ">", "=="])), r - h, term())
    if draw(st.booleans()):
        return ForAll(r, ForAll(h, Implies(cases, goal)))
    return Exists([r, h], And(cases, goal))


@settings(max_examples=60, deadline=None)
@given(linear_claims())
def test_the_rewrite_is_an_equivalence(f):
    g = eliminate_defined(f)
    assert equivalent(f, g), (f, g)
