"""A float start state on a circle `u^2 + v^2 = r^2`, moved to a rational point of it.

A unit normal drawn in floating point (nx, ny) meets nx^2 + ny^2 = 1 only up to rounding,
and almost no point of the circle is rational, so the exact replay rejects the state. The
rational points are dense on a circle with a rational radius: from (-r, 0), the line of
slope m meets it again at (r(1 - m^2)/(1 + m^2), 2rm/(1 + m^2)). A slope close to the
float point's, with a bounded denominator, gives a rational point within rounding of it.
The interpreter then checks the assumptions exactly, so this can only make a replay
possible, never forge one.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

from certiloop.models.lang.terms import Node

DENOMINATOR = 10**8  # the slope's: the point moves by ~1e-16 of r at most


def circle_point(atom: Node, state: dict[str, Any], names: list[str]) -> dict[str, Fraction] | None:
    """New rational values for two of `names` that put them on the circle the equation
    `atom` states (u^2 + v^2 = r^2 with everything else known and r rational), or None."""
    import sympy

    from certiloop.proofs.core.symbolic import SympyTable, to_sympy

    table = SympyTable()
    try:
        expr = sympy.expand(to_sympy(atom.args[0], table) - to_sympy(atom.args[1], table))
    except Exception:  # noqa: BLE001 - a construct sympy does not take: no snapping
        return None
    variables = [a for a in table.atoms() if a.op == "var"]
    symbols = {str(table.symbol(a)): a for a in variables}
    known = {table.symbol(a): state[a.payload] for a in variables
             if type(state.get(a.payload)) in (int, Fraction)}
    free = [table.symbol(a) for a in variables if a.payload in names]
    for i, u in enumerate(free):
        for v in free[i + 1:]:
            rest = expr.subs({s: sympy.Rational(x.numerator, x.denominator)
                              for s, x in known.items() if s not in (u, v)})
            point = _on_circle(rest, u, v, state, symbols)
            if point is not None:
                return point
    return None


def _on_circle(expr, u, v, state: dict[str, Any], symbols) -> dict[str, Fraction] | None:
    import sympy

    try:
        poly = sympy.Poly(expr, u, v)
    except sympy.PolynomialError:
        return None
    terms = dict(poly.terms())
    a = terms.get((2, 0))
    if a is None or a == 0 or terms.get((0, 2)) != a or set(terms) - {(2, 0), (0, 2), (0, 0)}:
        return None
    square = -terms.get((0, 0), 0) / a
    if not square.is_Rational or square <= 0:
        return None
    num, den = sympy.sqrt(square.p), sympy.sqrt(square.q)
    if not (num.is_Integer and den.is_Integer):
        return None
    r = Fraction(int(num), int(den))
    un, vn = symbols[str(u)].payload, symbols[str(v)].payload
    x, y = float(state[un]), float(state[vn])
    if not (math.isfinite(x) and math.isfinite(y)) or x + float(r) == 0:
        return None
    m = Fraction(y / (x + float(r))).limit_denominator(DENOMINATOR)
    return {un: r * (1 - m * m) / (1 + m * m), vn: r * 2 * m / (1 + m * m)}


def sphere_point(values: list[float], r: Fraction) -> list[Fraction] | None:
    """A rational point of the sphere sum(x_i^2) = r^2 near `values`: stereographic
    parameters from the pole on the far side of the first coordinate, each a rational with
    a bounded denominator."""
    x0, rest = values[0], values[1:]
    side = 1 if x0 >= 0 else -1  # the pole (-side*r, 0, ...): far from the point
    base = x0 * side + float(r)
    if not base > 0 or not all(math.isfinite(v) for v in values):
        return None
    m = [Fraction(v / base).limit_denominator(DENOMINATOR) for v in rest]
    total = sum(x * x for x in m)
    return [side * r * (1 - total) / (1 + total), *(2 * r * x / (1 + total) for x in m)]


def radius(values: list[float]) -> Fraction | None:
    """r, a short rational, where the values' squares sum to r^2 within rounding."""
    square = sum(v * v for v in values)
    if not (math.isfinite(square) and square > 0):
        return None
    r = Fraction(math.sqrt(square)).limit_denominator(1000)
    return r if abs(float(r * r) - square) <= 1e-9 * (1 + square) else None
