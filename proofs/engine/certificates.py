"""Polynomial barrier certificates by semidefinite programming (search, outside the trusted core).

For a polynomial ODE x' = f(x) with rational coefficients in at most MAX_VARS variables, a
sum-of-squares program (cvxpy: each "is a sum of squares" is a PSD Gram matrix over a
monomial basis, matched coefficient by coefficient) looks for a polynomial V of degree 2, then 4,
and a level c with
    -V' - sum h_i d_i                   (V <= c is kept inside the domain: dI's premise)
    c - V - sum s_k l_k                 (V <= c on the initial set, within the domain)
    V - c - u_j m_j - sum h_i e_i       (V > c where the guarantee's atom j fails)
    V - eta*|x|^2                       (bounded sublevel sets)
all sums of squares, the multipliers d, l, m, e too (S-procedure), where the h_i >= 0 are the
domain's polynomial atoms, the s_k >= 0 those and the assumptions' atoms in the ODE's
variables (and the assumptions' pairwise products) and u_j >= 0 the failure of atom j; with
the largest common margin. V and c are rounded to rationals with small denominators and
proposed as the atom `V <= c` to the planner (odeplan). When no V decreases everywhere (a
stable equilibrium whose basin is bounded), the fallback takes V = x^T P x from the
linearisation at 0, a level c between the initial set and the failures, and a polynomial g
with -V' - g (c - V) a sum of squares: `V <= c` with the rule dbx g. The core proves each
atom or drops it with its own exact rules (the premise and the initial condition, decided by
z3). The solver proposes; nothing here decides. Any failure (solver, shape, exception)
proposes nothing.
"""

from __future__ import annotations

import itertools
import warnings
from fractions import Fraction

import numpy as np
import sympy

from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import Node, Not, cmp
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.odes import OdeStep
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy

MAX_VARS = 4
MAX_FIELD_DEGREE = 3
DEGREES = (2, 4)  # of V, cheapest first
MAX_BASIS = 20  # monomials in a Gram basis: keeps each SDP small (about a second at most)
DENOMINATORS = (1, 2, 4, 10, 100, 1000)  # rounding, most readable first
ETA = 1e-2
Exp = tuple[int, ...]

_cache: dict[tuple, list[OdeStep]] = {}


def certificate_atoms(theorem: Theorem, ode: ODE) -> list[Node]:
    """Candidate atoms `V <= c` for the ODE (at most two roundings), or [] when the system or
    the theorem is out of reach, or the solver finds nothing. Deterministic; cached per input."""
    return [step.atom for step in certificate_steps(theorem, ode)]


def certificate_steps(theorem: Theorem, ode: ODE) -> list[OdeStep]:
    """The certificates with the rule to try first: dI, or dbx with the SDP's cofactor."""
    key = (ode.key, theorem.assumptions.key, theorem.guarantee.key)
    if key not in _cache:
        if len(_cache) > 256:  # a long campaign: keep memory bounded
            _cache.clear()
        try:
            _cache[key] = _propose(theorem, ode)
        except Exception:  # noqa: BLE001 - a proposer must never stop a proof
            _cache[key] = []
    return _cache[key]


def _propose(theorem: Theorem, ode: ODE) -> list[OdeStep]:
    table = SympyTable()
    xs = [table.symbol(v) for v in ode.variables]
    if not xs or len(xs) > MAX_VARS:
        return []
    field = [_poly(to_sympy(f, table), xs) for _, f in ode.eqs]
    if any(f is None for f in field) or max(sum(e) for f in field for e in f) > MAX_FIELD_DEGREE:
        return []
    init = _sides(theorem.assumptions, xs, table, failing=False)
    unsafe = _sides(theorem.guarantee, xs, table, failing=True)
    domain = _sides(ode.domain, xs, table, failing=False)  # the core assumes it in each premise
    if not init or not unsafe:
        return []
    for degree in DEGREES:
        solved = _solve(field, init, unsafe, domain, len(xs), degree)
        if solved is not None:
            return [OdeStep(atom) for atom in _rounded(*solved, field, domain, xs, table)]
    level = _level_set(field, init, unsafe, len(xs))
    if level is None:
        return []
    V, c, g = level
    return [OdeStep(cmp("<=", _term(V, xs, table), c), "dbx", _term(g, xs, table))]


