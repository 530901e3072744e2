"""Compile model terms and formulas into Python closures over a concrete state.

The interpreter evaluates the same tests and assignments many thousands of times, so each
`Node` is turned once into a closure `f(state)`. A state maps symbol names to numbers
(floats, or Fractions for exact replay), booleans or index elements (ints), arrays and
families to a `Table`, and `#universe:S` to the elements of index sort S.

A read of a value nobody has chosen yet (a nondeterministic assignment not yet resolved, an
array cell never written) raises `NeedValue`; the interpreter decides it (by solving the
test that reads it, or by asking its chooser) and evaluates again.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any, Callable

from certiloop.models.lang.terms import BOOL, INT, ModelError, Node

Key = str | tuple[str, tuple]  # a symbol, or (array, index tuple) for one cell
Fn = Callable[[dict[str, Any]], Any]


class NeedValue(Exception):
    """A value that is still open was read."""

    def __init__(self, key: Key, sort) -> None:
        super().__init__(key)
        self.key, self.sort = key, sort


class Blocked(Exception):
    """No run through here: a test failed, an ODE's domain does not hold, 1/0."""


class BlockedByTest(Blocked):
    """A test `?cond` failed. The message is written only when shown: runs block by the
    thousand in a search, and printing the condition was 7 % of a sbs.ctrl2 run."""

    def __init__(self, cond) -> None:
        super().__init__(cond)
        self.cond = cond

    def __str__(self) -> str:
        return f"test {self.cond} failed"


OPEN = object()  # a cell made open again by `a[i] := *` in a table with a default


class Table:
    """The cells of an array or family that have values; a missing cell is still open,
    unless the table has a default (arrays replayed from a solver's model)."""

    __slots__ = ("cells", "default")

    def __init__(self, cells: dict[tuple, Any] | None = None, default: Any = None) -> None:
        self.cells = cells if cells is not None else {}
        self.default = default

    def copy(self) -> "Table":
        return Table(dict(self.cells), self.default)

    def read(self, key: tuple) -> Any:
        value = self.cells.get(key, self.default)
        return None if value is OPEN else value

    def __repr__(self) -> str:
        return f"Table({self.cells})"


def universe(state: dict[str, Any], sort) -> range:
    try:
        return state[f"#universe:{sort.name}"]
    except KeyError:
        raise ModelError(f"no size was chosen for the index sort {sort.name}") from None


BY_ID_LIMIT = 100_000  # nodes remembered by identity per compiler


