"""Darboux polynomials of polynomial ODEs by a degree-bounded search (outside the trusted core).

For x' = f(x) with f polynomial over QQ (at most MAX_VARS variables), a Darboux polynomial p
satisfies p' = g*p with a polynomial cofactor g of degree <= deg f - 1; its sign never changes
along a flow, so `p >= 0` and `p <= 0` (or, where the assumptions fix the start point, the one
sign p has there, and `p = c` for a first integral) are candidate invariant atoms for the
planner (odeplan), which the core proves by its exact Darboux identity or drops. Nothing here
decides.

p' - g*p = 0 is bilinear in the coefficients of p and g. The search fixes the non-constant
part h of g from a short, deterministic list and solves the rest, (L_f - h)(p) = λ p with λ a
rational constant, exactly by linear algebra over QQ (a generalised eigenproblem on the
polynomials of degree <= d whose image stays of degree <= d). The list of h:
  * 0: first integrals (λ = 0) and constant cofactors (the affine left eigenvectors, and more);
  * the cofactors of the irreducible factors q of the field's components that divide their own
    derivative (x' = x*(1 - y) gives p = x, g = 1 - y);
  * the top-degree part of g forced by the top-degree part of the field: in two variables an
    irreducible homogeneous Darboux polynomial of the top field F divides x*F_2 - y*F_1, so p's
    top part is a product of such factors (for a radial top field F = r*(x, y), g's top is d*r);
    with both top parts fixed, g's next part solves a linear system.
In two variables with deg f = 2 and x*F_2 - y*F_1 != 0 this finds the cofactor of every p whose
top part factors over QQ (g = top + λ), though an eigenspace of dimension > 1 is returned as a
basis only; for deg f = 3 the next part is one particular solution when it is not unique, and
for higher degrees g's lower non-constant parts are taken as 0, so cofactors can be missed.
Each result is re-checked here (p' = g*p identically) and the core checks it again. Sizes are
bounded by counts, not a clock.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import sympy
from sympy import QQ
from sympy.polys.matrices import DomainMatrix

from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import Node, cmp, const
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.odes import conjuncts
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy

MAX_VARS = 4
MAX_ENTRIES = 2500  # rows x columns of one linear system: keeps each solve to milliseconds
MAX_SHIFTS = 8  # non-constant cofactor parts tried per degree
MAX_FOUND = 6  # Darboux polynomials proposed per ODE (each gives one or two atoms to the planner)
MAX_FACTOR_DEGREE = 3  # factors of the field's components tried as p directly
Exp = tuple[int, ...]

_cache: dict[tuple, list[Node]] = {}


def search_atoms(theorem: Theorem, ode: ODE) -> list[Node]:
    """Candidate atoms from the Darboux polynomials of a non-affine polynomial ODE, or [].
    Per p, from its range [lo, hi] over the box the assumptions' bounds give the ODE's
    variables (a point where they fix it): the sign p has there (`p > 0`, `p < 0`, `p = 0`,
    `p >= 0`, `p <= 0`), for a first integral `lo <= p`, `p <= hi` (`p = c` at a point);
    without a box, `p >= 0` and `p <= 0`. Deterministic; cached per input."""
    key = (ode.key, theorem.assumptions.key)
    if key not in _cache:
        if len(_cache) > 256:  # a long campaign: keep memory bounded
            _cache.clear()
        try:
            _cache[key] = _atoms(theorem, ode)
        except Exception:  # noqa: BLE001 - a proposer must never stop a proof
            _cache[key] = []
    return _cache[key]


def _atoms(theorem: Theorem, ode: ODE) -> list[Node]:
    table = SympyTable()
    xs = [table.symbol(v) for v in ode.variables]
    field = _field(ode, xs, table)
    if field is None or max(f.total_degree() for f in field) < 2:
        return []  # not polynomial over QQ, or affine: darboux.py's eigenvectors cover it
    box = _start_box(theorem, ode, table)
    atoms: list[Node] = []
    for p, g in darboux_polynomials(field, xs):
        atoms += _proposed(from_sympy(p.as_expr(), table), _range(p, box), g.is_zero)
    return atoms


Interval = tuple[sympy.Rational | None, sympy.Rational | None]  # None: unbounded


def _proposed(p: Node, span: Interval, first_integral: bool) -> list[Node]:
    """The atoms proposed for a Darboux polynomial p whose values at the start lie in `span`.
    Its sign never changes, so the start's sign is the strongest claim (a first integral keeps
    its value); the range only guides the choice: the core checks the start anyway."""
    lo, hi = span
    if first_integral and (lo is not None or hi is not None):
        if lo == hi:
            return [cmp("==", p, _const(lo))]
        return [cmp(op, p, _const(c)) for op, c in ((">=", lo), ("<=", hi)) if c is not None]
    if lo is not None and lo > 0:
        return [cmp(">", p, 0)]
    if hi is not None and hi < 0:
        return [cmp("<", p, 0)]
    if lo == 0 and hi == 0:
        return [cmp("==", p, 0)]
    if lo == 0:
        return [cmp(">=", p, 0)]
    if hi == 0:
        return [cmp("<=", p, 0)]
    return [cmp(">=", p, 0), cmp("<=", p, 0)]


def _const(c: sympy.Rational) -> Node:
    return const(Fraction(int(c.p), int(c.q)))


def _field(ode: ODE, xs: list[sympy.Symbol], table: SympyTable) -> list[sympy.Poly] | None:
    """The right-hand sides as polynomials over QQ in the ODE's variables, or None."""
    if not xs or len(xs) > MAX_VARS:
        return None
    field = []
    for _, f in ode.eqs:
        e = sympy.expand(to_sympy(f, table))
        if not e.is_polynomial(*xs) or e.free_symbols - set(xs):
            return None
        try:
            field.append(sympy.Poly(e, *xs, domain=QQ))
        except (sympy.PolynomialError, sympy.CoercionFailed):
            return None
    return field


