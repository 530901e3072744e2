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
from certiloop.proofs.arith.smtlib import script
from certiloop.proofs.checker.certificate import RLIMIT, decide
from certiloop.proofs.checker.derive import Rejected
from certiloop.proofs.checker.weakening import weakened

x, y, c, s, u = Reals("x y c s u")
B = IndexSort("B")
i, j = Var("i", B), Var("j", B)
a = Array("a", B)


def _record(instances=None, lowered=False, abbreviations=(), facts=(), atoms=(), decided=None):
    """A weakening record; `decided` is the weaker formula whose SMT-LIB text it records."""
    return {"instances": instances, "lowered": lowered,
            "abbreviations": [[name, repr(d.key)] for name, d in abbreviations],
            "facts": [repr(f.key) for f in facts], "atoms": [[k, repr(atom.key)] for k, atom in atoms],
            "smtlib": "" if decided is None else script(decided)}


def test_an_instance_is_rebuilt_by_substitution():
    """(∀u u·u + c >= 0) -> x·x + c >= 0: the hypothesis at u = x is the goal itself; at u = y
    it is a weakening z3 refutes (x = 1, y = 0, c = -1/2)."""
    leaf = Implies(ForAll(u, u * u + c >= 0), x * x + c >= 0)
    wanted = Implies(x * x + c >= 0, x * x + c >= 0)
    assert weakened(leaf, _record([[0, [repr(x.key)]]], decided=wanted), "o1").same(wanted)
    at_y = Implies(y * y + c >= 0, x * x + c >= 0)
    assert weakened(leaf, _record([[0, [repr(y.key)]]], decided=at_y), "o1").same(at_y)
    assert "sat" in decide(script(at_y), RLIMIT)
    with pytest.raises(Rejected, match="not the one these steps give"):  # recorded at y, claims x
        weakened(leaf, _record([[0, [repr(y.key)]]], decided=wanted), "o1")
    with pytest.raises(Rejected, match="more instance terms"):  # x >= 0 has no quantifier
        weakened(Implies(x >= 0, x >= 0), _record([[0, [repr(x.key)]]], decided=wanted), "o1")
    with pytest.raises(Rejected, match="another sort"):  # a real named like the leaf's index symbol i
        weakened(Implies(And(ForAll(u, u * u + c >= 0), cmp("==", i, j)), x >= 0),
                 _record([[0, [repr(Var("i").key)]], 1], decided=wanted), "o1")


def test_a_universal_goal_gets_a_fresh_skolem_constant():
    """c >= 0 -> ∀u u·u + c >= 0 becomes c >= 0 -> u@sk1·u@sk1 + c >= 0, unless the leaf
    already has a symbol of that name (it would not be arbitrary)."""
    k = Var("u@sk1")
    wanted = Implies(c >= 0, k * k + c >= 0)
    leaf = Implies(c >= 0, ForAll(u, u * u + c >= 0))
    assert weakened(leaf, _record([0], decided=wanted), "o1").same(wanted)
    stale = Implies(And(c >= 0, k >= 1), ForAll(u, u * u + c >= 0))
    with pytest.raises(Rejected, match="not fresh"):
        weakened(stale, _record([0, 1], decided=Implies(And(c >= 0, k >= 1), k * k + c >= 0)), "o1")


def test_an_abbreviation_must_stand_for_a_term_giving_the_same_polynomial():
    """x² + 2xy + y² >= 0 abstracted to s·s >= 0 with s = x + y ((x + y)² is it); s = x - y
    is not ((x - y)² = x² - 2xy + y²), and s may not be a symbol of the leaf."""
    leaf = x * x + 2 * x * y + y * y >= 0
    def square(t, atom=s * s >= 0, k=0):
        return _record(abbreviations=[("s", t)], atoms=[(k, atom)], decided=atom)

    assert weakened(leaf, square(x + y), "o1").same(s * s >= 0)
    with pytest.raises(Rejected, match="rewritten atom"):
        weakened(leaf, square(x - y), "o1")
    with pytest.raises(Rejected, match="fresh"):
        weakened(Implies(s >= 0, leaf), dict(square(x + y, k=1), smtlib=script(Implies(s >= 0, s * s >= 0))),
                 "o1")
    with pytest.raises(Rejected, match="rewritten atom"):  # the operator must stay: s·s > 0 is not implied
        weakened(leaf, square(x + y, s * s > 0), "o1")
    for k in (1, -1):  # the leaf has one atom, number 0
        with pytest.raises(Rejected, match="not one of the formula's 1 atoms"):
            weakened(leaf, square(x + y, k=k), "o1")


def test_lowering_is_recomputed_read_over_write_and_reads_as_symbols():
    """a{i := x}[j] >= 0 is (i = j -> x >= 0) & (i != j -> a[j] >= 0), i and j reals, a[j] a symbol."""
    leaf = select(store(a, (i,), x), j) >= 0
    ri, rj, aj = Var("i", REAL), Var("j", REAL), Var("a[j]", REAL)
    wanted = And(Implies(cmp("==", ri, rj), x >= 0), Implies(Not(cmp("==", ri, rj)), aj >= 0))
    assert weakened(leaf, _record(lowered=True, decided=wanted), "o1").same(wanted)


def test_an_index_value_in_arithmetic_is_rejected():
    """i = j -> a[i] = a[j] lowered keeps i = j; written as i - j = 0 it is the same polynomial,
    but over the reals i - j means something an index cannot: rejected."""
    leaf = Implies(cmp("==", i, j), cmp("==", select(a, i), select(a, j)))
    ri, rj, ai, aj = Var("i", REAL), Var("j", REAL), Var("a[i]", REAL), Var("a[j]", REAL)
    ack = Implies(cmp("==", ri, rj), cmp("==", ai, aj))
    good = Implies(ack, Implies(cmp("==", ri, rj), cmp("==", ai, aj)))
    assert weakened(leaf, _record(lowered=True, decided=good), "o1").same(good)
    bad = Implies(ack, Implies(cmp("==", ri - rj, 0), cmp("==", ai, aj)))
    with pytest.raises(Rejected, match="index value"):  # the atoms: ack's two, then the leaf's two
        weakened(leaf, _record(lowered=True, atoms=[(2, cmp("==", ri - rj, 0))], decided=bad), "o1")
