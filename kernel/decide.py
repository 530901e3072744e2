"""Runtime of the float-sound scalar code (`certiloop extract`, scalar shape, and the scalar
controller monitors): the generated step is ONE body written over a number kit `_R`, run twice
at most:

* FLOAT, the filter: every real value is a `Bounded` float v with a bound e on |v - x| for
  its real value x (the formulas of `certiloop.kernel.filtered`, one operation at a time).
  A comparison whose sign the bound cannot certify raises `Undecided`;
* EXACT: the same body on `fractions.Fraction` values of the float inputs (float inputs are
  exact rationals), so every decision is the real model's.

`run(step, *args)` runs the filter, and the exact pass only where the filter raised. Where
the exact pass cannot represent a value (the square root of a rational that is not a square)
the step reports no run: the caller falls back, as for a state where the model has none.

The same kit semantics in both passes, the exact interpreter's: a division by zero or the
square root of a negative number is ill-defined (no run through it); a non-finite input is
outside the model's domain (no run); a real output is returned as the
largest float <= its real value (a float at most the real value, as the C kernel's `cl_lower`;
here always the largest, so that a monitor can recognise it), or no run if that is not
finite."""

from __future__ import annotations

import math
import sys
from fractions import Fraction
from functools import lru_cache

import numpy as np

# numpy and the standard library only: the generated monitors carry this module's source
U = 2.0 ** -52  # as certiloop.kernel.filtered: twice the unit roundoff of float64
ETA = 2.0 ** -1000  # covers a product's underflow
INFL = 1.0 + 2.0 ** -40  # covers the rounding of the bound computations themselves


def floor(q: Fraction) -> float:
    """The largest float <= the rational q (|q| at most the largest float)."""
    f = float(q)
    if Fraction(f) > q:
        f = math.nextafter(f, -math.inf)
    return f


class Undecided(Exception):
    """The floats cannot decide a comparison: run the exact pass."""


class NoRun(Exception):
    """The model has no run from this state (a non-finite input or output)."""


def _up(x: float) -> float:
    return math.nextafter(x, math.inf)


class _BySign:
    """The six comparisons from `self._sign(other)`: -1, 0 or 1, or None (not comparable)."""

    __slots__ = ()
    __hash__ = None  # type: ignore[assignment]

    def __lt__(self, other):
        s = self._sign(other)
        return NotImplemented if s is None else s < 0

    def __le__(self, other):
        s = self._sign(other)
        return NotImplemented if s is None else s <= 0

    def __gt__(self, other):
        s = self._sign(other)
        return NotImplemented if s is None else s > 0

    def __ge__(self, other):
        s = self._sign(other)
        return NotImplemented if s is None else s >= 0

    def __eq__(self, other):
        s = self._sign(other)
        return NotImplemented if s is None else s == 0

    def __ne__(self, other):
        s = self._sign(other)
        return NotImplemented if s is None else s != 0


class Bounded(_BySign):
    """A float v with |v - x| <= e for the real value x (e = 0: exact)."""

    __slots__ = ("v", "e")
    __hash__ = None  # type: ignore[assignment]

    def __init__(self, v: float, e: float = 0.0) -> None:
        self.v, self.e = v, e

    def __repr__(self) -> str:
        return f"Bounded({self.v!r}, {self.e!r})"

    # ---------------------------------------------------------------- arithmetic
    def __add__(self, other):
        b = _lift(other)
        if b is None:
            return NotImplemented
        v = self.v + b.v
        if self.e == 0 and b.e == 0 and math.isfinite(v):
            # TwoSum: the exact rounding error of a sum of two floats
            bb = v - self.v
            err = abs((self.v - (v - bb)) + (b.v - bb))
            return Bounded(v, err)
        return Bounded(v, _up(abs(v) * U + self.e + b.e))

    __radd__ = __add__

    def __neg__(self):
        return Bounded(-self.v, self.e)

    def __sub__(self, other):
        b = _lift(other)
        return NotImplemented if b is None else self + (-b)

    def __rsub__(self, other):
        b = _lift(other)
        return NotImplemented if b is None else b + (-self)

    def __mul__(self, other):
        b = _lift(other)
        if b is None:
            return NotImplemented
        a = self
        v = a.v * b.v
        if (a.e == 0 and a.v == 0) or (b.e == 0 and b.v == 0):
            return Bounded(0.0)  # exactly 0
        e = abs(v) * U + ETA + abs(a.v) * b.e + abs(b.v) * a.e + a.e * b.e
        return Bounded(v, _up(e * INFL))

    __rmul__ = __mul__

    def __truediv__(self, other):
        b = _lift(other)
        if b is None:
            return NotImplemented
        return _div(self, b)

    def __rtruediv__(self, other):
        a = _lift(other)
        if a is None:
            return NotImplemented
        return _div(a, self)

    def __pow__(self, n):
        if not isinstance(n, int) or n < 0:
            return NotImplemented
        out = Bounded(1.0)
        for _ in range(n):
            out = out * self
        return out

    # ---------------------------------------------------------------- comparisons
    def _sign(self, other) -> int | None:
        """The sign of x - y in the reals; None for an operand the kit does not know."""
        b = _lift(other)
        if b is None:
            return None
        a = self
        if a.e == 0 and b.e == 0:
            if math.isfinite(a.v) and math.isfinite(b.v):
                return (a.v > b.v) - (a.v < b.v)  # floats compare exactly
            raise Undecided
        d = a.v - b.v
        e = (a.e + b.e) * INFL
        if math.isfinite(d) and abs(d) > e:
            return 1 if d > 0 else -1
        raise Undecided

    def __bool__(self):
        return self != 0


