"""Model terms -> z3 terms, through z3's C API (trusted: what z3 is asked is built here).

z3's Python layer wraps every intermediate term in an object with its own reference count,
sort lookups and coercions: about 20 µs per node, which made translation three quarters of
a check on the `sbs` obligations. Here each node is one C call (plus a reference count), a
subterm shared by several parents is translated once, and sorts are followed on our side.
The terms built are exactly those z3's Python layer builds for the same expressions (same
calls, same Int -> Real coercions: `tests/proofs/core/test_z3terms.py` checks AST identity against it
on every library obligation), so z3 searches exactly as before and no verdict changes.
"""

from __future__ import annotations

import ctypes
from fractions import Fraction

import z3
from z3 import z3core
from z3.z3 import _to_expr_ref  # the typed Python object for a raw term

from certiloop.models.lang.terms import BOOL, INT, REAL, Node, Sort

_COMPARE = {"<": z3core.Z3_mk_lt, "<=": z3core.Z3_mk_le, ">": z3core.Z3_mk_gt, ">=": z3core.Z3_mk_ge}
_MIRROR = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "==", "!=": "!="}
_NARY = {"+": z3core.Z3_mk_add, "*": z3core.Z3_mk_mul, "and": z3core.Z3_mk_and, "or": z3core.Z3_mk_or}
_inc_ref = z3core.Z3_inc_ref


