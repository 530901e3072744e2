"""The checker's weakening rules (proofs/checker/weakening.py) on hand-built leaves: each
recorded step is re-derived, and the weaker formula is accepted only when it is the one hand
mathematics gives; wrong instances, abbreviations that are not fresh or not the term they
stand for, and index values used in arithmetic are rejected."""

import pytest

from certiloop.models.lang.terms import (
    REAL,
    And,
    Array,
    ForAll,
    Implies,
    IndexSort,
    Not,
    Reals,
    Var,
    cmp,
    select,
    store,
)
from certiloop.proofs.checker.derive import Rejected
from certiloop.proofs.checker.weakening import weakened

x, y, c, s, u = Reals("x y c s u")
B = IndexSort("B")
i, j = Var("i", B), Var("j", B)
a = Array("a", B)


def _record(formula, instances=None, lowered=False, abbreviations=(), facts=()):
    return {"instances": instances, "lowered": lowered,
            "abbreviations": [[name, repr(d.key)] for name, d in abbreviations],
            "facts": [repr(f.key) for f in facts], "formula": repr(formula.key)}


def test_an_instance_is_rebuilt_by_substitution():
    """(∀u u·u + c >= 0) -> x·x + c >= 0: the hypothesis at u = x is the goal itself."""
    leaf = Implies(ForAll(u, u * u + c >= 0), x * x + c >= 0)
    wanted = Implies(x * x + c >= 0, x * x + c >= 0)
    assert weakened(leaf, _record(wanted, [[0, [repr(x.key)]]]), "o1").same(wanted)
    with pytest.raises(Rejected):  # recorded at y, the formula claims the instance at x
        weakened(leaf, _record(wanted, [[0, [repr(y.key)]]]), "o1")
    with pytest.raises(Rejected):  # an instance term for a hypothesis that has no quantifier
        weakened(Implies(x >= 0, x >= 0), _record(wanted, [[0, [repr(x.key)]]]), "o1")


def test_a_universal_goal_gets_a_fresh_skolem_constant():
    """c >= 0 -> ∀u u·u + c >= 0 becomes c >= 0 -> u@sk1·u@sk1 + c >= 0, unless the leaf
    already has a symbol of that name (it would not be arbitrary)."""
    k = Var("u@sk1")
    wanted = Implies(c >= 0, k * k + c >= 0)
    assert weakened(Implies(c >= 0, ForAll(u, u * u + c >= 0)), _record(wanted, [0]), "o1").same(wanted)
    stale = Implies(And(c >= 0, k >= 1), ForAll(u, u * u + c >= 0))
    with pytest.raises(Rejected, match="not fresh"):
        weakened(stale, _record(wanted, [0, 1]), "o1")


def test_an_abbreviation_must_stand_for_a_term_giving_the_same_polynomial():
    """x² + 2xy + y² >= 0 abstracted to s·s >= 0 with s = x + y ((x + y)² is it); s = x - y
    is not ((x - y)² = x² - 2xy + y²), and s may not be a symbol of the leaf."""
    leaf = x * x + 2 * x * y + y * y >= 0
    assert weakened(leaf, _record(s * s >= 0, abbreviations=[("s", x + y)]), "o1").same(s * s >= 0)
    with pytest.raises(Rejected):
        weakened(leaf, _record(s * s >= 0, abbreviations=[("s", x - y)]), "o1")
    with pytest.raises(Rejected, match="fresh"):
        weakened(Implies(s >= 0, leaf), _record(Implies(s >= 0, s * s >= 0), abbreviations=[("s", x + y)]),
                 "o1")
    with pytest.raises(Rejected):  # the operator must stay: s·s > 0 is not implied
        weakened(leaf, _record(s * s > 0, abbreviations=[("s", x + y)]), "o1")


def test_lowering_is_recomputed_read_over_write_and_reads_as_symbols():
    """a{i := x}[j] >= 0 is (i = j -> x >= 0) & (i != j -> a[j] >= 0), i and j reals, a[j] a symbol."""
    leaf = select(store(a, (i,), x), j) >= 0
    ri, rj, aj = Var("i", REAL), Var("j", REAL), Var("a[j]", REAL)
    wanted = And(Implies(cmp("==", ri, rj), x >= 0), Implies(Not(cmp("==", ri, rj)), aj >= 0))
    assert weakened(leaf, _record(wanted, lowered=True), "o1").same(wanted)
    swapped = And(Implies(cmp("==", ri, rj), aj >= 0), Implies(Not(cmp("==", ri, rj)), x >= 0))
    with pytest.raises(Rejected):
        weakened(leaf, _record(swapped, lowered=True), "o1")


def test_an_index_value_in_arithmetic_is_rejected():
    """i = j -> a[i] = a[j] lowered keeps i = j; written as i - j = 0 it is the same polynomial,
    but over the reals i - j means something an index cannot: rejected."""
    leaf = Implies(cmp("==", i, j), cmp("==", select(a, i), select(a, j)))
    ri, rj, ai, aj = Var("i", REAL), Var("j", REAL), Var("a[i]", REAL), Var("a[j]", REAL)
    ack = Implies(cmp("==", ri, rj), cmp("==", ai, aj))
    good = Implies(ack, Implies(cmp("==", ri, rj), cmp("==", ai, aj)))
    assert weakened(leaf, _record(good, lowered=True), "o1").same(good)
    bad = Implies(ack, Implies(cmp("==", ri - rj, 0), cmp("==", ai, aj)))
    with pytest.raises(Rejected, match="index value"):
        weakened(leaf, _record(bad, lowered=True), "o1")
