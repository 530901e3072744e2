"""Interval numbers for the interpreter: a value known only to lie in a box.

A flow without a closed form ends in an enclosure, not a point (`enclosure.py`); the rest
of the run computes on that interval with mpmath's outward-rounded arithmetic, mixed with
exact Fractions. A comparison is answered only when it holds for every point of the
intervals; otherwise it raises `Uncertain`, a `Blocked`, so that no undecided test is ever
passed (nor its negation: `not (x < 1)` never sees a guess).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from certiloop.falsify.evaluate import Blocked


class Uncertain(Blocked):
    """Interval arithmetic cannot decide this comparison (or division)."""


class IntervalValue:
    __slots__ = ("iv",)
    __hash__ = None  # type: ignore[assignment]  # no interval is a dictionary key (an index)

    def __init__(self, iv) -> None:
        self.iv = iv

    @staticmethod
    def lift(x: Any):
        from certiloop.falsify.enclosure import iv_of

        if isinstance(x, IntervalValue):
            return x.iv
        if isinstance(x, (Fraction, int, float)) and not isinstance(x, bool):
            return iv_of(x)
        return None

    def _with(self, other, how):
        y = IntervalValue.lift(other)
        if y is None:
            return NotImplemented
        return IntervalValue(how(self.iv, y))

    def __add__(self, o):
        return self._with(o, lambda a, b: a + b)

    __radd__ = __add__

    def __sub__(self, o):
        return self._with(o, lambda a, b: a - b)

    def __rsub__(self, o):
        return self._with(o, lambda a, b: b - a)

    def __mul__(self, o):
        return self._with(o, lambda a, b: a * b)

    __rmul__ = __mul__

    def __truediv__(self, o):
        return self._with(o, lambda a, b: a / _nonzero(b))

    def __rtruediv__(self, o):
        return self._with(o, lambda a, b: b / _nonzero(a))

    def __neg__(self):
        return IntervalValue(-self.iv)

    def __pos__(self):
        return self

    def __pow__(self, n):
        if not isinstance(n, int) or n < 0:
            return NotImplemented
        return IntervalValue(self.iv ** n)

    # ---- comparisons: decided for every point, or Uncertain
    def _decide(self, other, how):
        y = IntervalValue.lift(other)
        if y is None:
            return NotImplemented
        answer = how(self.iv, y)
        if answer is None:
            raise Uncertain(f"{self} against {other}: the enclosure cannot decide it")
        return bool(answer)

    def __lt__(self, o):
        return self._decide(o, lambda a, b: a < b)

    def __le__(self, o):
        return self._decide(o, lambda a, b: a <= b)

    def __gt__(self, o):
        return self._decide(o, lambda a, b: a > b)

    def __ge__(self, o):
        return self._decide(o, lambda a, b: a >= b)

    def __eq__(self, o):
        return self._decide(o, _equal)

    def __ne__(self, o):
        result = self.__eq__(o)
        return result if result is NotImplemented else not result

    def __bool__(self):
        raise TypeError("an interval is not a truth value")

    def __float__(self) -> float:
        return float(self.iv.mid.a)  # for margins and plots only, never for a decision

    @property
    def width(self) -> float:
        return float(self.iv.delta.b)

    def __repr__(self) -> str:
        return f"[{float(self.iv.a):.12g}, {float(self.iv.b):.12g}]"


def _equal(a, b):
    if a.b < b.a or b.b < a.a:
        return False
    if a.a == a.b == b.a == b.b:
        return True
    return None


def _nonzero(b):
    if b.a <= 0 <= b.b:
        raise Uncertain("division by an interval that contains 0")
    return b
