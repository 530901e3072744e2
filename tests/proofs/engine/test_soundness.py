"""Soundness: counterexamples re-check exactly; unsafe variants never prove; the prover and
the refuter never disagree."""

from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models import And, Reals, Theorem, assign, havoc, library, loop, ode, seq
from certiloop.models import test as guard
from certiloop.models.lang.programs import ODE, Choice, Loop, Seq, Test
from certiloop.models.lang.terms import cmp
from certiloop.proofs.core import interval as iv
from certiloop.proofs.core.exact import truth
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine import Budget
from certiloop.proofs.engine.prover import Prover, discharge_one
from certiloop.proofs.refute.unroll import refute

# Models small enough to discharge every obligation at full strength in the test suite; the
# 144-branch ctrl2 family is covered by its exactly re-checked refutation runs instead.
SMALL_MODELS = [n for n in library.names() if len(generate(library.get(n))) <= 40]


@pytest.mark.parametrize("name", SMALL_MODELS)
def test_every_refuted_obligation_has_a_counterexample_that_falsifies_it(name):
    for ob in generate(library.get(name)):
        res = discharge_one(ob, keep_model=True)
        if res.verdict == "refuted":
            if res.check.startswith("z3 model evaluation"):
                continue  # quantified: checked by z3's evaluator, reported as such
            assert truth(ob.formula, res.raw_model) is False, (ob.path, res.counterexample)


# --------------------------------------------------------------------------- mutants

FLIP = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "==": "!=", "!=": "=="}
WEAKEN = {"<": "<=", ">": ">=", "<=": "<=", ">=": ">=", "==": "==", "!=": "!="}


def _mutate_tests(program, op_map, counter, target):
    """Rewrite the `target`-th comparison inside a test or ODE domain with op_map."""
    def cond(f):
        if f.op == "cmp":
            counter[0] += 1
            if counter[0] == target:
                return cmp(op_map[f.payload], *f.args)
            return f
        if f.op in ("and", "or", "not", "implies"):
            from certiloop.models.lang.terms import rebuild

            return rebuild(f, tuple(cond(a) for a in f.args))
        return f

    def walk(p):
        if isinstance(p, Test):
            return Test(cond(p.cond))
        if isinstance(p, ODE):
            return ODE(p.eqs, cond(p.domain), p.invariants)
        if isinstance(p, Seq):
            return Seq(tuple(walk(q) for q in p.parts))
        if isinstance(p, Choice):
            return Choice(tuple(walk(q) for q in p.alternatives), p.labels)
        if isinstance(p, Loop):
            return Loop(walk(p.body), p.invariant, p.label)
        return p

    return walk(program)


def _mutants(name):
    base = library.get(name)
    for k in range(1, 40):
        counter = [0]
        prog = _mutate_tests(base.program, FLIP, counter, k)
        if counter[0] < k:
            return
        yield k, Theorem(f"{name}~{k}", base.assumptions, prog, base.guarantee,
                         "proved", base.abbreviations, unroll=1)


MUTATED = ["sbs.ctrl1", "textbook.train", "textbook.water_tank", "textbook.bouncing_ball"]
ALL_MUTANTS_TRUE = {"textbook.bouncing_ball"}


@pytest.fixture(scope="module")
def prover():
    with Prover(jobs=2, budget=Budget(rlimit=2_000_000)) as p:
        yield p


@pytest.mark.parametrize("name", MUTATED)
def test_prover_and_refuter_never_disagree_on_mutants(prover, name):
    """For every flipped comparison in a test or domain: the mutant is never both proved
    and shown to have a violating run. Counts how many mutants die."""
    killed = 0
    total = 0
    for _k, mutant in _mutants(name):
        total += 1
        result = prover.prove(mutant)
        if result.verdict == "proved":  # only then can the two disagree
            refutation, _ = refute(mutant, Budget())
            assert refutation is None, mutant.name
        killed += result.verdict != "proved"
    # every flip of bouncing_ball's tests and domain leaves a true claim (the loop invariant holds
    # after either branch, whatever the tests pass; an ODE whose domain h < 0 contradicts
    # h >= 0 never runs), so nothing dies there; elsewhere some mutant must
    assert total > 0 and (killed > 0 or name in ALL_MUTANTS_TRUE)


x, v, a, b, m = Reals("x v a b m")


@pytest.mark.parametrize("program, pre", [
    # each is a known-unsafe variant of a safe design: braking check forgotten,
    # wrong sign of the brake, a domain that lets time run past the period
    (loop(seq(havoc(a), guard(a <= 1), ode({x: v, v: a}, v >= 0)), x <= m), And(x <= m, v == 0)),
    (loop(seq(assign(a, b), ode({x: v, v: a}, v >= 0)), x <= m), And(x <= m, v == 0, b > 0)),
    (loop(seq(havoc(v), guard(x + v <= m), ode({x: v}, True)), x <= m), x <= m),
])
def test_known_unsafe_variants_are_never_proved(prover, program, pre):
    result = prover.prove(Theorem("unsafe", pre, program, x <= m, "refuted"))
    assert result.verdict == "refuted"
    assert result.refutation is not None


# --------------------------------------------------------------------------- arithmetic

fractions = st.fractions(-100, 100, max_denominator=50)


@given(fractions, fractions, st.fractions(0, 1, max_denominator=1000), fractions)
@settings(max_examples=300)
def test_interval_arithmetic_encloses_exact_results(p, q, width, r):
    box_p = iv.Interval(p - width, p + width)
    for op, exact in ((iv.add, p + q), (iv.mul, p * q)):
        out = op(box_p, q)
        lo, hi = (out.lo, out.hi) if isinstance(out, iv.Interval) else (out, out)
        assert lo <= exact <= hi
    # a decided comparison is right for every point of the interval
    for cmp_op in ("<", "<=", ">", ">=", "==", "!="):
        decided = iv.compare(cmp_op, box_p, r)
        if decided is not None:
            for point in (p - width, p, p + width):
                assert decided == {"<": point < r, "<=": point <= r, ">": point > r,
                                   ">=": point >= r, "==": point == r, "!=": point != r}[cmp_op]


def test_algebraic_counterexamples_are_checked_with_intervals():
    # x*x = 2 has only irrational solutions: z3 answers with an algebraic number
    program = seq(havoc(x), guard(x * x == 2), guard(x > 0))
    (ob,) = generate(Theorem("sqrt2", True, program, x < Fraction(7, 5)))
    res = discharge_one(ob, keep_model=True)
    assert res.verdict == "refuted" and res.check == "interval arithmetic"
    assert res.counterexample["x@1"].startswith("1.41421")