def _lift(x) -> Bounded | None:
    """An operand as a Bounded value: ints exactly where the float is the int."""
    if isinstance(x, Bounded):
        return x
    if isinstance(x, bool):
        return None
    if isinstance(x, int):
        f = float(x) if abs(x) < 2 ** 1023 else math.inf
        if math.isfinite(f) and int(f) == x:
            return Bounded(f)
        return Bounded(f, _up(abs(f - x) * 2.0) if math.isfinite(f) else math.inf)
    if isinstance(x, Fraction):
        return _constant(x.numerator, x.denominator)
    return None


def _div(a: Bounded, b: Bounded):
    if b.e == 0 and b.v == 0:
        raise NoRun  # x / 0 is ill-defined: the model has no run through it
    den = abs(b.v) - b.e
    if not den > 0:
        raise Undecided  # the divisor's sign (or whether it is 0) is not certain
    if a.e == 0 and a.v == 0:
        return Bounded(0.0)  # 0 / a non-zero divisor
    v = a.v / b.v
    num = (abs(v) * (1.0 + U) + ETA) * b.e + a.e
    e = abs(v) * U + ETA + num / den
    return Bounded(v, _up(e * INFL))


@lru_cache(maxsize=256)
def _constant(num: int, den: int) -> Bounded:
    q = Fraction(num, den)
    try:
        f = float(q)
    except OverflowError:
        return Bounded(math.inf, math.inf)
    err = abs(Fraction(f) - q)
    if err == 0:
        return Bounded(f)
    bound = float(err)
    if Fraction(bound) < err:
        bound = _up(bound)
    return Bounded(f, bound)


class _Kit:
    """What both kits share: arrays of reals."""

    def array(self, x):
        """A real array input: an object array of the kit's values (a copy)."""
        a = np.asarray(x, dtype=float)
        out = np.empty(a.shape, dtype=object)
        out[...] = [self.real(y) for y in a.reshape(-1)] if a.size else []
        return out

    @staticmethod
    def zeros(shape):
        out = np.empty(shape, dtype=object)
        out[...] = 0  # an exact 0 in both kits
        return out

    def out_array(self, x):
        a = np.asarray(x, dtype=object)
        return np.array([self.out(y) for y in a.reshape(-1)], dtype=float).reshape(a.shape)


