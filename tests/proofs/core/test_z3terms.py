"""The z3 translator builds, through z3's C API, exactly the terms z3's Python layer builds.

The reference below is the translator certiloop used before (one z3 Python object per
node, z3's own coercions). Both translate into one context, where z3 shares equal terms,
so equal terms are the same AST: `eq` is identity, not equivalence. Identical input means
z3 searches exactly as before, with the same resource count and the same verdict.
"""

from __future__ import annotations

from fractions import Fraction

import pytest
import z3

from certiloop.models import library
from certiloop.models.lang.terms import (
    BOOL,
    FALSE,
    INT,
    REAL,
    And,
    Array,
    Bool,
    Exists,
    Family,
    ForAll,
    Iff,
    Implies,
    IndexSort,
    Int,
    Node,
    Not,
    Or,
    Real,
    Var,
    cmp,
    const,
    store,
)
from certiloop.proofs.arith.projection import abbreviation_instances
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.core.weaken import weakenings
from certiloop.proofs.core.z3terms import Z3Translator


class Reference:
    """z3's Python layer, node by node, into a given context."""

    def __init__(self, tr: Z3Translator) -> None:
        self.tr = tr

    def __call__(self, n: Node, bound: dict | None = None) -> z3.ExprRef:
        bound = bound or {}
        op, ctx = n.op, self.tr.ctx
        if op == "const":
            f = n.payload
            return z3.IntVal(f.numerator, ctx) if n.sort == INT else z3.RealVal(
                f"{f.numerator}/{f.denominator}", ctx)
        if op == "var":
            return bound[n.payload] if n.payload in bound else z3.Const(n.payload, self.tr.sort(n.sort))
        if op in ("true", "false"):
            return z3.BoolVal(op == "true", ctx)
        if op in ("forall", "exists"):
            inner = dict(bound)
            zs = [z3.Const(v.payload, self.tr.sort(v.sort)) for v in n.payload]
            inner.update({v.payload: z for v, z in zip(n.payload, zs)})
            body = self(n.args[0], inner)
            return z3.ForAll(zs, body) if op == "forall" else z3.Exists(zs, body)
        sub = [self(a, bound) for a in n.args]
        if op == "+":
            return z3.Sum(*sub) if len(sub) > 1 else sub[0]
        if op == "*":
            return z3.Product(*sub) if len(sub) > 1 else sub[0]
        if op == "neg":
            return -sub[0]
        if op == "/":
            a, b = sub
            return z3.ToReal(a) / z3.ToReal(b) if z3.is_int(a) and z3.is_int(b) else a / b
        if op == "^":
            return z3.Product(*([sub[0]] * n.payload)) if n.payload > 1 else (
                sub[0] if n.payload == 1 else z3.IntVal(1, ctx))
        if op == "select":
            return z3.Select(sub[0], *sub[1:])
        if op == "store":
            return z3.Store(sub[0], *sub[1:])
        if op == "cmp":
            a, b = sub
            return {"<": lambda: a < b, "<=": lambda: a <= b, ">": lambda: a > b, ">=": lambda: a >= b,
                    "==": lambda: a == b, "!=": lambda: a != b}[n.payload]()
        if op == "and":
            return z3.And(*sub)
        if op == "or":
            return z3.Or(*sub)
        if op == "not":
            return z3.Not(sub[0])
        if op == "implies":
            return z3.Implies(*sub)
        if op == "iff":
            return sub[0] == sub[1]
        raise TypeError(op)


def assert_same_terms(f: Node) -> None:
    tr = Z3Translator()
    ours = tr(f)
    assert ours.eq(Reference(tr)(f)), f"the C-API translation differs from z3's Python layer's for {f}"


x, y, z = Real("x"), Real("y"), Real("z")
i, j = Int("i"), Int("j")
p, q = Bool("p"), Bool("q")
B = IndexSort("B")
b, c = Var("b", B), Var("c", B)

