"""Evaluate a formula at a concrete state exactly (rationals) or with rational intervals.

This is how a solver's counterexample is checked independently of the solver: the
obligation, with the model's values substituted, must evaluate to false.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from certiloop.models.terms import Node

from . import interval as iv
from .smt import ArrayValue


class Undecided(Exception):
    """The evaluator cannot decide this formula (a quantifier, or intervals too wide)."""


def evaluate(n: Node, state: dict[str, Any]) -> Any:
    op = n.op
    if op == "const":
        return n.payload
    if op == "var":
        if n.payload not in state:
            raise Undecided(f"no value for `{n.payload}`")
        return state[n.payload]
    if op == "true":
        return True
    if op == "false":
        return False
    if op in ("forall", "exists", "box", "diamond"):
        raise Undecided(f"cannot evaluate the quantified formula `{n}` exactly")
    if op == "and":
        vals = [evaluate(a, state) for a in n.args]
        if any(v is False for v in vals):
            return False
        return True if all(v is True for v in vals) else None
    if op == "or":
        vals = [evaluate(a, state) for a in n.args]
        if any(v is True for v in vals):
            return True
        return False if all(v is False for v in vals) else None
    if op == "not":
        v = evaluate(n.args[0], state)
        return None if v is None else not v
    if op == "implies":
        a = evaluate(n.args[0], state)
        if a is False:
            return True
        b = evaluate(n.args[1], state)
        if b is True:
            return True
        return False if (a is True and b is False) else None
    if op == "iff":
        a, b = (evaluate(x, state) for x in n.args)
        return None if a is None or b is None else a == b
    if op == "select":
        arr = evaluate(n.args[0], state)
        idx = tuple(index_value(evaluate(i, state)) for i in n.args[1:])
        if not isinstance(arr, ArrayValue):
            raise Undecided(f"no exact value for the array `{n.args[0]}`")
        return arr.get(idx)
    if op == "store":
        arr = evaluate(n.args[0], state)
        *idx, val = n.args[1:]
        if not isinstance(arr, ArrayValue):
            raise Undecided(f"no exact value for the array `{n.args[0]}`")
        entries = dict(arr.entries)
        entries[tuple(index_value(evaluate(i, state)) for i in idx)] = evaluate(val, state)
        return ArrayValue(entries, arr.default)
    if op == "cmp":
        a, b = (evaluate(x, state) for x in n.args)
        if not _numeric(a) or not _numeric(b):
            if isinstance(a, (Fraction, int)) or isinstance(b, (Fraction, int)):
                raise Undecided(f"cannot compare `{n}`")
            return (a == b) if n.payload == "==" else (a != b) if n.payload == "!=" else None
        return iv.compare(n.payload, iv.lift(a), iv.lift(b))
    vals = [iv.lift(evaluate(a, state)) for a in n.args]
    if op == "+":
        out = vals[0]
        for v in vals[1:]:
            out = iv.add(out, v)
        return out
    if op == "*":
        out = vals[0]
        for v in vals[1:]:
            out = iv.mul(out, v)
        return out
    if op == "neg":
        return iv.neg(vals[0])
    if op == "/":
        try:
            return iv.div(vals[0], vals[1])
        except ZeroDivisionError:
            raise Undecided(f"division by zero in `{n}`") from None
    if op == "^":
        return iv.power(vals[0], n.payload)
    raise Undecided(f"cannot evaluate `{n}`")


def _numeric(x: Any) -> bool:
    return isinstance(x, (Fraction, iv.Interval)) or (isinstance(x, int) and not isinstance(x, bool))


def index_value(x: Any) -> Any:
    if isinstance(x, Fraction) and x.denominator == 1:
        return int(x)
    if isinstance(x, iv.Interval):
        raise Undecided("an array index is only known approximately")
    return x


def truth(n: Node, state: dict[str, Any]) -> bool | None:
    """True/False if decided exactly, None if intervals could not decide it."""
    try:
        v = evaluate(n, state)
    except Undecided:
        return None
    if v is not None and not isinstance(v, bool):
        raise TypeError(f"`{n}` is not a formula")
    return v
