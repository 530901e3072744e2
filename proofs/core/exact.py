"""Evaluate a formula at a concrete state exactly (rationals) or with rational intervals.

This is how a solver's counterexample is checked independently of the solver: the
obligation, with the model's values substituted, must evaluate to false.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction
from typing import Any

from certiloop.models.lang.terms import INT, Node, free_vars
from certiloop.proofs.core import interval as iv
from certiloop.proofs.core.solver import ArrayValue


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
    if op in ("forall", "exists"):
        return _bounded_quantifier(n, state)
    if op in ("box", "diamond"):
        raise Undecided(f"cannot evaluate the modal formula `{n}` here")
    if op in ("and", "or"):  # one false conjunct (true disjunct) decides, whatever the others read
        decisive, vals, undecided = op == "or", [], None
        for a in n.args:
            try:
                vals.append(evaluate(a, state))
            except Undecided as exc:  # e.g. a division by zero in another part
                vals.append(None)
                undecided = undecided or exc
        if any(v is decisive for v in vals):
            return decisive
        if undecided is not None:
            raise undecided
        return (not decisive) if all(v is (not decisive) for v in vals) else None
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
        if isinstance(a, ArrayValue) or isinstance(b, ArrayValue):
            equal = _arrays_equal(a, b, n.args[0].sort, state)
            return equal if n.payload == "==" else not equal
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


def _arrays_equal(a: Any, b: Any, sort, state: dict[str, Any]) -> bool:
    """Extensional equality: the same value at every index — over the model's finite
    universe when there is one, else at every index either names plus the defaults."""
    if not isinstance(a, ArrayValue) or not isinstance(b, ArrayValue):
        raise Undecided("an array compared with something that is not one")
    pools = [state.get(f"#universe:{d.name}") for d in sort.domain]
    if all(pool is not None for pool in pools):
        indices = list(itertools.product(*pools))
    else:
        if a.default is None or b.default is None:
            raise Undecided("arrays whose values outside their listed entries are unknown")
        indices = list(set(a.entries) | set(b.entries))
        if not _same(a.default, b.default):
            return False
    return all(_same(a.get(i), b.get(i)) for i in indices)


def _same(x: Any, y: Any) -> bool:
    if _numeric(x) and _numeric(y):
        decided = iv.compare("==", iv.lift(x), iv.lift(y))
        if decided is None:
            raise Undecided("array entries too close to compare")
        return decided
    return x == y


MAX_ENUMERATION = 200_000


def _bounded_quantifier(n: Node, state: dict[str, Any]) -> bool | None:
    """∀/∃ over integers whose guard bounds every variable: decide by enumeration."""
    variables = n.payload
    body = n.args[0]
    if all(f"#universe:{v.sort.name}" in state for v in variables):
        return _finite_quantifier(n, state)
    if any(v.sort != INT for v in variables):
        raise Undecided(f"cannot evaluate `{n}` exactly (quantifier over a non-integer sort)")
    guard_op = "implies" if n.op == "forall" else "and"
    if body.op != guard_op:
        raise Undecided(f"cannot evaluate `{n}`: no guard bounds its variables")
    guard = body.args[0]
    ranges = []
    total = 1
    for v in variables:
        lo, hi = _bounds_of(v.payload, guard, state)
        if lo is None or hi is None:
            raise Undecided(f"cannot evaluate `{n}`: `{v.payload}` is not bounded by the guard")
        ranges.append(range(lo, hi + 1))
        total *= max(0, hi - lo + 1)
        if total > MAX_ENUMERATION:
            raise Undecided(f"cannot evaluate `{n}`: more than {MAX_ENUMERATION} cases")
    undecided = False
    for combo in itertools.product(*ranges):
        inner = dict(state, **{v.payload: x for v, x in zip(variables, combo)})
        val = evaluate(body, inner)
        if val is None:
            undecided = True
        elif (val is False) == (n.op == "forall"):
            return n.op == "exists"
    return None if undecided else n.op == "forall"


def _finite_quantifier(n: Node, state: dict[str, Any]) -> bool | None:
    """∀/∃ over index sorts, enumerating the model's finite universe of each."""
    pools = [state[f"#universe:{v.sort.name}"] for v in n.payload]
    undecided = False
    for combo in itertools.product(*pools):
        inner = dict(state, **{v.payload: x for v, x in zip(n.payload, combo)})
        val = evaluate(n.args[0], inner)
        if val is None:
            undecided = True
        elif (val is False) == (n.op == "forall"):
            return n.op == "exists"
    return None if undecided else n.op == "forall"


def _bounds_of(name: str, guard: Node, state: dict[str, Any]) -> tuple[int | None, int | None]:
    lo: int | None = None
    hi: int | None = None
    for atom in guard.args if guard.op == "and" else (guard,):
        if atom.op != "cmp":
            continue
        a, b = atom.args
        op = atom.payload
        if b.op == "var" and b.payload == name and not (a.op == "var" and a.payload == name):
            a, b = b, a
            op = {"<": ">", "<=": ">=", ">": "<", ">=": "<="}.get(op, op)
        if not (a.op == "var" and a.payload == name) or name in free_vars(b):
            continue
        try:
            bound = evaluate(b, state)
        except Undecided:
            continue
        if not isinstance(bound, Fraction) and not isinstance(bound, int):
            continue
        fl, ce = math.floor(bound), math.ceil(bound)
        if op in ("<", "<="):
            cand = (ce - 1) if op == "<" else fl
            hi = cand if hi is None else min(hi, cand)
        elif op in (">", ">="):
            cand = (fl + 1) if op == ">" else ce
            lo = cand if lo is None else max(lo, cand)
    return lo, hi


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
