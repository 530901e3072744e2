"""Square roots (`e^(1/2)`, `sqrt(e)`) in kyx formulas, translated into polynomial arithmetic.

A root whose argument is a sum of squares (`(x-xc)^2 + (y-yc)^2`, `2`) is never evaluated at
a negative number, so each comparison using it is replaced by an equivalent one without it:
with s = sqrt(e) >= 0 and s^2 = e, a term is A + B*s (A, B polynomials, s^2 reduced to e)
and its sign follows from the signs of A, B and A^2 - B^2*e (`sign_condition`). Any other
root is named by a symbol the reader pins in the assumptions (s >= 0 & s^2 = e), which is
exact only where e >= 0: that is a side condition of the claim (kyx/reader.py). A never-negative
argument has no division but by a number: the sign condition evaluates e only in some of its
branches, so a division there would escape the claim's check for division by zero."""

from __future__ import annotations

from fractions import Fraction
from math import isqrt

from certiloop.models.lang.terms import FALSE, TRUE, And, Node, Not, Or, cmp, const, div, free_vars, neg

Pair = tuple["Node | None", "Node | None"]  # A + B*s, None for a zero part


def exact_root(c: Fraction) -> Fraction | None:
    """sqrt(c) when it is rational (c >= 0), else None."""
    p, q = c.numerator, c.denominator
    if p < 0 or isqrt(p) ** 2 != p or isqrt(q) ** 2 != q:
        return None
    return Fraction(isqrt(p), isqrt(q))


def number(e: Node) -> Fraction | None:
    """The value of a term built from numbers alone (`3.986*10^14/(42164*10^3)^3`), or None
    (a symbol, or a division by 0)."""
    op = e.op
    if op == "const":
        return e.payload
    values = [number(a) for a in e.args]
    if not values or any(v is None for v in values):
        return None
    if op == "+":
        return sum(values, Fraction(0))
    if op == "neg":
        return -values[0]
    if op == "*":
        out = Fraction(1)
        for v in values:
            out *= v
        return out
    if op == "/":
        return None if values[1] == 0 else values[0] / values[1]
    if op == "^" and isinstance(e.payload, int) and (e.payload >= 0 or values[0] != 0):
        return values[0] ** e.payload
    return None


def never_negative(e: Node) -> bool:
    """e >= 0 everywhere, by its shape: constants >= 0, even powers, x*x, and sums, products
    and quotients by positive numbers of such. Not `1/x^2`: a comparison's sign condition
    does not always evaluate e, so a division inside it would escape its check for zero."""
    if e.op == "/" and not (e.args[1].op == "const" and e.args[1].payload > 0):
        return False
    if e.op == "const":
        return e.payload >= 0
    if e.op == "^":
        return e.payload % 2 == 0 or never_negative(e.args[0])
    if e.op == "*" and len(e.args) == 2 and e.args[0].key == e.args[1].key:
        return True
    if e.op in ("+", "*", "/"):
        return all(never_negative(a) for a in e.args)
    return False


class NotPolynomialInRoot(ValueError):
    """The root sits where A + B*s has no meaning (inside an array read, say)."""


def split(t: Node, root: str, e: Node) -> Pair:
    """(A, B) with t = A + B*s, where the symbol `root` stands for s = sqrt(e)."""
    if root not in free_vars(t):
        return t, None
    op = t.op
    if op == "var":
        return None, const(1)
    if op == "+":
        out: Pair = (None, None)
        for a in t.args:
            out = _plus(out, split(a, root, e))
        return out
    if op == "neg":
        a, b = split(t.args[0], root, e)
        return (neg(a) if a is not None else None), (neg(b) if b is not None else None)
    if op == "*":
        out = (const(1), None)
        for a in t.args:
            out = _times(out, split(a, root, e), e)
        return out
    if op == "^" and isinstance(t.payload, int) and t.payload >= 0:
        base, out = split(t.args[0], root, e), (const(1), None)
        for _ in range(t.payload):
            out = _times(out, base, e)
        return out
    if op == "/":
        (a, b), (c, d) = split(t.args[0], root, e), split(t.args[1], root, e)
        if d is None:
            return (div(a, c) if a is not None else None), (div(b, c) if b is not None else None)
        # (a + b*s) / (c + d*s) = (a + b*s)(c - d*s) / (c^2 - d^2*e): a division the claim's
        # well-definedness obligations then check nonzero (stronger than c + d*s != 0: safe)
        c = c if c is not None else const(0)
        top = _times((a, b), (c, neg(d)), e)
        bottom = c * c - d * d * e
        return ((div(top[0], bottom) if top[0] is not None else None),
                (div(top[1], bottom) if top[1] is not None else None))
    raise NotPolynomialInRoot(f"`{t}`")