def _start_box(theorem: Theorem, ode: ODE, table: SympyTable) -> dict[sympy.Symbol, Interval]:
    """Bounds the assumptions' conjuncts put on the ODE's variables (`x >= 1/2`, `x = 1`, a
    strict bound read as non-strict), each variable's tightest."""
    names = {v.payload: table.symbol(v) for v in ode.variables}
    box: dict[sympy.Symbol, list] = {}
    for atom in conjuncts(theorem.assumptions):
        if atom.op != "cmp" or atom.payload == "!=" or not atom.args[0].sort.is_numeric:
            continue
        a, b = atom.args
        for var, val, op in ((a, b, atom.payload), (b, a, _FLIPPED[atom.payload])):
            if var.op != "var" or var.payload not in names:
                continue
            try:
                c = to_sympy(val, SympyTable())
            except TypeError:
                continue
            if not c.is_Rational:
                continue
            lo, hi = box.setdefault(names[var.payload], [None, None])
            if op in (">=", ">", "=="):
                box[names[var.payload]][0] = c if lo is None else max(lo, c)
            if op in ("<=", "<", "=="):
                box[names[var.payload]][1] = c if hi is None else min(hi, c)
    return {v: (lo, hi) for v, (lo, hi) in box.items()}


_FLIPPED = {">=": "<=", ">": "<", "<=": ">=", "<": ">", "==": "=="}


def _range(p: sympy.Poly, box: dict[sympy.Symbol, Interval]) -> Interval:
    """An enclosure of p's values over the box, by interval arithmetic on its monomials."""
    total: Interval = (sympy.Integer(0), sympy.Integer(0))
    for exps, c in p.as_dict().items():
        term: Interval = (c, c)
        for v, k in zip(p.gens, exps):
            if k:
                term = _times(term, _power(box.get(v, (None, None)), k))
        total = (_add(total[0], term[0]), _add(total[1], term[1]))
    return total


def _add(a, b):
    return None if a is None or b is None else a + b


def _power(span: Interval, k: int) -> Interval:
    lo, hi = span
    if k % 2 == 1:
        return (None if lo is None else lo**k, None if hi is None else hi**k)
    if lo is not None and lo >= 0:
        return (lo**k, None if hi is None else hi**k)
    if hi is not None and hi <= 0:
        return (hi**k, None if lo is None else lo**k)
    top = None if lo is None or hi is None else max(lo**k, hi**k)
    return (sympy.Integer(0), top)


