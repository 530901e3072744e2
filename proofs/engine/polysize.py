"""How large an obligation's nonlinear arithmetic is, counted before z3 sees it (search only).

z3's resource count (rlimit) does not cover all of its nonlinear work: on an atom with many
mixed monomials of high degree (a degree-10 barrier polynomial in two variables, a degree-5
one in twelve) one check can run for a minute while spending few units, or spend its units
at a tenth of the usual rate. `nonlinear_size` gives a deterministic count for such atoms, so
discharge.py can leave an obligation above budget.MAX_NONLINEAR_SIZE `unknown` without asking
z3: a pure function of the formula, never of the clock. It can only withhold a proof, never
give one.

The count of one comparison `a op b` of degree above MIN_DEGREE: expand a - b into monomials
over the rationals, keep the mixed ones (two or more distinct variables; a term that is
neither a sum, a product, a power, a negation, a constant nor a variable counts as one
variable), and multiply their number, their largest total degree and the bit length of the
largest coefficient once all are integers (decimal coefficients such as 0.0052726 make the
polynomials nlsat projects huge). A formula's count is the largest over its comparisons.
Expansion stops at MAX_TERMS monomials: such a comparison counts TOO_LARGE.
"""

from __future__ import annotations

from fractions import Fraction
from math import gcd

from certiloop.models.lang.terms import Node

MAX_TERMS = 4000  # monomials held while expanding one comparison
MIN_DEGREE = 3  # comparisons of degree <= 3 count 0: left to z3's own budget
TOO_LARGE = 10**9  # the count of a comparison whose expansion passes MAX_TERMS
Monomial = tuple[tuple[str, int], ...]  # (variable, exponent), sorted by variable
Poly = dict[Monomial, Fraction]

_cache: dict[tuple, int] = {}  # comparison's key -> its count


class _TooLarge(Exception):
    pass


def nonlinear_size(formula: Node) -> int:
    """The largest count (mixed monomials x their largest degree x coefficient bits) over the
    comparisons of the formula; a comparison whose expansion passes MAX_TERMS counts TOO_LARGE.
    A shape it cannot read counts 0 (z3 then decides, as without the bound)."""
    try:
        return _size(formula)
    except (RecursionError, TypeError, ValueError, ZeroDivisionError):
        return 0


def _size(formula: Node) -> int:
    best = 0
    for atom in _comparisons(formula, []):
        if max(_degree_bound(atom.args[0]), _degree_bound(atom.args[1])) <= MIN_DEGREE:
            continue  # cheap to tell, and the common case: no expansion, no key to hash
        size = _cache.get(atom.key)
        if size is None:
            if len(_cache) > 100_000:  # a long campaign: keep memory bounded
                _cache.clear()
            size = _cache[atom.key] = _atom_size(atom)
        best = max(best, size)
    return best


def _atom_size(atom: Node) -> int:
    try:
        p = _expand(atom.args[0])
        for m, c in _expand(atom.args[1]).items():
            _add_term(p, m, -c)
    except _TooLarge:
        return TOO_LARGE
    mixed = [sum(k for _, k in m) for m, c in p.items() if len(m) >= 2]
    return len(mixed) * max(mixed) * _bits(p) if mixed else 0


def _degree_bound(n: Node) -> int:
    op = n.op
    if op == "const":
        return 0
    if op == "+":
        return max(map(_degree_bound, n.args))
    if op == "*":
        return sum(map(_degree_bound, n.args))
    if op == "neg":
        return _degree_bound(n.args[0])
    if op == "^" and isinstance(n.payload, int):
        return n.payload * _degree_bound(n.args[0])
    if op == "/" and n.args[1].op == "const":
        return _degree_bound(n.args[0])
    return 1


def _bits(p: Poly) -> int:
    """The bit length of the largest coefficient once all are made integers (by the least
    common multiple of their denominators)."""
    scale = 1
    for c in p.values():
        scale = scale * c.denominator // gcd(scale, c.denominator)
    return max(abs(c.numerator * (scale // c.denominator)).bit_length() for c in p.values())


def _comparisons(n: Node, out: list[Node]) -> list[Node]:
    if n.op == "cmp":
        if n.args[0].sort.is_numeric:
            out.append(n)
        return out
    for a in n.args:
        if isinstance(a, Node) and a.sort.name == "Bool":
            _comparisons(a, out)
    return out


def _add_term(p: Poly, m: Monomial, c: Fraction) -> None:
    total = p.get(m, Fraction(0)) + c
    if total:
        p[m] = total
        if len(p) > MAX_TERMS:
            raise _TooLarge
    else:
        p.pop(m, None)


def _times(p: Poly, q: Poly) -> Poly:
    if len(p) * len(q) > MAX_TERMS * 10:
        raise _TooLarge
    out: Poly = {}
    for m1, c1 in p.items():
        for m2, c2 in q.items():
            merged = dict(m1)
            for v, k in m2:
                merged[v] = merged.get(v, 0) + k
            _add_term(out, tuple(sorted(merged.items())), c1 * c2)
    return out


def _expand(n: Node) -> Poly:
    op = n.op
    if op == "const":
        return {(): Fraction(n.payload)} if n.payload else {}
    if op == "+":
        out: Poly = {}
        for a in n.args:
            for m, c in _expand(a).items():
                _add_term(out, m, c)
        return out
    if op == "neg":
        return {m: -c for m, c in _expand(n.args[0]).items()}
    if op == "*":
        out = {(): Fraction(1)}
        for a in n.args:
            out = _times(out, _expand(a))
        return out
    if op == "^" and isinstance(n.payload, int) and n.payload >= 0:
        base, out = _expand(n.args[0]), {(): Fraction(1)}
        for _ in range(n.payload):
            out = _times(out, base)
        return out
    if op == "/" and n.args[1].op == "const" and n.args[1].payload:
        return {m: c / Fraction(n.args[1].payload) for m, c in _expand(n.args[0]).items()}
    name = n.payload if op == "var" else n.key  # anything else: one opaque variable
    return {((str(name), 1),): Fraction(1)}
