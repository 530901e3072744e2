"""Exact rational interval arithmetic (Fraction endpoints, so no rounding error at all).

Counterexamples from z3 may contain algebraic numbers (roots of polynomials); we enclose
each in a tiny rational interval and evaluate with intervals: a comparison is decided only
when the whole interval lies on one side.
"""

from __future__ import annotations

from dataclasses import dataclass, field
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
    # the exact value as a sympy expression over algebraic numbers, when it is known (kept
    # through arithmetic, so that a comparison the interval cannot decide is decided exactly)
    exact: Any = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.lo > self.hi:
            raise ValueError(f"empty interval [{self.lo}, {self.hi}]")
        if self.exact is None and self.poly:
            import sympy

            z = sympy.Symbol("z")
            root = sympy.CRootOf(sympy.Poly(list(reversed(self.poly)), z), self.root_index - 1)
            object.__setattr__(self, "exact", root)


Number = Fraction | Interval


def lift(x: Any) -> Number:
    if isinstance(x, Interval):
        return x
    if isinstance(x, bool):
        raise TypeError("a truth value is not a number")
    return Fraction(x)


def _bounds(x: Number) -> tuple[Fraction, Fraction]:
    return (x.lo, x.hi) if isinstance(x, Interval) else (x, x)


def _exact(x: Number) -> Any:
    if isinstance(x, Interval):
        return x.exact
    import sympy

    return sympy.Rational(x.numerator, x.denominator)


def _make(lo: Fraction, hi: Fraction, exact: Any = None) -> Number:
    return lo if lo == hi else Interval(lo, hi, exact=exact)


def _combined(a: Number, b: Number | None, how) -> Any:
    """The exact value of an operation on a and b, if both are known exactly (only worth
    it when an interval is involved: plain rationals are exact already)."""
    if not isinstance(a, Interval) and not isinstance(b, Interval):
        return None
    ea = _exact(a)
    eb = _exact(b) if b is not None else None
    if ea is None or (b is not None and eb is None):
        return None
    return how(ea, eb)


def add(a: Number, b: Number) -> Number:
    (al, ah), (bl, bh) = _bounds(a), _bounds(b)
    return _make(al + bl, ah + bh, _combined(a, b, lambda x, y: x + y))


def neg(a: Number) -> Number:
    lo, hi = _bounds(a)
    return _make(-hi, -lo, _combined(a, None, lambda x, _y: -x))


def mul(a: Number, b: Number) -> Number:
    (al, ah), (bl, bh) = _bounds(a), _bounds(b)
    products = (al * bl, al * bh, ah * bl, ah * bh)
    return _make(min(products), max(products), _combined(a, b, lambda x, y: x * y))


def div(a: Number, b: Number) -> Number:
    bl, bh = _bounds(b)
    if bl <= 0 <= bh:
        if isinstance(b, Interval) and b.exact is not None and _sign(b.exact) != 0:
            return div(a, _refined(b))
        raise ZeroDivisionError("division by an interval that contains 0")
    (al, ah) = _bounds(a)
    quotients = (al / bl, al / bh, ah / bl, ah / bh)
    return _make(min(quotients), max(quotients), _combined(a, b, lambda x, y: x / y))


def power(a: Number, n: int) -> Number:
    lo, hi = _bounds(a)
    exact = _combined(a, None, lambda x, _y: x**n)
    if n == 0:
        return Fraction(1)
    if n % 2 == 1 or lo >= 0:
        return _make(min(lo**n, hi**n), max(lo**n, hi**n), exact)
    if hi <= 0:
        return _make(hi**n, lo**n, exact)
    return _make(Fraction(0), max(lo**n, hi**n), exact)


DIGITS = 60  # enough to settle the sign of a nonzero algebraic number of the sizes we meet


def _sign(e: Any) -> int | None:
    """The sign of an exact algebraic expression: 0 iff its minimal polynomial is z;
    otherwise from DIGITS digits (None below 1e-50: not settled)."""
    import sympy

    z = sympy.Symbol("z")
    try:
        if sympy.minimal_polynomial(e, z) == z:
            return 0
    except (NotImplementedError, ValueError):
        return None
    value = sympy.N(e, DIGITS)
    if abs(value) < sympy.Float("1e-50"):
        return None
    return 1 if value > 0 else -1


def _refined(x: Interval) -> Interval:
    import sympy

    mid = Fraction(str(sympy.N(x.exact, DIGITS)))
    eps = Fraction(1, 10**(DIGITS - 5))
    return Interval(mid - eps, mid + eps, x.decimal, x.poly, x.root_index, x.exact)


def compare(op: str, a: Number, b: Number) -> bool | None:
    """True/False when decided for every value in the intervals (or, failing that, exactly
    from the algebraic values they enclose), None otherwise."""
    d = add(a, neg(b))
    decided = _compare_bounds(op, d)
    if decided is None and isinstance(d, Interval) and d.exact is not None:
        sign = _sign(d.exact)
        if sign is not None:
            decided = {"<": sign < 0, "<=": sign <= 0, ">": sign > 0, ">=": sign >= 0,
                       "==": sign == 0, "!=": sign != 0}[op]
    return decided


def _compare_bounds(op: str, d: Number) -> bool | None:
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
        r = _compare_bounds("==", d)
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