def _times(a: Interval, b: Interval) -> Interval:
    """Interval product. With an unbounded end: a constant a scales b, else all is unbounded
    (simple, and only ever a wider enclosure)."""
    if a == (0, 0) or b == (0, 0):
        return (sympy.Integer(0), sympy.Integer(0))
    if None in a or None in b:
        if a[0] is not None and a[0] == a[1]:  # a constant times an interval
            c = a[0]
            ends = (None if b[0] is None else c * b[0], None if b[1] is None else c * b[1])
            return ends if c >= 0 else (ends[1], ends[0])
        return (None, None)
    products = [x * y for x in a for y in b]
    return (min(products), max(products))


# --------------------------------------------------------------------------- the search


def darboux_polynomials(field: list[sympy.Poly], xs: list[sympy.Symbol],
                        degrees: tuple[int, ...] | None = None) -> list[tuple[sympy.Poly, sympy.Poly]]:
    """(p, g) with p' = g*p identically along x' = field, p non-constant, irreducible over QQ,
    primitive with integer coefficients, each checked exactly; at most MAX_FOUND, in a fixed
    order (the field's factors first, then by degree of p)."""
    if degrees is None:
        degrees = (1, 2, 3) if len(xs) <= 2 else (1, 2)
    found: dict[tuple, tuple[sympy.Poly, sympy.Poly]] = {}

    def add(p: sympy.Poly) -> None:
        for q in _irreducible_parts(p):
            g = _cofactor(q, field)
            if g is None:
                continue
            # first integrals p and p + c are one: their atoms are chosen by the range anyway
            key = _key(_nonconstant(q)) if g.is_zero else _key(q)
            if key not in found and len(found) < MAX_FOUND:
                found[key] = (q, g)

    for q in _component_factors(field):
        add(q)
    for d in degrees:
        if len(found) >= MAX_FOUND:
            break
        for h in _shifts(field, xs, d, [g for _, g in found.values()]):
            for p in _eigenpolynomials(field, xs, d, h):
                add(p)
    return list(found.values())


def lie(p: sympy.Poly, field: list[sympy.Poly]) -> sympy.Poly:
    """p' along the field."""
    total = sympy.Poly(0, *p.gens, domain=QQ)
    for i, f in enumerate(field):
        total += p.diff(p.gens[i]) * f
    return total


def _cofactor(p: sympy.Poly, field: list[sympy.Poly]) -> sympy.Poly | None:
    """g with p' = g*p exactly, or None."""
    q, r = lie(p, field).div(p)
    return q if r.is_zero else None


def _key(p: sympy.Poly) -> tuple:
    return tuple(sorted(p.as_dict().items()))


def _normal(p: sympy.Poly) -> sympy.Poly:
    """The primitive integer multiple of p whose leading coefficient is positive."""
    _, p = p.clear_denoms(convert=False)
    p = p.primitive()[1]
    return -p if p.LC() < 0 else p


def _irreducible_parts(p: sympy.Poly) -> list[sympy.Poly]:
    """The non-constant irreducible factors of p over QQ, normalised (a factor of a Darboux
    polynomial is one too; a product adds nothing its factors do not)."""
    if p.is_zero or p.is_ground:
        return []
    return [_normal(q) for q, _ in p.factor_list()[1] if not q.is_ground]


def _component_factors(field: list[sympy.Poly]) -> list[sympy.Poly]:
    """The irreducible factors of the field's components of degree <= MAX_FACTOR_DEGREE, in
    order: the cheap common case x' = x*(...)."""
    out: dict[tuple, sympy.Poly] = {}
    for f in field:
        for q in _irreducible_parts(f):
            if q.total_degree() <= MAX_FACTOR_DEGREE:
                out.setdefault(_key(q), q)
    return list(out.values())


def _homogeneous(p: sympy.Poly, d: int) -> sympy.Poly:
    """The part of p of total degree d."""
    terms = {e: c for e, c in p.as_dict().items() if sum(e) == d}
    return sympy.Poly.from_dict(terms or {(0,) * len(p.gens): 0}, *p.gens, domain=QQ)


