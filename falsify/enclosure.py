"""Validated enclosures of polynomial flows: boxes certain to contain the true solution.

For x' = f(x) with f polynomial in the flow variables (coefficients: rationals, or any
arithmetic of parameters the flow keeps constant) the interval Taylor method follows a box
of start states for an exact duration. Each step of size h
  1. finds an a priori enclosure B with X + [0,h]·f(B) ⊆ B: by Picard–Lindelöf (Schauder's
     fixed point, uniqueness by the Lipschitz f) every solution from X stays in B on [0,h];
  2. takes x(h) ∈ Σ_{j<k} h^j/j!·L^j(X) + h^k/k!·L^k(B), L^j the Lie derivatives (sympy,
     once per ODE), the last term Lagrange's remainder evaluated on B.
All arithmetic is mpmath's interval arithmetic, rounded outward; rational constants and
the duration enter as enclosing intervals. Steps and halvings are bounded (no clock): a
flow that blows up, or whose boxes grow useless, is reported as `CannotEnclose`.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable

PREC = 113  # bits (quad precision): rounding far below any violation worth confirming
ORDER = 10  # Taylor order, lowered for systems whose Lie derivatives grow large
MAX_TERMS = 4000  # operations in all Lie derivatives together (sympy count_ops)
MAX_STEPS = 2000  # Taylor steps per flow
MAX_HALVINGS = 40  # of one step, before the a priori enclosure is given up (a blow-up)
INFLATE_TRIES = 6  # widenings of a candidate a priori enclosure before the step is halved
STEP_TOLERANCE = 1e-15  # relative width a step's remainder may add (else the step is halved)
MAX_RELATIVE_WIDTH = 1e-3  # a box wider than this (relative to its size) proves nothing


class CannotEnclose(Exception):
    """The flow is not polynomial, or no useful enclosure was found (say why)."""


@dataclass
class Enclosure:
    end: list[Any]  # one interval per flow variable: x(tau)
    path: list[list[Any]]  # path[i] contains x(t) for t in [times[i-1], times[i]]; path[0] = start
    times: list[Fraction]  # 0 and the end time of each step (the last is tau)

    @property
    def steps(self) -> int:
        return len(self.times) - 1

    @property
    def width(self) -> float:
        return max((float(x.delta.b) for x in self.end), default=0.0)


@contextmanager
def precision():
    """mpmath's interval context at PREC bits (it has no workprec; the old one is restored)."""
    from mpmath import iv

    old = iv.prec
    iv.prec = max(old, PREC)
    try:
        yield
    finally:
        iv.prec = old


def iv_of(x: Any):
    """An mpmath interval containing the rational (or interval) x, rounded outward."""
    from mpmath import iv

    if isinstance(x, Fraction):
        return iv.mpf(x.numerator) / iv.mpf(x.denominator)
    if isinstance(x, bool):
        raise TypeError("a truth value is not a number")
    if isinstance(x, (int, float)):
        return iv.mpf(x)
    if hasattr(x, "a") and hasattr(x, "b"):  # already an interval
        return x
    raise TypeError(f"cannot enclose the value {x!r}")


class TaylorSystem:
    """The Lie derivatives L^0..L^k of one ODE, compiled for interval evaluation."""

    def __init__(self, ode) -> None:
        import sympy

        from certiloop.proofs.core.symbolic import SympyTable, to_sympy

        table = SympyTable()
        self.names = [v.payload for v in ode.variables]
        xs = [table.symbol(v) for v in ode.variables]
        try:
            rhs = [sympy.expand(to_sympy(f, table)) for _, f in ode.eqs]
        except TypeError as exc:
            raise CannotEnclose(f"not an arithmetic right-hand side: {exc}") from None
        rhs, inverted = _inverted(rhs, xs)
        if any(not f.is_polynomial(*xs, *inverted) for f in rhs):
            bad = next(f for f in rhs if not f.is_polynomial(*xs, *inverted))
            raise CannotEnclose(f"the right-hand side {bad} is not polynomial in {xs}")
        # constants of the flow: every other symbol (a parameter, an array cell)
        known = set().union(*(f.free_symbols for f in rhs), *(d.free_symbols for d in inverted.values()))
        self.params = [s for s in sorted(known - set(xs) - set(inverted), key=str)]
        self.param_atoms = [table.atom(s) for s in self.params]
        with precision():
            self._denominators = _compiled(list(inverted.values()), xs + self.params)
        xs = xs + list(inverted)
        levels, size = [list(xs)], 0
        while len(levels) <= ORDER:
            nxt = [sympy.expand(sum(sympy.diff(g, x) * f for x, f in zip(xs, rhs))) for g in levels[-1]]
            size += sum(sympy.count_ops(g) for g in nxt)
            if size > MAX_TERMS and len(levels) > 2:  # keep order >= 2; evaluation cost grows with size
                break
            levels.append(nxt)
        self.order = len(levels) - 1  # the remainder's order k
        with precision():  # the rational constants' enclosures
            self.rhs = _compiled(rhs, xs + self.params)
            self.levels = [_compiled(level, xs + self.params) for level in levels]


    def start(self, values: list[Any], params: list[Any]) -> list[Any]:
        """The start of the enclosed system: the flow's values, then 1/d for each inverted
        denominator d (an interval holding 0 there: the flow cannot start)."""
        with precision():
            x, p = [iv_of(v) for v in values], [iv_of(v) for v in params]
            out = list(x)
            for d in self._denominators(x + p):
                if d.a <= 0 <= d.b:
                    raise CannotEnclose("a denominator of the right-hand side may be 0 where the flow starts")
                out.append(1 / d)
            return out