NODE_KINDS = [
    x + y * 2 - z / 3 >= Fraction(-7, 4),
    x ** 0 + x ** 1 + x ** 3 + (x + y) ** 2 > -1,
    -x == Fraction(5, 2),
    i + 2 * j - 1 < i * j,  # Int arithmetic
    x + i <= 3,  # Real meets Int: to_real inside the sum
    i / j > x,  # Int/Int division is real division
    (i ** 2) * x > -i,  # an Int power beside a Real
    i * j * x + i + j > i / j,  # several to_real terms built before their parent
    cmp("==", i, const(Fraction(3))),
    cmp("!=", x, i),
    And(p, Or(q, Not(p)), Implies(q, p), Iff(p, q)),
    cmp("==", p, q),
    ForAll(x, Exists([y, i], y * y == x + i)),
    ForAll(x, x * y >= 0) | (x * y >= 0),  # a subterm free outside, bound inside
    ForAll(b, Family("nx", B)(b) >= 0),
    cmp("==", b, c),
    Not(cmp("==", b, c)) | (Family("on", B, BOOL)(b)),
    Array("a", INT)[i + 1] == Array("a", INT)[i] + 1,
    Array("m", (INT, INT, INT), INT)[i, j, 1] > 0,
    cmp("==", store(Array("a", INT), (i,), x), Array("a", INT)),
    store(Array("m", (B, INT), REAL), (b, i), const(2))[c, j] <= x,
    store(Array("k", INT, INT), (i,), j)[j] >= i,  # Int values
    Node("or", (p,), BOOL),
    FALSE,
]


@pytest.mark.parametrize("f", NODE_KINDS, ids=lambda f: str(f)[:40])
def test_every_node_kind_is_the_same_term(f):
    assert_same_terms(f)


def test_a_shared_subterm_inside_and_outside_a_binder_keeps_its_binding():
    inner = x * y >= 0  # one object: free at the top, bound under ∀x
    f = And(inner, ForAll(x, Implies(inner, inner)))
    assert_same_terms(f)
    assert check_valid(f, 100_000).status == "sat"  # not valid: x*y >= 0 fails at x=1,y=-1


def _checked_forms(model: str):
    """Every formula the prover sends to z3 for the model: each obligation as stated and
    all its weakenings (instantiated, lowered, abstracted)."""
    for ob in generate(library.get(model)):
        yield ob.formula
        for _, weaker in weakenings(ob.formula, ob.abbreviations, abbreviation_instances, ob.stronger):
            yield weaker


QUICK = ["sbs.ctrl1", "sbs.predictive", "cfmpa.builtdr", "textbook.bouncing_ball", "rcm.passivity",
         "raven.jump_detected", "cfmpa.property8"]


@pytest.mark.parametrize("model", QUICK)
def test_library_obligations_are_the_same_terms(model):
    for f in _checked_forms(model):
        assert_same_terms(f)


@pytest.mark.slow
@pytest.mark.parametrize("model", [m for m in library.names() if m not in QUICK])
def test_every_library_obligation_is_the_same_term(model):
    for f in _checked_forms(model):
        assert_same_terms(f)


@pytest.mark.parametrize("f", NODE_KINDS, ids=lambda f: str(f)[:40])
def test_released_translator_leaves_its_python_terms_intact(f):
    """`release` drops only the translator's own references: a z3 object made before it
    (the goal a check asserts) still denotes the same term, and z3 decides it the same way."""
    tr = Z3Translator()
    goal = z3.Not(tr(f))
    text = goal.sexpr()
    before = z3.Solver(ctx=tr.ctx)
    before.add(goal)
    expected = before.check()
    tr.release()
    tr.release()  # a second release does nothing
    for k in range(50):  # z3 frees unreferenced terms when it next builds one
        z3.Real(f"fresh{k}", tr.ctx) + k
    assert goal.sexpr() == text and z3.Not(goal.arg(0)).eq(goal)
    after = z3.Solver(ctx=tr.ctx)
    after.add(goal)
    assert after.check() == expected