class _Float(_Kit):
    """The filter's kit."""

    name = "float"

    @staticmethod
    def real(x) -> Bounded:
        f = float(x)
        if not math.isfinite(f):
            raise NoRun
        return Bounded(f)

    @staticmethod
    def c(num: int, den: int = 1) -> Bounded:
        return _constant(num, den)

    @staticmethod
    def div(a, b):
        return _div(_lift(a), _lift(b))

    @staticmethod
    def sqrt(a):
        a = _lift(a)
        if a.e == 0:
            if a.v < 0:
                raise NoRun  # the root of a negative number is ill-defined
            v = math.sqrt(a.v)
            if Fraction(v) ** 2 == Fraction(a.v):
                return Bounded(v)
            return Bounded(v, _up(abs(v) * U + ETA))
        lo = (a.v - a.e * INFL) - (abs(a.v) + a.e) * U
        if not lo > 0:
            raise Undecided
        v = math.sqrt(a.v)
        e = abs(v) * U + ETA + a.e * INFL / math.sqrt(lo) * (1.0 + 4 * U)
        return Bounded(v, _up(e * INFL))

    @staticmethod
    def out(x) -> float:
        b = _lift(x)
        if b.e == 0:
            if not math.isfinite(b.v):
                raise Undecided  # the float overflowed, the real value may not have
            return b.v
        if not (math.isfinite(b.v) and math.isfinite(b.e)):
            raise Undecided
        # the largest float <= the real value, where the bound pins it down (else exactly): the
        # same float as the exact pass's, whichever pass decides
        e = Fraction(b.e) * Fraction(INFL)
        f = floor(Fraction(b.v) - e)
        if Fraction(b.v) + e < Fraction(math.nextafter(f, math.inf)):
            return f
        raise Undecided

    @staticmethod
    def close(value, command, tol) -> bool:
        """|value - command| <= tol in the reals, or command is the float the controller
        returns for value (its largest float <= value): decided in the filter where every real
        value within the bound gives the same answer, else by the exact pass."""
        v, c, t = _lift(value), _lift(command), _lift(tol)
        if c.e or t.e or not (math.isfinite(v.v) and math.isfinite(v.e)):
            raise Undecided
        if v.e == 0:
            return c.v == v.v or abs(Fraction(v.v) - Fraction(c.v)) <= Fraction(t.v)
        x, e, cmd = Fraction(v.v), Fraction(v.e) * Fraction(INFL), Fraction(c.v)
        gap = abs(x - cmd)
        if gap + e <= Fraction(t.v):
            return True  # within tol wherever in [x - e, x + e] the real value lies
        if gap - e > Fraction(t.v) and (x + e < cmd or c.v < sys.float_info.max
                                        and x - e >= Fraction(math.nextafter(c.v, math.inf))):
            return False  # beyond tol, and command is not its largest float below, anywhere there
        raise Undecided


_MAX = Fraction(sys.float_info.max)


class _Exact(_Kit):
    """The exact pass's kit: Fractions of the float inputs."""

    name = "exact"

    @staticmethod
    def real(x) -> Fraction:
        f = float(x)
        if not math.isfinite(f):
            raise NoRun
        return Fraction(f)

    @staticmethod
    @lru_cache(maxsize=256)
    def c(num: int, den: int = 1) -> Fraction:
        return Fraction(num, den)

    @staticmethod
    def div(a, b):
        if b == 0:
            raise NoRun  # x / 0 is ill-defined: the model has no run through it
        if isinstance(a, Enclosure) or isinstance(b, Enclosure):
            return Enclosure._of(a) / b
        return Fraction(a) / b

    @staticmethod
    def sqrt(a):
        if a < 0:
            raise NoRun  # the root of a negative number is ill-defined
        if isinstance(a, Enclosure):
            if a.lo < 0:
                raise NoRun  # the sign of the radicand is not decided: the caller falls back
            return Enclosure(_sqrt_down(a.lo), _sqrt_up(a.hi))
        a = Fraction(a)
        n, d = math.isqrt(a.numerator), math.isqrt(a.denominator)
        if n * n == a.numerator and d * d == a.denominator:
            return Fraction(n, d)
        return Enclosure(_sqrt_down(a), _sqrt_up(a))  # irrational: a rational enclosure

    @staticmethod
    def out(x) -> float:
        q = x.lo if isinstance(x, Enclosure) else Fraction(x)
        if abs(q) > _MAX:
            raise NoRun  # the real value is beyond the float range
        return floor(q)

    @staticmethod
    def close(value, command, tol) -> bool:
        if isinstance(value, Enclosure):
            if value.hi - command <= tol and command - value.lo <= tol:
                return True
            if value.lo - command > tol or command - value.hi > tol:
                return _Exact.out_or_none(value) == float(command)
            raise NoRun  # within the enclosure's width of the tolerance: not decided
        value = Fraction(value)
        return abs(value - command) <= tol or _Exact.out_or_none(value) == float(command)

    @staticmethod
    def out_or_none(x):
        try:
            return _Exact.out(x)
        except NoRun:
            return None