def _nonconstant(g: sympy.Poly) -> sympy.Poly:
    return g - g.coeff_monomial((0,) * len(g.gens))


def _shifts(field: list[sympy.Poly], xs: list[sympy.Symbol], d: int,
            known: list[sympy.Poly]) -> list[sympy.Poly]:
    """The non-constant cofactor parts h to try for p of degree d, deduplicated, in order."""
    zero = sympy.Poly(0, *xs, domain=QQ)
    out: dict[tuple, sympy.Poly] = {_key(zero): zero}
    for g in known + _top_cofactors(field, xs, d):
        h = _nonconstant(g)
        out.setdefault(_key(h), h)
    return list(out.values())[:MAX_SHIFTS]


def _top_cofactors(field: list[sympy.Poly], xs: list[sympy.Symbol], d: int) -> list[sympy.Poly]:
    """The two highest homogeneous parts of the cofactors a Darboux polynomial of degree d can
    have (two variables): p's top part P divides x*F_2 - y*F_1 for the field's top part F, which
    fixes g's top part G; with P and G fixed, the next-highest part of p' = g*p is linear in
    p's and g's next parts, whose solution gives g's next part (for deg f = 3, all of g but its
    constant). For a radial F = r*(x, y), any P works and only G = d*r is known."""
    m = max(f.total_degree() for f in field)
    if len(xs) != 2 or m < 2:
        return []
    top = [_homogeneous(f, m) for f in field]
    x, y = (sympy.Poly(v, *xs, domain=QQ) for v in xs)
    H = x * top[1] - y * top[0]
    if H.is_zero:
        r, rest = top[0].div(x)
        return [r * d] if rest.is_zero and not r.is_zero else []
    factors = [q for q in _irreducible_parts(H) if q.total_degree() <= d]
    out = []
    for k in range(1, d + 1):
        for combo in itertools.combinations_with_replacement(factors, k):
            P = _homogeneous(sympy.prod(combo, start=sympy.Poly(1, *xs, domain=QQ)), d)
            if P.total_degree() != d or P.is_zero:
                continue
            G, rest = lie(P, top).div(P)
            if rest.is_zero:
                out.append(G + _next_part(field, P, G, d, m) if d >= 1 and m >= 3 else G)
    return out


def _next_part(field: list[sympy.Poly], P: sympy.Poly, G: sympy.Poly, d: int, m: int) -> sympy.Poly:
    """g's part of degree m - 2, given the top parts P of p and G of g: the degree d + m - 2
    part of p' - g*p, L_top(p_next) + L_next(P) - G*p_next - g_next*P = 0, is linear in the
    coefficients of p_next (degree d - 1) and g_next (degree m - 2); the solution with the free
    unknowns 0, or 0 when there is none."""
    gens, n = P.gens, len(P.gens)
    top = [_homogeneous(f, m) for f in field]
    following = [_homogeneous(f, m - 1) for f in field]
    unknown_p = [e for e in _monomials(n, d - 1) if sum(e) == d - 1]
    unknown_g = [e for e in _monomials(n, m - 2) if sum(e) == m - 2]
    monomial = lambda e: sympy.Poly.from_dict({e: 1}, *gens, domain=QQ)  # noqa: E731
    columns = ([lie(monomial(e), top) - G * monomial(e) for e in unknown_p]
               + [-(monomial(e) * P) for e in unknown_g] + [lie(P, following)])
    rows = [e for e in _monomials(n, d + m - 2) if sum(e) == d + m - 2]
    if len(rows) * len(columns) > MAX_ENTRIES:
        return sympy.Poly(0, *gens, domain=QQ)
    A = _matrix([[c.as_dict().get(e, 0) for c in columns] for e in rows], len(columns))
    R, pivots = A.rref()
    last = len(columns) - 1
    if last in pivots:
        return sympy.Poly(0, *gens, domain=QQ)  # inconsistent: no such p_next and g_next
    values = {c: -R.to_Matrix()[i, last] for i, c in enumerate(pivots)}
    offset = len(unknown_p)
    terms = {e: values.get(offset + j, 0) for j, e in enumerate(unknown_g)}
    return sympy.Poly.from_dict(terms or {(0,) * n: 0}, *gens, domain=QQ)


