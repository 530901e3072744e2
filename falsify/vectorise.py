"""Compile model terms and formulas into numpy closures over a batch of runs.

The batch simulator keeps one float64 array per scalar symbol (one entry per run, or a
(runs, times) grid when a flow is sampled) and evaluates each `Node` once per statement for
the whole batch, instead of once per run as `evaluate.Compiler` does. Compiled: real
scalars, families of reals or Booleans over one index sort (an array with the family axis
last, its size fixed per batch: `VCompiler.size`), symbols of the index sort (an element
per run, as a float), and ∀/∃ over the index sort (the body once per element, reduced).
Integers, arrays, Boolean symbols and other quantifiers raise `Unsupported`, and such a
model keeps the per-run interpreter. Semantics follow the interpreter's float closures
(equality up to `EQUAL_TOLERANCE`, margins signed by truth).
"""

from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from certiloop.falsify.evaluate import EQUAL_TOLERANCE
from certiloop.models.lang.terms import Node

Env = dict[str, Any]  # symbol -> float64 array (broadcastable)
VFn = Callable[[Env], Any]


class Unsupported(Exception):
    """The model uses a construct the batch simulator does not compile."""


def is_index_sort(sort) -> bool:
    """An index sort (boundaries B): neither a number, a Boolean nor an array."""
    return not sort.is_numeric and sort.name != "Bool" and not sort.is_array


def check_family(n: Node) -> None:
    """A family the batch keeps: reals or Booleans over one index sort."""
    sort = n.sort
    if len(sort.domain) != 1 or not is_index_sort(sort.domain[0]) or sort.range.name not in ("Real", "Bool"):
        raise Unsupported(f"`{n}` is not a family of reals or Booleans over one index sort")


class VCompiler:
    """Closures env -> array, cached per node key. `size` is the index sort's size in the
    batch being run (the closures of quantifiers read it when called)."""

    def __init__(self) -> None:
        self._cache: dict[tuple, VFn] = {}
        self.size = 0

    def __call__(self, n: Node) -> VFn:
        fn = self._cache.get(n.key)
        if fn is None:
            fn = self._cache[n.key] = self._compile(n)
        return fn

    def _compile(self, n: Node) -> VFn:  # noqa: C901 - one case per operator
        op = n.op
        if op == "const":
            value = float(n.payload)
            return lambda env: value
        if op == "true":
            return lambda env: True
        if op == "false":
            return lambda env: False
        if op == "var":
            _check_symbol(n)
            name = n.payload
            return lambda env: env[name]
        if op == "select":
            return self._select(n)
        if op in ("forall", "exists"):
            return self._quantifier(n)
        if op in ("store", "box", "diamond", "apply"):
            raise Unsupported(f"`{op}` in `{n}`")
        args = [self(a) for a in n.args]
        if op == "+":
            def add(env):
                out = args[0](env)
                for a in args[1:]:
                    out = out + a(env)
                return out
            return add
        if op == "*":
            def mul(env):
                out = args[0](env)
                for a in args[1:]:
                    out = out * a(env)
                return out
            return mul
        if op == "neg":
            a = args[0]
            return lambda env: -a(env)
        if op == "/":
            a, b = args
            return lambda env: a(env) / b(env)  # 1/0 gives inf/nan: such runs are dropped
        if op == "^":
            a, k = args[0], n.payload
            if not isinstance(k, int):
                raise Unsupported(f"exponent {k!r}")
            return lambda env: a(env) ** k
        if op == "cmp":
            if not n.args[0].sort.is_numeric:
                raise Unsupported(f"comparison of non-numbers `{n}`")
            return _comparison(n.payload, *args)
        if op == "and":
            return lambda env: _reduce(np.logical_and, [a(env) for a in args], True)
        if op == "or":
            return lambda env: _reduce(np.logical_or, [a(env) for a in args], False)
        if op == "not":
            a = args[0]
            return lambda env: np.logical_not(a(env))
        if op == "implies":
            a, b = args
            return lambda env: np.logical_or(np.logical_not(a(env)), b(env))
        if op == "iff":
            a, b = args
            return lambda env: np.equal(np.asarray(a(env), bool), np.asarray(b(env), bool))
        raise Unsupported(f"`{op}` in `{n}`")

    def _select(self, n: Node) -> VFn:
        """A family's cell: at an element bound by a quantifier (an int: one column) or at a
        symbol of the index sort (an element per run: one column per run)."""
        root = n.args[0]
        if root.op != "var" or len(n.args) != 2 or n.args[1].op != "var":
            raise Unsupported(f"`{n}` is not a family read at a symbol")
        check_family(root)
        name, idx = root.payload, self(n.args[1])

        def cell(env):
            table, at = env[name], idx(env)
            if isinstance(at, (int, np.integer)):
                return table[..., at]
            return gather(table, at)
        return cell

    def _quantifier(self, n: Node) -> VFn:
        """∀/∃ over the index sort: the body once per element, and-ed / or-ed, left to right."""
        if len(n.payload) != 1 or not is_index_sort(n.payload[0].sort):
            raise Unsupported(f"a quantifier over `{', '.join(str(v) for v in n.payload)}` in `{n}`")
        name, body, every = n.payload[0].payload, self(n.args[0]), n.op == "forall"
        join = np.logical_and if every else np.logical_or

        def quantify(env):
            inner, out = dict(env), every
            for k in range(self.size):
                inner[name] = k
                out = join(out, body(inner))
            return out
        return quantify

    def element_margin(self, n: Node) -> VFn:
        """The margin of a ∀ over the index sort as the interpreter's guarantee parts see it:
        the body's margin at every element, the smallest of them (1 for no element)."""
        name, body = n.payload[0].payload, self.margin(n.args[0])

        def smallest(env):
            inner, out = dict(env), np.inf
            for k in range(self.size):
                inner[name] = k
                out = np.minimum(out, body(inner))
            return np.where(np.isinf(out), 1.0, out)
        return smallest

    # ------------------------------------------------------------------ margins
    def margin(self, n: Node) -> VFn:
        """Vectorised `evaluate.margin`: >= 0 where n holds, < 0 where it is violated."""
        raw, truth = self._margin(n), self(n)
        tiny = math.ulp(0.0)

        def signed(env):
            m, t = raw(env), truth(env)
            return np.where(t, np.where(m >= 0, m, 0.0), np.where(m < 0, m, -tiny))
        return signed

    def _margin(self, n: Node) -> VFn:
        op = n.op
        truth = self(n)
        if op == "cmp":
            a, b = self(n.args[0]), self(n.args[1])
            if n.payload in (">=", ">"):
                return lambda env: a(env) - b(env)
            if n.payload in ("<=", "<"):
                return lambda env: b(env) - a(env)
            if n.payload == "==":
                return lambda env: -np.abs(a(env) - b(env))
            return lambda env: np.where(truth(env), np.abs(a(env) - b(env)), -1.0)
        if op in ("and", "or"):
            parts = [self.margin(x) for x in n.args]
            pick = np.minimum if op == "and" else np.maximum
            return lambda env: _reduce(pick, [p(env) for p in parts], None)
        if op == "not":
            inner = self.margin(n.args[0])
            return lambda env: -inner(env)
        if op == "implies":
            a, b = self.margin(n.args[0]), self.margin(n.args[1])
            return lambda env: np.maximum(-a(env), b(env))
        return lambda env: np.where(truth(env), 1.0, -1.0)


