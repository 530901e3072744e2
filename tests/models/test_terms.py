import gc
import weakref
from fractions import Fraction

import pytest

from certiloop.models import (
    INT,
    And,
    Array,
    Exists,
    Family,
    ForAll,
    Implies,
    IndexSort,
    Int,
    ModelError,
    Not,
    Real,
    Reals,
    dot,
)
from certiloop.models.lang import memos
from certiloop.models.lang.memos import NodeMemo, substitute_shared
from certiloop.models.lang.terms import free_vars, substitute

x, y, z = Reals("x y z")


def test_operators_build_terms_and_formulas():
    f = 2 * x + y / 3 - z**2 >= 0
    assert f.op == "cmp" and f.payload == ">="
    assert str(f) == "2*x + y/3 - z^2 >= 0"
    assert str(-(x + y) * z) == "-(x + y)*z"


def test_formula_refuses_bool_and_explains_chained_comparisons():
    with pytest.raises(ModelError, match="chained comparisons"):
        bool(x <= y)
    with pytest.raises(ModelError, match="chained"):
        0 <= x <= 1  # noqa: B015 - this is the mistake we want caught


def test_float_literals_mean_their_decimal_text():
    assert (x + 0.1).args[1].payload == Fraction(1, 10)


def test_structural_identity_via_key_not_eq():
    assert (x + 1).same(x + 1)
    assert not (x + 1).same(1 + x)
    assert (x == y).op == "cmp"  # == builds a formula


def test_connectives_simplify_trivial_cases():
    assert str(And(x > 0, True)) == "x > 0"
    assert And(x > 0, False).op == "false"
    assert Implies(False, x > 0).op == "true"
    assert str(Not(x > 0)) == "!(x > 0)"


def test_families_and_arrays():
    B = IndexSort("B")
    i = Real("i")  # wrong sort for an index
    n = Family("n", B)
    with pytest.raises(ModelError, match="sort Real, expected B"):
        n(i)
    from certiloop.models.lang.terms import Var

    j = Var("j", B)
    assert n(j).sort.name == "Real"
    P = Array("P", (INT, INT, INT), INT)
    k, a, b = Int("k"), Int("a"), Int("b")
    cell = P[k][a][b]
    assert cell.sort == INT and str(cell) == "P[k][a][b]"
    with pytest.raises(ModelError, match="takes 3"):
        P[k, a, b, k]


def test_substitution_avoids_capture():
    f = ForAll(y, x < y)
    g = substitute(f, {"x": y + 1})
    (bound,) = g.payload
    assert bound.name != "y"
    assert "y" in free_vars(g)  # the substituted y stays free


def test_free_vars_respect_binders():
    f = And(Exists(y, x < y), z > 0)
    assert set(free_vars(f)) == {"x", "z"}


def test_free_vars_are_remembered_but_each_caller_gets_its_own_dict():
    f = And(x < y, ForAll(z, z > x))
    first = free_vars(f)
    first["w"] = z  # a caller adding to its result must not change the next caller's
    assert list(free_vars(f)) == ["x", "y"]
    assert set(free_vars(f.args[1], frozenset({"x"}))) == set()  # a bound set is never cached


def test_substitute_shared_agrees_with_substitute_and_is_bounded(monkeypatch):
    monkeypatch.setattr(memos, "_SUBSTITUTED", {})
    monkeypatch.setattr(memos, "SUBSTITUTED_KEPT", 3)
    f = ForAll(y, Implies(x < y, y * y > z))
    for env in ({"x": y + 1}, {"z": x * x}, {"x": z, "z": y}, {"x": y + 1}, {"y": x}):
        assert substitute_shared(f, env).same(substitute(f, env))
        assert len(memos._SUBSTITUTED) <= 3
    # equal keys, different objects: the remembered result is the same term
    again = substitute_shared(ForAll(y, Implies(x < y, y * y > z)), {"x": y + 1})
    assert again.same(substitute(f, {"x": y + 1}))


def test_node_memo_is_by_identity_and_keeps_its_nodes():
    memo = NodeMemo(size=2)
    a, b = x + y, x + y  # equal terms, two objects
    memo.put(a, "a")
    assert memo.get(a) == "a" and memo.get(b) is None
    alive = weakref.ref(a)
    del a
    gc.collect()
    # the memo holds the node, so its id cannot be taken by a new node while remembered
    assert alive() is not None
    memo.put(b, "b")
    memo.put(y + z, "c")  # a third entry: the memo starts afresh and lets its nodes go
    gc.collect()
    assert alive() is None and memo.get(b) is None


def test_dot_checks_lengths():
    with pytest.raises(ModelError, match="length 2 and 3"):
        dot([x, y], [x, y, z])
    assert str(dot([x, y], [y, z])) == "x*y + y*z"


def test_quantifying_over_a_term_is_rejected():
    with pytest.raises(ModelError, match="plain symbol"):
        ForAll(x + 1, x > 0)


def test_a_pickled_term_is_a_copy_of_its_fields_and_caches():
    """A process pool pickles a theorem on another thread while this one fills the terms' caches:
    a pickle must take a copy of the fields, never iterate the live dict."""
    import pickle

    from certiloop.models import Reals

    x, y = Reals("x y")
    f = (x * y + 1 <= 2 * x) & (y >= 0)
    key = f.key  # fills the cache
    assert "_key" in f.__dict__
    state = f.__getstate__()
    assert state == f.__dict__ and state is not f.__dict__
    back = pickle.loads(pickle.dumps(f))
    assert back.key == key and back is not f
    assert str(back.sort) == str(f.sort) and f.sort.__getstate__() is not f.sort.__dict__