def _term(p: dict, xs: list[sympy.Symbol], table: SympyTable) -> Node:
    e = sum(sympy.Rational(q.numerator, q.denominator) * sympy.Mul(*(x**k for x, k in zip(xs, m)))
            for m, q in p.items())
    return from_sympy(sympy.expand(sympy.S(e)), table)


def _poly(e: sympy.Expr, xs: list[sympy.Symbol]) -> dict[Exp, Fraction] | None:
    """The coefficients of a polynomial over QQ in xs, or None (another symbol, a division)."""
    e = sympy.expand(e)
    if not e.free_symbols <= set(xs) or not e.is_polynomial(*xs):
        return None
    terms = sympy.Poly(e, *xs).terms() if e != 0 else []
    if not all(c.is_Rational for _, c in terms):
        return None
    return {tuple(m): Fraction(int(c.p), int(c.q)) for m, c in terms}


def _sides(f: Node, xs: list[sympy.Symbol], table: SympyTable, failing: bool) -> list[dict]:
    """Polynomials s >= 0 from the atoms of f in xs alone (failing: u >= 0 where the atom
    fails, its closure); atoms of any other shape are left out, which only weakens the SDP."""
    out = []
    for op, a, b in _literals(f):
        if not a.sort.is_numeric:
            continue
        try:
            d = _poly(to_sympy(a, table) - to_sympy(b, table), xs)
        except (TypeError, ValueError):
            continue
        if d is None or not d:
            continue
        neg = {e: -c for e, c in d.items()}
        if op in (">=", ">"):
            out.append(neg if failing else d)
        elif op in ("<=", "<"):
            out.append(d if failing else neg)
        elif op == "==" and not failing:
            out += [d, neg]
    return out


def _literals(f: Node) -> list[tuple[str, Node, Node]]:
    """The comparisons f is a conjunction of, negations pushed in (KeYmaera X writes
    guarantees as `!(p <= 0)` and `!(a | b)`); other shapes are left out."""
    if f.op == "not" and f.args[0].op == "cmp" and f.args[0].payload in _NEGATED:
        return [(_NEGATED[f.args[0].payload], *f.args[0].args)]
    if f.op == "not" and f.args[0].op == "or":
        return [x for d in f.args[0].args for x in _literals(Not(d))]
    if f.op == "cmp":
        return [(f.payload, *f.args)]
    if f.op == "and":
        return [x for part in f.args for x in _literals(part)]
    return []


_NEGATED = {"<=": ">", "<": ">=", ">=": "<", ">": "<=", "!=": "=="}


def _monomials(n: int, degree: int) -> list[Exp]:
    return [e for d in range(degree + 1) for e in sorted(
        (e for e in itertools.product(range(d + 1), repeat=n) if sum(e) == d), reverse=True)]


def _plus(a: Exp, b: Exp) -> Exp:
    return tuple(i + j for i, j in zip(a, b))


def _degree(p: dict) -> int:
    return max((sum(e) for e in p), default=0)