def _plus(x: Pair, y: Pair) -> Pair:
    return _sum(x[0], y[0]), _sum(x[1], y[1])


def _times(x: Pair, y: Pair, e: Node) -> Pair:
    """(a + b*s)(c + d*s) = (a*c + b*d*e) + (a*d + b*c)*s."""
    (a, b), (c, d) = x, y
    return _sum(_mul(a, c), _mul(_mul(b, d), e)), _sum(_mul(a, d), _mul(b, c))


def _sum(p: Node | None, q: Node | None) -> Node | None:
    return q if p is None else p if q is None else p + q


def _mul(p: Node | None, q: Node | None) -> Node | None:
    return None if p is None or q is None else p * q


def sign_condition(op: str, a: Node | None, b: Node, e: Node) -> Node:
    """`a + b*s op 0` for s = sqrt(e) (e >= 0), without s: exact. Constant a or b (the
    usual `root op bound`) give the short forms a reader expects."""
    a = a if a is not None else const(0)
    if op in ("<", "<="):
        return sign_condition({"<": ">", "<=": ">="}[op], _negated(a), _negated(b), e)
    b_squared_e = e if _is(b, lambda c: c * c == 1) else _product(b, b) * e
    a_squared = _product(a, a)
    if op == "==":  # a = -b*s: opposite signs (or a zero) and equal squares
        return And(_compare("<=", _product(a, b), 0), _compare("==", a_squared, b_squared_e))
    if op == "!=":
        return Not(sign_condition("==", a, b, e))
    strict = op == ">"
    # a >= 0: enough when b >= 0, else a must outweigh |b|*s; a < 0: b*s must outweigh it
    a_wins, b_wins = _compare(op, a_squared, b_squared_e), _compare(op, b_squared_e, a_squared)
    if _is(b, lambda c: c > 0):
        return Or(_compare(op, a, 0), b_wins)
    if _is(b, lambda c: c < 0):
        return And(_compare(op, a, 0), a_wins)
    if _is(b, lambda c: c == 0):
        return _compare(op, a, 0)
    return Or(And(_compare(op, a, 0), Or(_compare(">=", b, 0), a_wins)),
              And(_compare("<=" if strict else "<", a, 0), _compare(">", b, 0), b_wins))


def _is(n: Node, test) -> bool:
    return n.op == "const" and test(n.payload)


def _product(p: Node, q: Node) -> Node:
    return const(p.payload * q.payload) if p.op == "const" and q.op == "const" else p * q


def _negated(n: Node) -> Node:
    return const(-n.payload) if n.op == "const" else neg(n)


def _compare(op: str, a: Node, b: Node | int) -> Node:
    """cmp, decided at once when both sides are numbers."""
    b = b if isinstance(b, Node) else const(b)
    if a.op == "const" and b.op == "const":
        x, y = a.payload, b.payload
        holds = {"<": x < y, "<=": x <= y, ">": x > y, ">=": x >= y, "==": x == y, "!=": x != y}[op]
        return TRUE if holds else FALSE
    return cmp(op, a, b)


def without_root(f: Node, root: str, e: Node) -> Node:
    """The formula f (connectives over comparisons) with every comparison that uses the
    root symbol replaced by its sign condition."""
    if root not in free_vars(f):
        return f
    if f.op == "cmp":
        a, b = split(f.args[0] - f.args[1], root, e)
        return sign_condition(f.payload, a, b if b is not None else const(0), e)
    if f.op in ("and", "or", "not", "implies", "iff"):
        return Node(f.op, tuple(without_root(g, root, e) for g in f.args), f.sort, f.payload)
    raise NotPolynomialInRoot(f"`{f}`")