class Compiler:
    """Closures for one number type: float for search, Fraction for exact replay."""

    def __init__(self, exact: bool = False) -> None:
        self.exact = exact
        self._cache: dict[tuple, Fn] = {}
        # by the node object too: a key is a nested tuple whose hash Python recomputes on every
        # lookup (the interpreter asks for the same nodes' closures thousands of times a run).
        # The node is kept with its closure, so that its id is not reused while cached.
        self._by_id: dict[int, tuple[Node, Fn]] = {}

    def __call__(self, n: Node) -> Fn:
        got = self._by_id.get(id(n))
        if got is not None and got[0] is n:
            return got[1]
        fn = self._cache.get(n.key)
        if fn is None:
            fn = self._compile(n)
            self._cache[n.key] = fn
        if len(self._by_id) >= BY_ID_LIMIT:  # nodes built on the fly: the keys still dedupe them
            self._by_id.clear()
        self._by_id[id(n)] = (n, fn)
        return fn

    def number(self, x: Any) -> Any:
        return Fraction(x) if self.exact else float(x)

    def _compile(self, n: Node) -> Fn:  # noqa: C901 - one case per operator
        op, c = n.op, self
        if op == "const":
            value = self.number(n.payload)
            return lambda s: value
        if op == "true":
            return lambda s: True
        if op == "false":
            return lambda s: False
        if op == "var":
            name, sort = n.payload, n.sort

            def read(s):
                try:
                    return s[name]
                except KeyError:
                    raise NeedValue(name, sort) from None
            return read
        if op == "select":
            root, idx = n.args[0], [c(i) for i in n.args[1:]]
            if root.op != "var":
                raise ModelError(f"cannot execute the array expression `{root}`")
            name, sort = root.payload, n.sort

            if len(idx) == 1:  # families over one index sort: the common, hot case
                only = idx[0]

                def cell(s):
                    i = only(s)
                    key = (i if type(i) is int else index(i),)  # an int index as is: the hot path
                    value = s[name].read(key)
                    if value is None:
                        raise NeedValue((name, key), sort)
                    return value
                return cell

            def cells(s):
                key = tuple(index(i(s)) for i in idx)
                value = s[name].read(key)
                if value is None:
                    raise NeedValue((name, key), sort)
                return value
            return cells
        args = [c(a) for a in n.args]
        if op == "+":
            if len(args) == 2:
                a, b = args
                return lambda s: a(s) + b(s)
            return lambda s: sum((a(s) for a in args[1:]), args[0](s))
        if op == "*":
            if len(args) == 2:
                a, b = args
                return lambda s: a(s) * b(s)
            def product(s):
                out = args[0](s)
                for a in args[1:]:
                    out = out * a(s)
                return out
            return product
        if op == "neg":
            a = args[0]
            return lambda s: -a(s)
        if op == "/":
            a, b = args

            def divide(s):
                den = b(s)
                if den == 0:
                    raise Blocked(f"division by zero in `{n}`")
                return a(s) / den
            return divide
        if op == "^":
            a, k = args[0], n.payload
            return lambda s: a(s) ** k
        if op == "cmp":
            if not self.exact and n.payload in ("==", "!=") and n.args[0].sort.is_numeric:
                return _near(n.payload == "==", *args)
            return _comparison(n.payload, *args)
        if op == "and":
            return lambda s: all(a(s) for a in args)
        if op == "or":
            return lambda s: any(a(s) for a in args)
        if op == "not":
            a = args[0]
            return lambda s: not a(s)
        if op == "implies":
            a, b = args
            return lambda s: (not a(s)) or b(s)
        if op == "iff":
            a, b = args
            return lambda s: a(s) == b(s)
        if op in ("forall", "exists"):
            return self._quantifier(n)
        if op in ("box", "diamond"):
            shown = " ".join(str(n).split())
            shown = shown if len(shown) <= 60 else shown[:57] + "..."
            raise ModelError(f"the falsifier cannot evaluate the modal formula `{shown}` (a modality "
                             "inside the guarantee or an assumption); state it as the claim's program")
        raise ModelError(f"cannot execute `{n}`")

    def _quantifier(self, n: Node) -> Fn:
        variables, body = n.payload, self(n.args[0])
        pools = [_pool(v, n.args[0], self) for v in variables]
        names = [v.payload for v in variables]
        want_all = n.op == "forall"

        def quantify(s):
            saved = {x: s[x] for x in names if x in s}
            try:
                return _enumerate(s, names, pools, body, want_all)
            finally:
                for x in names:
                    s.pop(x, None)
                s.update(saved)
        return quantify


def _enumerate(s, names, pools, body, want_all) -> bool:
    def go(k: int) -> bool:
        if k == len(names):
            return bool(body(s))
        for x in pools[k](s):
            s[names[k]] = x
            if go(k + 1) != want_all:
                return not want_all
        return want_all
    return go(0)


def _pool(v: Node, body: Node, compiler: Compiler) -> Callable[[dict], Any]:
    """The values a bound variable ranges over: an index sort's universe, or the integers
    its guard bounds (∀i. 0 <= i ∧ i < N -> ...)."""
    if v.sort == INT:
        lo, hi = int_bounds(v.payload, body, compiler)
        if lo is None or hi is None:
            raise ModelError(f"cannot execute a quantifier over `{v.payload}`: its guard does not bound it")
        return lambda s: range(math.ceil(lo(s)), math.floor(hi(s)) + 1)
    if v.sort.is_numeric or v.sort == BOOL:
        if v.sort == BOOL:
            return lambda s: (False, True)
        raise ModelError(f"cannot execute a quantifier over the real `{v.payload}`")
    sort = v.sort
    return lambda s: universe(s, sort)