def _solve(field, init, unsafe, domain, n, degree):
    """(V's coefficients by monomial, c) from the SDP, or None (too big, infeasible, failed)."""
    field_degree = max(_degree(f) for f in field)
    # S-procedure terms: the initial atoms and their pairwise products (a box needs x*y terms)
    terms = [p for p in init + domain if _degree(p) <= degree]
    terms += [_times(p, q) for i, p in enumerate(init) for q in init[i:] if _degree(p) + _degree(q) <= degree]
    top = 2 * ((max(degree + field_degree - 1, degree, *map(_degree, unsafe)) + 1) // 2)
    index = {e: i for i, e in enumerate(_monomials(n, top))}
    if len(_monomials(n, top // 2)) > MAX_BASIS:
        return None
    import cvxpy as cp  # heavy (about a second): only once a certificate is wanted

    monos = _monomials(n, degree)
    v = cp.Variable(len(monos))
    embed = np.zeros((len(index), len(monos)))
    lie = np.zeros((len(index), len(monos)))
    for k, m in enumerate(monos):
        embed[index[m], k] = 1
        for i, f in enumerate(field):
            if m[i]:
                lower = tuple(d - (j == i) for j, d in enumerate(m))
                for e, c in f.items():
                    lie[index[_plus(lower, e)], k] += m[i] * float(c)
    V, dV = embed @ v, lie @ v
    square = _vector({tuple(2 * (j == i) for j in range(n)): 1 for i in range(n)}, index)
    one = _vector({(0,) * n: 1}, index)
    c, t, s = cp.Variable(), cp.Variable(), cp.Variable(nonneg=True)
    squares = [monos.index(tuple(2 * (j == i) for j in range(n))) for i in range(n)]
    # V's scale: its x_i^2 coefficients sum to n; bounded coefficients keep the solver accurate
    constraints = [t <= 1, s <= 1, cp.sum(v[squares]) == n, cp.norm(v, "inf") <= 100]
    if any(f.get((0,) * n) for f in field):
        constraints.append(s == 0)  # an equilibrium away from 0: V' = 0 there
    constraints.append(_sos(cp, V - ETA * square, n, top // 2, index))

    def multiple(p: dict, limit: int = degree):  # p times a sum of squares, degree <= limit
        return _times_matrix(p, index) @ _sos_term(cp, n, max(0, limit - _degree(p)) // 2, index)

    # V' <= 0 inside the domain; strict, so that it survives rounding
    inside = sum((multiple(h, top) for h in domain), np.zeros(len(index)))
    constraints.append(_sos(cp, -dV - s * square - inside, n, top // 2, index))

    init_side = (c - t) * one - V - sum((multiple(p) for p in terms), np.zeros(len(index)))
    constraints.append(_sos(cp, init_side, n, top // 2, index))
    for u in unsafe:
        outside = V - (c + t) * one - multiple(u) - sum((multiple(h) for h in domain), np.zeros(len(index)))
        constraints.append(_sos(cp, outside, n, top // 2, index))
    problem = cp.Problem(cp.Maximize(t + s), constraints)
    try:
        with warnings.catch_warnings():  # "inaccurate": the rounding and the core judge that
            warnings.simplefilter("ignore")
            problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if problem.status not in ("optimal", "optimal_inaccurate") or t.value is None or t.value < 1e-4:
        return None
    return dict(zip(monos, v.value)), float(c.value)


def _level_set(field, init, unsafe, n):
    """The fallback when no V decreases everywhere: V = x^T P x, a Lyapunov function of the
    linearisation at the equilibrium 0, a level c between the initial set and the failures,
    and a polynomial g with -V' >= g (c - V) everywhere (dbx: V' <= 0 where V = c, so V <= c
    is kept however V' behaves far away). (V, c, g) rounded, or None."""
    zero = (0,) * n
    if any(f.get(zero) for f in field):
        return None
    import cvxpy as cp

    units = [tuple(int(j == i) for j in range(n)) for i in range(n)]
    A = np.array([[float(f.get(u, 0)) for u in units] for f in field])
    P = cp.Variable((n, n), symmetric=True)
    lyapunov = [P >> np.eye(n), A.T @ P + P @ A << -np.eye(n)]
    if _solved(cp, cp.Problem(cp.Minimize(cp.trace(P)), lyapunov)) is None:
        return None
    P = P.value / min(np.diag(P.value))
    V = {_plus(units[i], units[j]): Fraction(round(P[i, j] * (2 - (i == j)) * 10), 10)
         for i in range(n) for j in range(i, n)}
    V = {e: q for e, q in V.items() if q}
    top = 2 * ((max(max(map(_degree, field)) + 1, 2, *map(_degree, unsafe)) + 1) // 2)
    index = {e: i for i, e in enumerate(_monomials(n, top))}
    if len(_monomials(n, top // 2)) > MAX_BASIS:
        return None

    def sos(p):
        return _sos(cp, p, n, top // 2, index)

    def multiple(p: dict):  # p times a sum of squares of degree 2 at most (else a number)
        return _times_matrix(p, index) @ _sos_term(cp, n, max(0, 2 - _degree(p)) // 2, index)

    # the levels between: init inside V <= lo, every failure outside V >= hi (S-procedure)
    Vv, one, lo, hi = _vector(V, index), _vector({zero: 1}, index), cp.Variable(), cp.Variable()
    terms = [p for p in init if _degree(p) <= 2]
    terms += [_times(p, q) for i, p in enumerate(init) for q in init[i:] if _degree(p) + _degree(q) <= 2]
    inside = [sos(lo * one - Vv - sum((multiple(p) for p in terms), np.zeros(len(index))))]
    outside = [sos(Vv - hi * one - multiple(u)) for u in unsafe]
    if _solved(cp, cp.Problem(cp.Minimize(lo), inside)) is None or \
            _solved(cp, cp.Problem(cp.Maximize(hi), outside)) is None:
        return None
    lo, hi = float(lo.value), float(hi.value)
    dV, square = _vector(_lie(V, field), index), _vector({_plus(u, u): 1 for u in units}, index)
    g_monos = _monomials(n, max(map(_degree, field)) - 1)
    for level in (lo + (hi - lo) * k for k in (0.5, 0.25, 0.75)):
        c = next((q for q in (Fraction(round(level * d), d) for d in DENOMINATORS) if lo < q < hi), None)
        if c is None:
            continue
        gap = {zero: c, **{e: -q for e, q in V.items()}}  # c - V
        times = _times_matrix(gap, index)[:, [index[m] for m in g_monos]]
        g, margin = cp.Variable(len(g_monos)), cp.Variable()
        constraints = [margin <= 1, cp.norm(g, "inf") <= 100, sos(-dV - times @ g - margin * square)]
        if _solved(cp, cp.Problem(cp.Maximize(margin), constraints)) is None or margin.value < 1e-6:
            continue
        for den in DENOMINATORS:
            rounded = {m: Fraction(round(x * den), den) for m, x in zip(g_monos, g.value)}
            rounded = {m: q for m, q in rounded.items() if q}
            if _kept(V, c, rounded, field):
                return V, c, rounded
    return None


def _solved(cp, problem):
    """The problem's value, or None when the solver fails or finds no solution."""
    try:
        with warnings.catch_warnings():  # "inaccurate": the rounding and the core judge that
            warnings.simplefilter("ignore")
            problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    return problem.value if problem.status in ("optimal", "optimal_inaccurate") else None


def _lie(V: dict, field) -> dict:
    """V' = sum_i dV/dx_i f_i, exactly."""
    out: dict = {}
    for i, f in enumerate(field):
        partial = {tuple(d - (j == i) for j, d in enumerate(e)): q * e[i] for e, q in V.items() if e[i]}
        for e, q in _times(partial, f).items():
            out[e] = out.get(e, 0) + q
    return out


def _kept(V: dict, c: Fraction, g: dict, field) -> bool:
    """-V' - g (c - V) >= 0 (up to float error) at every sample point (a filter only)."""
    n = len(field)
    rest = _lie(V, field)
    for e, q in _times(g, {(0,) * n: c, **{e: -q for e, q in V.items()}}).items():
        rest[e] = rest.get(e, 0) + q
    values = _value(rest, _samples(n))
    return bool(np.all(values <= 1e-9 * (1 + np.abs(values).max())))


def _value(p: dict, x: np.ndarray) -> np.ndarray:
    return sum((float(q) * np.prod(x ** np.array(e), axis=1) for e, q in p.items()), np.zeros(len(x)))


def _times(p: dict, q: dict) -> dict:
    out: dict = {}
    for a, x in p.items():
        for b, y in q.items():
            out[_plus(a, b)] = out.get(_plus(a, b), 0) + x * y
    return out


def _vector(p: dict, index: dict) -> np.ndarray:
    out = np.zeros(len(index))
    for e, c in p.items():
        out[index[e]] += float(c)
    return out


def _times_matrix(p: dict, index: dict) -> np.ndarray:
    """Multiplication by p, on coefficient vectors (products beyond the index's degree: none
    arise, the multipliers' degrees are chosen to fit)."""
    out = np.zeros((len(index), len(index)))
    for a, k in index.items():
        for e, c in p.items():
            if _plus(a, e) in index:
                out[index[_plus(a, e)], k] += float(c)
    return out


def _sos_term(cp, n: int, half: int, index: dict):
    """The coefficients of z^T Q z with z the monomials up to degree `half` and Q a PSD
    variable: a sum of squares (a nonnegative number for half = 0)."""
    basis = _monomials(n, half)
    gram = np.zeros((len(index), len(basis) ** 2))
    for i, a in enumerate(basis):
        for j, b in enumerate(basis):
            gram[index[_plus(a, b)], i * len(basis) + j] += 1
    return gram @ cp.vec(cp.Variable((len(basis), len(basis)), PSD=True), order="F")


def _sos(cp, p, n: int, half: int, index: dict):
    """p (coefficients over index) is a sum of squares of polynomials of degree <= half."""
    return p == _sos_term(cp, n, half, index)


def _rounded(V: dict, c: float, field, domain, xs, table) -> list[Node]:
    """`V <= c` rounded to small denominators: the first two roundings under which V' <= 0
    still holds at sample points (a cheap filter; the core's exact check decides)."""
    scale = min(V[e] for e in V if sum(e) == 2 and max(e) == 2)
    if scale <= 0:  # an inaccurate solution: no readable scale
        return []
    zero = (0,) * len(xs)
    points = _samples(len(xs))
    points = points[np.all([_value(h, points) >= 0 for h in domain], axis=0)] if domain else points
    atoms: list[Node] = []
    seen = set()
    for den in DENOMINATORS:
        coeffs = {e: Fraction(round(x / scale * den), den) for e, x in V.items() if e != zero}
        coeffs = {e: q for e, q in coeffs.items() if q}
        level = Fraction(round((c - V.get(zero, 0.0)) / scale * den), den)
        p = sum(sympy.Rational(q.numerator, q.denominator) * sympy.Mul(*(x**k for x, k in zip(xs, e)))
                for e, q in coeffs.items())
        if p == 0 or (p, level) in seen or not _decreases(coeffs, field, points):
            continue
        seen.add((p, level))
        atoms.append(cmp("<=", from_sympy(sympy.expand(p), table), level))
        if len(atoms) == 2:
            break
    return atoms


def _samples(n: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    return np.concatenate([rng.uniform(-1, 1, (200, n)), rng.uniform(-10, 10, (200, n))])


def _decreases(coeffs: dict, field, points: np.ndarray) -> bool:
    """V' <= 0 (up to float error) at every sample point."""
    def value(p: dict, x: np.ndarray) -> np.ndarray:
        return sum(float(q) * np.prod(x ** np.array(e), axis=1) for e, q in p.items())

    dV = 0.0
    for i, f in enumerate(field):
        partial = {tuple(d - (j == i) for j, d in enumerate(e)): q * e[i] for e, q in coeffs.items() if e[i]}
        dV = dV + value(partial, points) * value(f, points)
    return bool(np.all(dV <= 1e-9 * (1 + np.abs(dV).max())))