SQRT_BITS = 256  # the relative width of a square root's rational enclosure: 2^-SQRT_BITS


def _sqrt_down(q: Fraction) -> Fraction:
    """A rational <= sqrt(q), q >= 0, within a relative 2^-SQRT_BITS."""
    if q <= 0:
        return Fraction(0)
    scale = 2 * SQRT_BITS + max(0, q.denominator.bit_length() - q.numerator.bit_length())
    return Fraction(math.isqrt((q.numerator << (2 * scale)) // q.denominator), 1 << scale)


def _sqrt_up(q: Fraction) -> Fraction:
    r = _sqrt_down(q)
    step = Fraction(1, r.denominator) if r.denominator > 1 else Fraction(1)
    while (r + step) * (r + step) < q:  # never more than once or twice: isqrt floors
        r += step
    return r + step


class Enclosure(_BySign):
    """An irrational value of the exact pass (a square root and what is computed from it): a
    rational interval [lo, hi] holding it. A comparison is decided where the interval lies on
    one side; else the exact pass gives up (NoRun: the caller falls back)."""

    __slots__ = ("lo", "hi")
    __hash__ = None  # type: ignore[assignment]

    def __init__(self, lo, hi) -> None:
        self.lo, self.hi = Fraction(lo), Fraction(hi)

    @staticmethod
    def _of(x):
        if isinstance(x, Enclosure):
            return x
        if isinstance(x, (int, Fraction)) and not isinstance(x, bool):
            return Enclosure(x, x)
        return None

    def __add__(self, other):
        b = Enclosure._of(other)
        return NotImplemented if b is None else Enclosure(self.lo + b.lo, self.hi + b.hi)

    __radd__ = __add__

    def __neg__(self):
        return Enclosure(-self.hi, -self.lo)

    def __sub__(self, other):
        b = Enclosure._of(other)
        return NotImplemented if b is None else self + (-b)

    def __rsub__(self, other):
        b = Enclosure._of(other)
        return NotImplemented if b is None else b + (-self)

    def __mul__(self, other):
        b = Enclosure._of(other)
        if b is None:
            return NotImplemented
        ends = [self.lo * b.lo, self.lo * b.hi, self.hi * b.lo, self.hi * b.hi]
        return Enclosure(min(ends), max(ends))

    __rmul__ = __mul__

    def __pow__(self, n):
        if not isinstance(n, int) or n < 0:
            return NotImplemented
        out = Enclosure(1, 1)
        for _ in range(n):
            out = out * self
        return out

    def inverse(self):
        if self.lo <= 0 <= self.hi:
            raise NoRun  # whether the divisor is 0 is not decided
        return Enclosure(1 / self.hi, 1 / self.lo)

    def __truediv__(self, other):
        b = Enclosure._of(other)
        return NotImplemented if b is None else self * b.inverse()

    def __rtruediv__(self, other):
        a = Enclosure._of(other)
        return NotImplemented if a is None else a * self.inverse()

    def _sign(self, other):
        b = Enclosure._of(other)
        if b is None:
            return None
        if self.lo > b.hi:
            return 1
        if self.hi < b.lo:
            return -1
        if self.lo == self.hi == b.lo == b.hi:
            return 0
        raise NoRun  # within the enclosures' width: not decided


FLOAT = _Float()
EXACT = _Exact()


def run(step, blocked, *args):
    """`step(kit, *args)` with the filter, else exactly; `blocked` where the model has no run
    (or the exact pass cannot represent a value)."""
    try:
        return step(FLOAT, *args)
    except Undecided:
        pass
    except NoRun:
        return blocked
    try:
        return step(EXACT, *args)
    except NoRun:
        return blocked


def redo_exactly(part, kit, *args):
    """`part(kit, *args)`, one part of a step (a boundary of a family monitor); where the filter
    cannot decide it, that part alone again on exact rationals of the same arguments (floats,
    dicts of them), instead of the whole step. An argument the filter holds only within an
    error bound cannot be made exact here: Undecided, the whole step's exact pass."""
    try:
        return part(kit, *args)
    except Undecided:
        if kit is not FLOAT:
            raise
    return part(EXACT, *(_exactly(a) for a in args))


def _exactly(x):
    if isinstance(x, dict):
        return {k: _exactly(v) for k, v in x.items()}
    if isinstance(x, Bounded):
        if x.e:
            raise Undecided
        return Fraction(x.v)
    return x