def _inverted(rhs: list, xs: list) -> tuple[list, dict]:
    """A rational right-hand side made polynomial: each denominator d that mentions a flow
    variable becomes a new variable w, with w' = -w^2 * d' (the derivative of 1/d). Along a
    solution that starts with w = 1/d, (w*d)' = w*d'*(1 - w*d) keeps w*d = 1 (the solution
    of a polynomial system is unique), so the enlarged system's solution from there is the
    original one, with w = 1/d beside it. Returns the enlarged right-hand sides (the flow's,
    then the w's) and {w: d}."""
    import sympy

    moving = set(xs)
    inverted: dict = {}
    out = []
    for f in rhs:
        if f.is_polynomial(*xs):
            out.append(f)
            continue
        numerator, denominator = sympy.fraction(sympy.together(f))
        denominator = sympy.expand(denominator)
        if not denominator.free_symbols & moving:
            out.append(f)
            continue
        w = next((w for w, d in inverted.items() if d == denominator), None)
        if w is None:
            w = sympy.Dummy(f"inv{len(inverted)}")
            inverted[w] = denominator
        out.append(sympy.expand(numerator * w))
    for w, d in inverted.items():
        rate = sum(sympy.diff(d, x) * f for x, f in zip(xs, out))
        out.append(sympy.expand(-w ** 2 * rate))
    return out, inverted


def _compiled(exprs, symbols) -> Callable[[list], list]:
    """Closures evaluating sympy expressions on a list of intervals (one per symbol)."""
    fns = [_compile(e, {s: k for k, s in enumerate(symbols)}) for e in exprs]
    return lambda values: [fn(values) for fn in fns]


def _compile(e, index) -> Callable[[list], Any]:
    from mpmath import iv

    if e.is_Symbol:
        k = index[e]
        return lambda v: v[k]
    if e.is_Rational:
        value = iv_of(Fraction(int(e.p), int(e.q)))
        return lambda v: value
    parts = [_compile(a, index) for a in e.args]
    if e.is_Add:
        def add(v):
            out = parts[0](v)
            for p in parts[1:]:
                out = out + p(v)
            return out
        return add
    if e.is_Mul:
        def mul(v):
            out = parts[0](v)
            for p in parts[1:]:
                out = out * p(v)
            return out
        return mul
    if e.is_Pow and e.exp.is_Integer:
        base, n = parts[0], int(e.exp)
        if n >= 0:
            return lambda v: base(v) ** n
        return lambda v: iv.mpf(1) / base(v) ** (-n)  # a parameter in a denominator
    raise CannotEnclose(f"cannot evaluate {e} in interval arithmetic")


def enclose(system: TaylorSystem, start: list[Any], params: list[Any], tau: Fraction) -> Enclosure:
    """Boxes containing the flow from (every point of) `start` for the exact duration tau."""
    if tau < 0:
        raise CannotEnclose("negative duration")
    with precision():
        x = [iv_of(v) for v in start]
        p = [iv_of(v) for v in params]
        path, times = [x], [Fraction(0)]
        done, h = Fraction(0), tau
        while done < tau:
            if len(times) > MAX_STEPS:
                raise CannotEnclose(f"more than {MAX_STEPS} Taylor steps (at t = {float(done):.6g})")
            h = min(h, tau - done)
            for _ in range(MAX_HALVINGS):
                stepped = _step(system, x, p, h)
                if stepped is not None:
                    break
                h /= 2
            else:
                raise CannotEnclose(f"no a priori enclosure at t = {float(done):.12g} even for a step of "
                                    f"{float(h):.3g}: the solution may blow up there")
            x, swept, grow = stepped
            _useful(x, done + h)
            path.append(swept)
            done += h
            times.append(done)
            h *= grow
        return Enclosure(x, path, times)