class Z3Translator:
    """Translates into its own z3 context: every check starts from a clean slate, so the
    same obligation gets the same search (z3's global context carries state between checks,
    which made results depend on what was checked before).

    `symbols` and `sorts` hold z3's Python objects for the model's symbols and index sorts
    (for reading a model back); everything else stays a raw C term, kept alive by a
    reference this translator holds until `release`."""

    def __init__(self) -> None:
        self.ctx = z3.Context()
        self._c = self.ctx.ref()
        self.sorts: dict[str, z3.SortRef] = {}
        self.symbols: dict[str, z3.ExprRef] = {}
        self._real = z3.RealSort(self.ctx)
        self._int = z3.IntSort(self.ctx)
        self._bool = z3.BoolSort(self.ctx)
        self._memo: dict[int, tuple[Node, z3core.Ast, Sort]] = {}  # id(node): (node kept alive, term, sort)
        self._held: list[z3core.Ast] = []  # every reference taken, oldest first
        self._empty = z3core.Z3_mk_string_symbol(self._c, "")  # a quantifier's qid and skid

    def _hold(self, term: z3core.Ast) -> None:
        _inc_ref(self._c, term)
        self._held.append(term)

    def release(self) -> None:
        """Drops this translator's references to its raw terms; z3's Python objects made from
        them (the goal, the model's symbols) keep their own. Newest first, so each term is
        freed right after its last parent. A context deleted while its terms are still
        referenced frees them by sweeping its whole term table once per level of nesting:
        3.9 ms per check on sbs.ctrl2_dynamic, against 0.1 ms this way. The translator
        must not be used afterwards."""
        dec = z3core.Z3_dec_ref
        for term in reversed(self._held):
            dec(self._c, term)
        self._held.clear()
        self._memo.clear()

    # ---- sorts
    def sort(self, s: Sort) -> z3.SortRef:
        if s == REAL:
            return self._real
        if s == INT:
            return self._int
        if s == BOOL:
            return self._bool
        if s.is_array:
            return z3.ArraySort(*(self.sort(d) for d in s.domain), self.sort(s.range))
        if s.name not in self.sorts:
            self.sorts[s.name] = z3.DeclareSort(s.name, self.ctx)
        return self.sorts[s.name]

    def symbol(self, n: Node) -> z3.ExprRef:
        sym = self.symbols.get(n.payload)
        if sym is None:
            sym = z3.Const(n.payload, self.sort(n.sort))
            self.symbols[n.payload] = sym
        return sym

    # ---- terms
    def __call__(self, n: Node, bound: dict[str, tuple[z3core.Ast, Sort]] | None = None) -> z3.ExprRef:
        ast, _ = self._tr(n, bound or {})
        return _to_expr_ref(ast, self.ctx)

    def _tr(self, n: Node, bound: dict[str, tuple[z3core.Ast, Sort]]) -> tuple[z3core.Ast, Sort]:
        if not bound:
            hit = self._memo.get(id(n))
            if hit is not None:
                return hit[1], hit[2]
        out = self._build(n, bound)
        self._hold(out[0])  # it must outlive later calls, which may build its parents
        if not bound:
            self._memo[id(n)] = (n, *out)
        return out

    def _build(self, n: Node, bound: dict[str, tuple[z3core.Ast, Sort]]) -> tuple[z3core.Ast, Sort]:
        op, c = n.op, self._c
        if op == "const":
            f: Fraction = n.payload
            if n.sort == INT:
                return z3core.Z3_mk_numeral(c, str(f.numerator), self._int.ast), INT
            return z3core.Z3_mk_numeral(c, f"{f.numerator}/{f.denominator}", self._real.ast), REAL
        if op == "var":
            if n.payload in bound:
                return bound[n.payload]
            return self.symbol(n).as_ast(), n.sort
        if op == "true":
            return z3core.Z3_mk_true(c), BOOL
        if op == "false":
            return z3core.Z3_mk_false(c), BOOL
        if op in ("forall", "exists"):
            return self._quantifier(n, bound)
        sub = [self._tr(a, bound) for a in n.args]
        if op in _NARY:
            if len(sub) == 1 and op in ("+", "*"):  # z3.Sum/Product of one term: the term
                return sub[0]
            terms, s = self._common(sub)
            return _NARY[op](c, len(terms), _array(terms)), s
        if op == "^":
            if n.payload == 0:
                return z3core.Z3_mk_numeral(c, "1", self._int.ast), INT
            if n.payload == 1:
                return sub[0]
            return z3core.Z3_mk_mul(c, n.payload, _array([sub[0][0]] * n.payload)), sub[0][1]
        if op == "neg":
            return z3core.Z3_mk_unary_minus(c, sub[0][0]), sub[0][1]
        if op == "/":
            (a, sa), (b, sb) = sub
            if sa == INT and sb == INT:  # real division of integers
                sub = [(self._to_real(a), REAL), (self._to_real(b), REAL)]
            (a, b), _ = self._common(sub)
            return z3core.Z3_mk_div(c, a, b), REAL
        if op == "cmp":
            rel = n.payload
            if self._reflected(sub[0][0], sub[1][0]):
                sub, rel = sub[::-1], _MIRROR[rel]
            (a, b), _ = self._common(sub)
            if rel == "==":
                return z3core.Z3_mk_eq(c, a, b), BOOL
            if rel == "!=":
                return z3core.Z3_mk_distinct(c, 2, _array([a, b])), BOOL
            return _COMPARE[rel](c, a, b), BOOL
        if op == "not":
            return z3core.Z3_mk_not(c, sub[0][0]), BOOL
        if op == "implies":
            return z3core.Z3_mk_implies(c, sub[0][0], sub[1][0]), BOOL
        if op == "iff":
            a, b = sub[0][0], sub[1][0]
            return (z3core.Z3_mk_eq(c, b, a) if self._reflected(a, b) else z3core.Z3_mk_eq(c, a, b)), BOOL
        if op == "select":
            (arr, s), idx = sub[0], sub[1:]
            cast = [self._cast(t, d) for t, d in zip(idx, s.domain)]
            return z3core.Z3_mk_select_n(c, arr, len(cast), _array(cast)), s.range
        if op == "store":
            (arr, s), idx, value = sub[0], sub[1:-1], sub[-1]
            cast = [self._cast(t, d) for t, d in zip(idx, s.domain)]
            v = self._cast(value, s.range)
            if len(cast) == 1:
                return z3core.Z3_mk_store(c, arr, cast[0], v), s
            return z3core.Z3_mk_store_n(c, arr, len(cast), _array(cast), v), s
        raise TypeError(f"cannot send `{n}` to z3 (modalities must be expanded first)")

    def _quantifier(self, n: Node, bound: dict[str, tuple[z3core.Ast, Sort]]) -> tuple[z3core.Ast, Sort]:
        inner = dict(bound)
        names = []
        for v in n.payload:
            zv = z3.Const(v.payload, self.sort(v.sort))
            inner[v.payload] = (zv.as_ast(), v.sort)
            names.append(zv)  # the Python objects keep the bound constants alive
        body, _ = self._tr(n.args[0], inner)
        return z3core.Z3_mk_quantifier_const_ex(
            self._c, n.op == "forall", 1, self._empty, self._empty, len(names),
            _array([v.as_ast() for v in names]), 0, (z3core.Pattern * 0)(), 0, _array([]), body), BOOL

    # ---- what z3's Python layer does implicitly
    def _reflected(self, a: z3core.Ast, b: z3core.Ast) -> bool:
        """Whether Python evaluates `a < b` as `b > a`: it does when b's class is a subclass
        of a's, here a numeral (IntNumRef, RatNumRef) beside another arithmetic term, or a
        quantifier (QuantifierRef) beside another formula."""
        c = self._c
        if z3core.Z3_is_numeral_ast(c, b):
            return not z3core.Z3_is_numeral_ast(c, a)
        return (z3core.Z3_get_ast_kind(c, b) == z3.Z3_QUANTIFIER_AST
                and z3core.Z3_get_ast_kind(c, a) != z3.Z3_QUANTIFIER_AST)

    def _common(self, sub: list[tuple[z3core.Ast, Sort]]) -> tuple[list[z3core.Ast], Sort]:
        """The terms in one sort: Int terms beside a Real one become Real (`to_real`)."""
        if any(s == REAL for _, s in sub) and any(s == INT for _, s in sub):
            return [self._to_real(t) if s == INT else t for t, s in sub], REAL
        return [t for t, _ in sub], sub[0][1]

    def _to_real(self, t: z3core.Ast) -> z3core.Ast:
        out = z3core.Z3_mk_int2real(self._c, t)
        self._hold(out)  # z3 frees an unreferenced term at the next call that builds one
        return out

    def _cast(self, term: tuple[z3core.Ast, Sort], target: Sort) -> z3core.Ast:
        t, s = term
        if s == INT and target == REAL:
            return self._to_real(t)
        if s != target and not (s.is_array and target.is_array):
            raise TypeError(f"a term of sort {s} where z3 expects {target}")
        return t


def _keep_freed_memory() -> None:
    """Every check's fresh context allocates large tables and frees them when it is deleted;
    glibc hands such blocks back to the kernel, and the next context faults them in again
    page by page: 4-5 ms per context, about a fifth of a typical obligation's check. Keeping
    freed blocks in the heap for reuse saves that (a performance setting only)."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc: nothing to tune
        return
    m_trim_threshold, m_mmap_threshold = -1, -3  # glibc's malloc.h
    mallopt(m_mmap_threshold, 32 << 20)  # glibc's ceiling on 64-bit systems
    mallopt(m_trim_threshold, 256 << 20)


_keep_freed_memory()


def _array(terms: list) -> ctypes.Array:
    return (z3core.Ast * len(terms))(*terms)