def _check_symbol(n: Node) -> None:
    sort = n.sort
    if sort.is_array:
        raise Unsupported(f"the family `{n}` read as a whole")
    if sort.name == "Bool":
        raise Unsupported(f"Boolean symbol `{n}`")
    if sort.is_numeric and sort.name != "Real":
        raise Unsupported(f"`{n}` is not real-valued")


def gather(table: np.ndarray, at) -> np.ndarray:
    """table[..., at] with one element per run (floats; an open element, nan, reads some
    column: such runs do not use the value)."""
    cols = np.asarray(at).astype(np.intp)  # nan -> some integer, clipped below
    np.minimum(np.maximum(cols, 0, out=cols), table.shape[-1] - 1, out=cols)  # np.clip: 4x slower
    if table.ndim == 2 and cols.shape == table.shape[:1]:  # (runs, elements): the hot case
        return table[_rows(cols.shape[0]), cols]
    cols = np.broadcast_to(cols, table.shape[:-1])
    return np.take_along_axis(table, cols[..., None], axis=-1)[..., 0]


_ARANGE: dict[int, np.ndarray] = {}


def _rows(n: int) -> np.ndarray:
    got = _ARANGE.get(n)
    if got is None:
        got = _ARANGE[n] = np.arange(n)
    return got


def _reduce(fn, values: list, empty):
    if not values:
        return empty
    out = values[0]
    for v in values[1:]:
        out = fn(out, v)
    return out


def _comparison(op: str, a: VFn, b: VFn) -> VFn:
    if op == "<":
        return lambda env: a(env) < b(env)
    if op == "<=":
        return lambda env: a(env) <= b(env)
    if op == ">":
        return lambda env: a(env) > b(env)
    if op == ">=":
        return lambda env: a(env) >= b(env)
    equal = op == "=="

    def near(env):
        x, y = a(env), b(env)
        close = np.abs(x - y) <= EQUAL_TOLERANCE * (1 + np.abs(x) + np.abs(y))
        return close if equal else np.logical_not(close)
    return near


def read_order(n: Node) -> list[str]:
    """The symbols a term (or an atom) reads, in the order the interpreter's closures read
    them: left to right, a division's denominator before its numerator."""
    out: dict[str, None] = {}

    def walk(x: Node) -> None:
        if x.op == "var":
            out.setdefault(x.payload, None)
            return
        args = x.args
        if x.op == "/":
            args = (args[1], args[0])
        for a in args:
            walk(a)
    walk(n)
    return list(out)


def conjuncts(f: Node) -> list[Node]:
    if f.op == "and":
        return [a for x in f.args for a in conjuncts(x)]
    return [f]


Leaf = tuple[str, "str | None"]  # a symbol (name, None), or a family's cell (family, index symbol)


def leaves(n: Node) -> list[Leaf]:
    """The values a term or formula reads, in the interpreter's read order (`read_order`): a
    cell's index symbol before the cell. Variables a quantifier binds are not values; a cell
    read at one is a leaf for every element."""
    out: dict[Leaf, None] = {}

    def walk(x: Node, bound: frozenset) -> None:
        if x.op == "var":
            if x.payload not in bound and not x.sort.is_array:
                out.setdefault((x.payload, None), None)
            return
        if x.op == "select" and len(x.args) == 2 and x.args[1].op == "var":
            walk(x.args[1], bound)
            out.setdefault((x.args[0].payload, x.args[1].payload), None)
            return
        if x.op in ("forall", "exists"):
            walk(x.args[0], bound | {v.payload for v in x.payload})
            return
        for a in (x.args[1], x.args[0]) if x.op == "/" else x.args:
            walk(a, bound)
    walk(n, frozenset())
    return list(out)
