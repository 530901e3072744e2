"""Reading and writing the interpreter's states: symbols and family cells, open values."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from certiloop.falsify.evaluate import Blocked, NeedValue, Table


class Rejected(Exception):
    """The chosen initial state does not satisfy the assumptions."""


def solve_linear(lhs, rhs, key, s: dict[str, Any], exact: bool):
    """x with lhs(x) = rhs(x), if both sides are affine in the open value `key` (else None).
    The sides are kept apart so that `x*G*X = 1` gives x = 1/(G*X) without cancellation."""
    old = get(s, key)
    try:
        values = []
        for x in (0, 1, 2):
            put(s, key, Fraction(x) if exact else float(x))
            values.append((lhs(s), rhs(s)))
    except (NeedValue, Blocked):
        return None
    finally:
        remove(s, key) if old is None else put(s, key, old)
    (l0, r0), (l1, r1), (l2, r2) = values
    slope_l, slope_r = l1 - l0, r1 - r0
    if exact:
        if l2 - l1 != slope_l or r2 - r1 != slope_r:
            return None
    elif (abs((l2 - l1) - slope_l) > 1e-9 * (1 + abs(slope_l))
          or abs((r2 - r1) - slope_r) > 1e-9 * (1 + abs(slope_r))):
        return None
    slope = slope_l - slope_r
    if slope == 0:
        return None
    return (r0 - l0) / slope


def quadratic_points(diff, key, s: dict[str, Any], edge_first: bool) -> list[float]:
    """Where `diff`, quadratic in the open value `key` (floats only), is extreme (its vertex)
    or zero (its real roots): the places a quadratic atom can hold, edges first if asked.
    [] when diff is not quadratic in key (checked at a fourth point)."""
    old = get(s, key)
    try:
        values = []
        for x in (-1.0, 0.0, 1.0, 2.0):
            put(s, key, x)
            values.append(float(diff(s)))
    except (NeedValue, Blocked, TypeError, ArithmeticError):
        return []
    finally:
        remove(s, key) if old is None else put(s, key, old)
    m, c, p, q = values
    a, b = (m + p) / 2 - c, (p - m) / 2
    if a == 0 or abs(a * 4 + b * 2 + c - q) > 1e-9 * (1 + abs(q)):
        return []
    vertex = [-b / (2 * a)]
    disc = b * b - 4 * a * c
    roots = sorted({(-b - disc ** 0.5) / (2 * a), (-b + disc ** 0.5) / (2 * a)}) if disc >= 0 else []
    return roots + vertex if edge_first else vertex + roots


def put(s: dict[str, Any], key, value: Any) -> None:
    if isinstance(key, str):
        s[key] = value
    else:
        table = s.get(key[0])
        if not isinstance(table, Table):
            table = s[key[0]] = Table()
        table.cells[key[1]] = value


def get(s: dict[str, Any], key) -> Any:
    """The value at a symbol or cell, None while it is open."""
    if isinstance(key, str):
        return s.get(key)
    table = s.get(key[0])
    return table.read(key[1]) if isinstance(table, Table) else None


def remove(s: dict[str, Any], key) -> None:
    if isinstance(key, str):
        s.pop(key, None)
    elif isinstance(s.get(key[0]), Table):
        s[key[0]].cells.pop(key[1], None)
