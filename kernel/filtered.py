"""Runtime side of float-sound extraction: floating-point values with rigorous error bounds
(a "filter"), and the exact rational re-evaluation generated code falls back to where the
filter cannot decide. numpy and the standard library only. The scheme, its proof sketch and
the contract other back ends (C) mirror are in `certiloop.kernel.extract.certified`.

Every certified value is a pair (v, e): v the float64 the code computed, e a float bound
with |v - x| <= e for the real value x of the same term on the same (float, hence rational)
inputs; e is None for a value known to be exact (an input, an exactly representable
constant). The helpers return such pairs for +, -, *, / (numpy arrays or scalars); a
comparison is certain where |a - b| > (ea + eb)·INFL, or where both sides are exact.
Non-finite values (overflow, 0/0) are never certain.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

U = 2.0 ** -52  # twice the unit roundoff of float64: a rounding error is <= u|fl(x)| <= U|fl(x)|/2
ETA = 2.0 ** -1000  # covers underflow (a product loses < 2^-1075, so do the bound's own operations);
# far above that so that bounds stay normal numbers: subnormal arithmetic is ~100x slower on x86
INFL = 1.0 + 2.0 ** -40  # covers the rounding of the bound computations themselves
TIGHT = 2.0 ** -20  # an output is taken from floats only if its bound is below this relative error


def add(a, ea, b, eb):
    """a + b. Exact operands: |fl(a+b) - (a+b)| <= u|fl(a+b)| (no underflow error: a sum
    that small is exact)."""
    v = a + b
    e = np.abs(v) * U
    if ea is not None:
        e = e + ea
    if eb is not None:
        e = e + eb
    return v, e


def sub(a, ea, b, eb):
    v = a - b
    e = np.abs(v) * U
    if ea is not None:
        e = e + ea
    if eb is not None:
        e = e + eb
    return v, e


def _eta(a, ea, b, eb):
    """ETA where a product may have underflowed; 0 where an exact factor is 0 (the product
    is then exactly 0, and so is its error)."""
    mask = None
    for x, ex in ((a, ea), (b, eb)):
        if ex is not None:
            continue
        if not isinstance(x, np.ndarray):
            if x == 0:
                return 0.0
            continue
        mask = x != 0 if mask is None else mask & (x != 0)
    return ETA if mask is None else np.where(mask, ETA, 0.0)


def mul(a, ea, b, eb):
    """a * b: |x - ab| <= |a|eb + |b|ea + ea·eb for the operands' errors, plus the rounding
    of ab (u|v|, or 2^-1075 where it underflows; none where an exact operand is 0)."""
    v = a * b
    e = np.abs(v) * U + _eta(a, ea, b, eb)
    if eb is not None:
        e = e + np.abs(a) * eb
    if ea is not None:
        e = e + np.abs(b) * ea
        if eb is not None:
            e = e + ea * eb
    return v, e


def div(a, ea, b, eb):
    """a / b: with |b| > eb, |x - a/b| <= (ea + |a/b| eb)/(|b| - eb), plus the rounding;
    infinite (never certain) where the divisor's sign is not certain."""
    v = np.divide(a, b)  # inf or NaN for a zero divisor, never ZeroDivisionError
    # rounding (+ underflow), none for an exact 0 numerator (then v = 0 exactly, or b = 0: NaN)
    e = np.abs(v) * U + (np.where(a == 0, 0.0, ETA) if ea is None else ETA)
    if ea is None and eb is None:
        return v, e
    den = np.abs(b) if eb is None else np.abs(b) - eb
    num = (np.abs(v) * (1.0 + U) + ETA) * (0.0 if eb is None else eb)
    if ea is not None:
        num = num + ea
    with np.errstate(divide="ignore", invalid="ignore"):
        e = e + np.where(den > 0, num / np.where(den > 0, den, 1.0), np.inf)
    return v, e


def neg(a, ea):
    return -a, ea


def uncertain(a, ea, b, eb):
    """Where the sign of a - b in the reals may differ from the sign of the float a - b: not
    (|a - b| > (ea + eb)·INFL, or both exact). NaN and infinite bounds are uncertain."""
    if ea is None and eb is None:
        return False
    e = ea if eb is None else eb if ea is None else ea + eb
    d = a if (isinstance(b, float) and b == 0.0) else a - b
    return np.logical_not((np.abs(d) > e * INFL) | (e == 0))


def loose(v, e):
    """Where a value's bound is too wide to return it from floats (not finite, or relative
    error above TIGHT); there it is recomputed exactly."""
    if e is None:
        return np.logical_not(np.isfinite(v))
    return np.logical_not((e * INFL <= np.abs(v) * TIGHT) & (np.abs(v) < np.inf))


def lower(v, e):
    """A float <= the real value: v - e rounded down (the safe side of a gain or a ceiling)."""
    if e is None:
        return v
    # a zero bound: v is exact (v - 0 would still be stepped down by nextafter)
    return np.where(e == 0, v, np.nextafter(v - e * INFL, -np.inf))


# ---------------------------------------------------------------- the exact path


def exact(x):
    """A float (or array of floats) as exact rationals: an object array of Fractions."""
    if isinstance(x, np.ndarray):
        out = np.empty(x.shape, dtype=object)
        out[...] = [Fraction(float(y)) for y in x.reshape(-1)] if x.size else []
        return out
    return Fraction(float(x))


class _Undefined:
    """NaN for the exact path: absorbs arithmetic and fails every comparison, without ever
    turning a Fraction into a float (float NaN would: Fraction * float converts, and a
    rational beyond the float range then raises)."""

    def _self(self, *_):
        return self

    __add__ = __radd__ = __sub__ = __rsub__ = __mul__ = __rmul__ = _self
    __truediv__ = __rtruediv__ = __pow__ = __neg__ = __abs__ = _self

    def _false(self, _):
        return False

    __lt__ = __le__ = __gt__ = __ge__ = __eq__ = _false

    def __ne__(self, _):
        return True

    __hash__ = object.__hash__

    def __float__(self):
        return float("nan")

    def __repr__(self):
        return "NAN"


NAN = _Undefined()


def xdiv(a, b):
    """a / b on rationals (object arrays or scalars), NaN where b == 0: the value is then
    never read, since the model's own guard b != 0 has failed."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.broadcast_arrays(np.asarray(a, dtype=object), np.asarray(b, dtype=object))
        out = np.empty(a.shape, dtype=object)
        out[...] = [x / y if y != 0 else NAN for x, y in zip(a.reshape(-1), b.reshape(-1))] \
            if a.size else []
        return out
    return a / b if b != 0 else NAN


def finite(*values) -> bool:
    """Every number given (scalars, arrays; Bool arrays pass) is finite."""
    for x in values:
        a = np.asarray(x)
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            return False
        if a.dtype.kind not in "fbiu" and not all(np.isfinite(float(y)) for y in a.reshape(-1)):
            return False
    return True


def floor(q):
    """The largest float <= the rational q (NaN stays NaN; beyond the float range: -inf or
    the largest finite float); element-wise on an object array; anything else unchanged."""
    if isinstance(q, np.ndarray) and q.dtype == object:
        return np.array([floor(x) for x in q.reshape(-1)], dtype=float).reshape(q.shape)
    if isinstance(q, (bool, np.bool_, np.ndarray)):
        return q
    if isinstance(q, _Undefined):
        return float("nan")
    if not isinstance(q, Fraction):
        return float(q)
    try:
        f = float(q)
    except OverflowError:
        return -np.inf if q < 0 else float(np.finfo(float).max)
    if Fraction(f) > q:
        f = float(np.nextafter(f, -np.inf))
    return f