def _step(system: TaylorSystem, x: list, p: list, h: Fraction):
    """(box at h, box swept on [0,h], factor for the next step) for one Taylor step, or
    None if no a priori enclosure was found for this h or its remainder is too wide."""
    from mpmath import iv

    b = a_priori(system, x, p, h)
    if b is None:
        return None
    hh = iv_of(h)
    span = iv.mpf([0, hh.b])  # the times of the step
    coefficients = [system.levels[j](x + p) for j in range(system.order)]
    remainder = system.levels[system.order](b + p)
    factorial = [iv.mpf(1)]
    for j in range(1, system.order + 1):
        factorial.append(factorial[-1] * j)
    slope = system.rhs(b + p)  # x' on the whole step
    end, swept, worst = [], [], 0.0
    for i in range(len(x)):
        terms = [coefficients[j][i] / factorial[j] for j in range(system.order)]
        terms.append(_remainder(remainder[i] / factorial[system.order]))
        added = (terms[-1] * hh ** system.order).delta.b
        if not _finite(added) or added > STEP_TOLERANCE * (1 + abs(x[i].mid).b):
            return None  # a shorter step keeps the remainder (the truncation error) small
        worst = max(worst, float((added / (STEP_TOLERANCE * (1 + abs(x[i].mid).b))).b))
        end.append(_horner(terms, hh))
        along = _meet(_horner(terms, span), b[i])
        if slope[i].a >= 0 or slope[i].b <= 0:  # monotone on the step: between its two ends
            along = _meet(along, _hull(x[i], end[-1]))
        swept.append(along)
    # the next step: as long as keeps this remainder within the tolerance (it grows as h^k)
    grow = 2.0 if worst <= 0 else min(2.0, 0.9 * worst ** (-1 / system.order))
    return end, swept, Fraction(max(1, int(grow * 16)), 16)  # dyadic: times keep small denominators


def _remainder(term):
    """Lagrange's remainder coefficient L^k(B)/k! (a hook: tests check it is needed)."""
    return term


def a_priori(system: TaylorSystem, x: list, p: list, h: Fraction) -> list | None:
    """A box B with x + [0,h]·f(B) ⊆ B, or None."""
    from mpmath import iv

    span = iv.mpf([0, iv_of(h).b])
    b = [xi + span * fi for xi, fi in zip(x, system.rhs(x + p))]
    for _ in range(INFLATE_TRIES):
        b = [_widen(bi) for bi in b]
        image = [xi + span * fi for xi, fi in zip(x, system.rhs(b + p))]
        if not all(_finite(y) for y in image):
            return None
        if all(bi.a <= y.a and y.b <= bi.b for bi, y in zip(b, image)):
            return image  # contained in b, so it is an enclosure too (and tighter)
        b = [_hull(bi, y) for bi, y in zip(b, image)]
    return None


def _widen(b):
    from mpmath import iv

    r = b.delta.b / 4 + (abs(b.mid).b + 1) * iv.mpf(2) ** -(PREC // 2)
    return iv.mpf([(b - r).a, (b + r).b])


def _horner(terms: list, t):
    out = terms[-1]
    for c in reversed(terms[:-1]):
        out = out * t + c
    return out


def _hull(a, b):
    from mpmath import iv

    return iv.mpf([min(a.a, b.a), max(a.b, b.b)])


def _meet(a, b):
    from mpmath import iv

    lo, hi = max(a.a, b.a), min(a.b, b.b)
    return iv.mpf([lo, hi]) if lo <= hi else b


def _finite(y) -> bool:
    from mpmath import isfinite

    return bool(isfinite(y.a) and isfinite(y.b))


def _useful(box: list, t: Fraction) -> None:
    for y in box:
        if not _finite(y) or y.delta.b > MAX_RELATIVE_WIDTH * (1 + abs(y.mid).b):
            raise CannotEnclose(f"the enclosure grew too wide at t = {float(t):.12g} (width "
                                f"{float(y.delta.b):.3g}): the flow may blow up or the boxes wrap")
