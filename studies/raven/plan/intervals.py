"""Outward-rounded interval arithmetic over numpy arrays (float64), for the planner's proofs.

An `Interval` holds arrays lo <= hi and encloses every real it stands for. After each
operation the bounds move one ulp outward (`np.nextafter`): IEEE addition, subtraction and
multiplication round to nearest, so the exact result lies within half an ulp of the
computed one, and one ulp outward encloses it. numpy's cos/sin are not correctly rounded
(a few ulp at most on every libm we know of), so their bounds are widened by TRIG_PAD
(1e-15 absolute, about 9 ulp at 1) and clipped to [-1, 1]. The extrema of cos/sin inside an
interval are found with a slack of 1e-9 rad, so a float approximation of pi can only add
an extremum, never miss one. Constants such as cos 75 deg are enclosed the same way.

The second, independent check of a path (`check.py`) uses mpmath's interval arithmetic
instead: a slip here cannot certify a path by itself.
"""

from __future__ import annotations

import numpy as np

TRIG_PAD = 1e-15
EXTREMUM_SLACK = 1e-9
_TWO_PI = 2 * np.pi


def _down(x):
    return np.nextafter(x, -np.inf)


def _up(x):
    return np.nextafter(x, np.inf)


class Interval:
    __slots__ = ("lo", "hi")

    def __init__(self, lo, hi=None) -> None:
        self.lo = np.asarray(lo, dtype=float)
        self.hi = self.lo if hi is None else np.asarray(hi, dtype=float)

    @staticmethod
    def _wrap(other) -> "Interval":
        return other if isinstance(other, Interval) else Interval(other)

    def __add__(self, other) -> "Interval":
        o = self._wrap(other)
        return Interval(_down(self.lo + o.lo), _up(self.hi + o.hi))

    __radd__ = __add__

    def __neg__(self) -> "Interval":
        return Interval(-self.hi, -self.lo)

    def __sub__(self, other) -> "Interval":
        o = self._wrap(other)
        return Interval(_down(self.lo - o.hi), _up(self.hi - o.lo))

    def __rsub__(self, other) -> "Interval":
        return self._wrap(other) - self

    def __mul__(self, other) -> "Interval":
        o = self._wrap(other)
        products = np.stack(np.broadcast_arrays(self.lo * o.lo, self.lo * o.hi, self.hi * o.lo,
                                                self.hi * o.hi))
        return Interval(_down(products.min(axis=0)), _up(products.max(axis=0)))

    __rmul__ = __mul__

    @property
    def width(self) -> np.ndarray:
        return self.hi - self.lo

    def __repr__(self) -> str:
        return f"Interval({self.lo!r}, {self.hi!r})"


def _contains_point(lo, hi, phase: float) -> np.ndarray:
    """Whether [lo, hi] (widened by the slack) contains phase + 2k pi for some integer k."""
    k = np.ceil((lo - EXTREMUM_SLACK - phase) / _TWO_PI)
    return phase + k * _TWO_PI <= hi + EXTREMUM_SLACK


def _trig(x: Interval, f, top_phase: float, bottom_phase: float) -> Interval:
    a, b = f(x.lo), f(x.hi)
    lo, hi = np.minimum(a, b) - TRIG_PAD, np.maximum(a, b) + TRIG_PAD
    hi = np.where(_contains_point(x.lo, x.hi, top_phase), 1.0, hi)
    lo = np.where(_contains_point(x.lo, x.hi, bottom_phase), -1.0, lo)
    wide = x.hi - x.lo >= _TWO_PI
    return Interval(np.where(wide, -1.0, np.maximum(lo, -1.0)), np.where(wide, 1.0, np.minimum(hi, 1.0)))


def cos(x: Interval) -> Interval:
    return _trig(x, np.cos, 0.0, np.pi)


def sin(x: Interval) -> Interval:
    return _trig(x, np.sin, np.pi / 2, -np.pi / 2)


def constant_trig(angle: float) -> tuple[Interval, Interval]:
    """(cos, sin) of a float angle as tight intervals."""
    point = Interval(np.asarray(angle, dtype=float))
    return cos(point), sin(point)