def _monomials(n: int, degree: int) -> list[Exp]:
    """Exponents of total degree <= degree, by degree then lexicographically (fixed order)."""
    return sorted((e for e in itertools.product(range(degree + 1), repeat=n) if sum(e) <= degree),
                  key=lambda e: (sum(e), tuple(-k for k in e)))


def _eigenpolynomials(field: list[sympy.Poly], xs: list[sympy.Symbol], d: int,
                      h: sympy.Poly) -> list[sympy.Poly]:
    """A basis of the non-constant p of degree <= d with (L_f - h)(p) = λ p for some rational
    λ, each eigenspace in turn (λ ascending); for h = 0 and λ = 0 (first integrals), a basis
    modulo constants."""
    basis = _monomials(len(xs), d)
    images = [lie(sympy.Poly.from_dict({e: 1}, *xs, domain=QQ), field)
              - h * sympy.Poly.from_dict({e: 1}, *xs, domain=QQ) for e in basis]
    high = sorted({e for im in images for e in im.as_dict() if sum(e) > d})
    if (len(high) + len(basis)) * len(basis) > MAX_ENTRIES:
        return []
    index = {e: i for i, e in enumerate(basis)}
    # columns: the images of the monomials; rows: the monomials of degree > d, then <= d
    H = _matrix([[im.as_dict().get(e, 0) for im in images] for e in high], len(basis))
    L = _matrix([[im.as_dict().get(e, 0) for im in images] for e in basis], len(basis))
    kernel = (H.nullspace().transpose() if high else DomainMatrix.eye(len(basis), QQ)).to_dense()
    k = kernel.shape[1]
    if k == 0:
        return []
    TB = L.matmul(kernel)  # the images of the kernel's basis, all of degree <= d
    rows = kernel.transpose().rref()[1]  # k rows where the kernel's basis is independent
    square, image = _rows(kernel, rows), _rows(TB, rows)
    A = square.inv().matmul(image)
    found = []
    for lam in _rational_roots(A.charpoly()):
        space = (TB - kernel.mul(QQ.convert(lam))).nullspace()
        vectors = [kernel.matmul(space.transpose()).to_Matrix()[:, j] for j in range(space.shape[0])]
        if h.is_zero and lam == 0:
            vectors = _modulo_constants(vectors, index[(0,) * len(xs)])
        for v in vectors:
            p = sympy.Poly.from_dict({e: v[i] for i, e in enumerate(basis) if v[i] != 0} or {basis[0]: 0},
                                     *xs, domain=QQ)
            if not p.is_ground:
                found.append(p)
    return found


def _matrix(rows: list[list], ncols: int) -> DomainMatrix:
    return DomainMatrix([[QQ.convert(c) for c in r] for r in rows], (len(rows), ncols), QQ)


def _rows(M: DomainMatrix, rows: tuple[int, ...]) -> DomainMatrix:
    return M.extract(list(rows), list(range(M.shape[1])))


def _rational_roots(coefficients: list) -> list[sympy.Rational]:
    """The distinct rational roots of a polynomial given by its coefficients, ascending."""
    t = sympy.Symbol("t")
    poly = sympy.Poly([QQ.to_sympy(QQ.convert(c)) for c in coefficients], t, domain=QQ)
    return sorted({-q.coeff_monomial(1) / q.LC() for q, _ in poly.factor_list()[1] if q.degree() == 1})


def _modulo_constants(vectors: list[sympy.Matrix], constant: int) -> list[sympy.Matrix]:
    """The vectors with the constant coefficient cleared, reduced to an independent set."""
    cleared = []
    for v in vectors:
        v = v.copy()
        v[constant] = 0
        cleared.append(v)
    if not cleared:
        return []
    M = sympy.Matrix.hstack(*cleared).T
    R, pivots = M.rref()
    return [R[i, :].T for i in range(len(pivots))]