def int_bounds(name: str, body: Node, compiler: Compiler):
    """Closures for the least and greatest value the guard of `body` allows `name`."""
    guard = body.args[0] if body.op in ("implies", "and") else body
    los, his = [], []
    for atom in guard.args if guard.op == "and" else (guard,):
        if atom.op != "cmp":
            continue
        a, b, op = atom.args[0], atom.args[1], atom.payload
        if b.op == "var" and b.payload == name:
            a, b = b, a
            op = {"<": ">", "<=": ">=", ">": "<", ">=": "<="}.get(op, op)
        if not (a.op == "var" and a.payload == name):
            continue
        bound = compiler(b)
        if op == "<":
            his.append(lambda s, f=bound: math.ceil(f(s)) - 1)
        elif op == "<=":
            his.append(bound)
        elif op == ">":
            los.append(lambda s, f=bound: math.floor(f(s)) + 1)
        elif op == ">=":
            los.append(bound)
    lo = (lambda s: max(f(s) for f in los)) if los else None
    hi = (lambda s: min(f(s) for f in his)) if his else None
    return lo, hi


def _comparison(op: str, a: Fn, b: Fn) -> Fn:
    if op == "<":
        return lambda s: a(s) < b(s)
    if op == "<=":
        return lambda s: a(s) <= b(s)
    if op == ">":
        return lambda s: a(s) > b(s)
    if op == ">=":
        return lambda s: a(s) >= b(s)
    if op == "==":
        return lambda s: a(s) == b(s)
    return lambda s: a(s) != b(s)


EQUAL_TOLERANCE = 1e-9  # relative; floats that landed on a boundary by root finding


def _near(equal: bool, a: Fn, b: Fn) -> Fn:
    """Float equality up to rounding: a flow stopped at h = 0 by root finding ends at
    h = 1e-16, and `?h = 0` must still see the ball on the ground; a value pinned by
    `?tmp*G = 1` satisfies it only up to rounding. Runs found this way are
    re-checked exactly (or by a margin far above this tolerance) before being reported."""
    def near(s):
        x, y = a(s), b(s)
        return (abs(x - y) <= EQUAL_TOLERANCE * (1 + abs(x) + abs(y))) == equal
    return near


def index(x: Any) -> Any:
    """Array indices are ints (index elements, integer counters); 2.0 reads cell 2."""
    if type(x) is int:
        return x
    if isinstance(x, bool):
        return x
    if isinstance(x, (float, Fraction)):
        if x != int(x):
            raise Blocked(f"non-integral array index {x}")
        return int(x)
    return x


# --------------------------------------------------------------------------- robustness


def margin(n: Node, compiler: Compiler) -> Fn:
    """How far a formula is from being false: >= 0 where it holds (for comparisons of
    numbers the signed distance, for connectives min/max), < 0 where it is violated. Used
    to steer the search towards violations and to plot distances to boundaries.

    The distances alone can sit at 0 on the wrong side (`which = 3 -> x = 0` at which = 3,
    x = 1 is max(0, -1) = 0), so the sign comes from the formula's truth: a violated
    formula whose distance says 0 gets the smallest negative float, which no tolerance
    mistakes for a deep violation."""
    raw, truth = _margin(n, compiler), compiler(n)

    def signed(s) -> float:
        m = raw(s)
        if truth(s):
            return m if m >= 0 else 0.0
        return m if m < 0 else -math.ulp(0.0)
    return signed


def _margin(n: Node, compiler: Compiler) -> Fn:
    op = n.op
    if op == "cmp":
        a, b = compiler(n.args[0]), compiler(n.args[1])
        if n.payload in (">=", ">"):
            return lambda s: float(a(s) - b(s))
        if n.payload in ("<=", "<"):
            return lambda s: float(b(s) - a(s))
        truth = compiler(n)
        if n.args[0].sort.is_numeric:
            if n.payload == "==":
                return lambda s: -abs(float(a(s) - b(s)))
            return lambda s: abs(float(a(s) - b(s))) if truth(s) else -1.0
        return lambda s: 1.0 if truth(s) else -1.0
    if op in ("and", "or"):
        parts = [margin(x, compiler) for x in n.args]
        pick = min if op == "and" else max
        return lambda s: pick(p(s) for p in parts)
    if op == "not":
        inner = margin(n.args[0], compiler)
        return lambda s: -inner(s)
    if op == "implies":
        a, b = margin(n.args[0], compiler), margin(n.args[1], compiler)
        return lambda s: max(-a(s), b(s))
    if op in ("forall", "exists"):
        truth = compiler(n)
        return lambda s: 1.0 if truth(s) else -1.0
    truth = compiler(n)
    return lambda s: 1.0 if truth(s) else -1.0
