"""Compile model terms and formulas into numpy closures over a batch of runs.

The batch simulator keeps one float64 array per scalar symbol (one entry per run, or a
(runs, times) grid when a flow is sampled) and evaluates each `Node` once per statement for
the whole batch, instead of once per run as `evaluate.Compiler` does. Only the scalar real
fragment is compiled: families, arrays, integers, Booleans and quantifiers raise
`Unsupported`, and such a model keeps the per-run interpreter. Semantics follow the
interpreter's float closures (equality up to `EQUAL_TOLERANCE`, margins signed by truth).
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


def check_sort(n: Node) -> None:
    sort = n.sort
    if sort.is_array or (not sort.is_numeric and n.op not in ("true", "false") and sort.name != "Bool"):
        raise Unsupported(f"`{n}` is not a scalar number")
    if sort.is_numeric and sort.name != "Real":
        raise Unsupported(f"`{n}` is not real-valued")


class VCompiler:
    """Closures env -> array, cached per node key."""

    def __init__(self) -> None:
        self._cache: dict[tuple, VFn] = {}

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
            check_sort(n)
            if n.sort.name == "Bool":
                raise Unsupported(f"Boolean symbol `{n}`")
            name = n.payload
            return lambda env: env[name]
        if op in ("select", "store", "forall", "exists", "box", "diamond", "apply"):
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
