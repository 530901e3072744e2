"""Exact rational interval arithmetic (Fraction endpoints, so no rounding error at all).

Counterexamples from z3 may contain algebraic numbers (roots of polynomials); we enclose
each in a tiny rational interval and evaluate with intervals: a comparison is decided only
when the whole interval lies on one side.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any


@dataclass(frozen=True)
class Interval:
    lo: Fraction
    hi: Fraction
    decimal: str = ""  # how z3 printed the algebraic number, for humans
    # the exact number, when known: the root_index-th real root (1-based, ascending) of the
    # polynomial with these ascending integer coefficients
    poly: tuple[int, ...] = ()
    root_index: int = 0

    def __post_init__(self) -> None:
        if self.lo > self.hi:
            raise ValueError(f"empty interval [{self.lo}, {self.hi}]")


Number = Fraction | Interval


def lift(x: Any) -> Number:
    if isinstance(x, Interval):
        return x
    if isinstance(x, bool):
        raise TypeError("a truth value is not a number")
    return Fraction(x)


def _bounds(x: Number) -> tuple[Fraction, Fraction]:
    return (x.lo, x.hi) if isinstance(x, Interval) else (x, x)


def _make(lo: Fraction, hi: Fraction) -> Number:
    return lo if lo == hi else Interval(lo, hi)


def add(a: Number, b: Number) -> Number:
    (al, ah), (bl, bh) = _bounds(a), _bounds(b)
    return _make(al + bl, ah + bh)


def neg(a: Number) -> Number:
    lo, hi = _bounds(a)
    return _make(-hi, -lo)


def mul(a: Number, b: Number) -> Number:
    (al, ah), (bl, bh) = _bounds(a), _bounds(b)
    products = (al * bl, al * bh, ah * bl, ah * bh)
    return _make(min(products), max(products))


def div(a: Number, b: Number) -> Number:
    bl, bh = _bounds(b)
    if bl <= 0 <= bh:
        raise ZeroDivisionError("division by an interval that contains 0")
    return mul(a, _make(1 / bh, 1 / bl))


def power(a: Number, n: int) -> Number:
    lo, hi = _bounds(a)
    if n == 0:
        return Fraction(1)
    if n % 2 == 1 or lo >= 0:
        return _make(min(lo**n, hi**n), max(lo**n, hi**n))
    if hi <= 0:
        return _make(hi**n, lo**n)
    return _make(Fraction(0), max(lo**n, hi**n))


def compare(op: str, a: Number, b: Number) -> bool | None:
    """True/False when decided for every value in the intervals, None otherwise."""
    d = add(a, neg(b))
    lo, hi = _bounds(d)
    if op == "<":
        return True if hi < 0 else False if lo >= 0 else None
    if op == "<=":
        return True if hi <= 0 else False if lo > 0 else None
    if op == ">":
        return True if lo > 0 else False if hi <= 0 else None
    if op == ">=":
        return True if lo >= 0 else False if hi < 0 else None
    if op == "==":
        return True if lo == hi == 0 else False if (lo > 0 or hi < 0) else None
    if op == "!=":
        r = compare("==", a, b)
        return None if r is None else not r
    raise ValueError(op)


def show_value(x: Any, digits: int = 6) -> str:
    """Decimal text for humans: 'x ≈ 0.70710678' for algebraics, exact decimals otherwise."""
    if isinstance(x, Interval):
        return x.decimal or f"≈{float((x.lo + x.hi) / 2):.{digits}g}"
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, Fraction):
        if x.denominator == 1:
            return str(x.numerator)
        text = f"{float(x):.{digits}g}"
        return text if Fraction(text) == x else f"{text} (= {x})"
    return str(x)
