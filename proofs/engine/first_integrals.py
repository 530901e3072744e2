"""First integrals of polynomial ODEs whose coefficients hold parameters (search, outside the
trusted core; darboux_search.py covers fields over QQ).

x' = f(x) with f polynomial in x over QQ(k), k the symbols the ODE does not move: a first
integral J (J' = 0) of degree <= d is a vector in the nullspace of the linear map L_f on
the polynomials of degree <= d, a matrix over the field QQ(k). Each basis vector, cleared of
denominators and of its content in k, is re-checked here (J' = 0 identically) and proposed
as an atom whose truth at the start the assumptions give:
  * `J = J(x0)` where the assumptions fix every variable of J (x1 = 0 & v1 = 1 & ...);
  * `J op c` where an assumption `a op b` is, on the start the assumptions fix, J - c times a
    positive rational (Flight Maneuvers: `w1^2*(x^2 + y^2) - 8*w1*y > -8*w1 + w1^2` with
    cos = 1, sin = 0 gives J > 8 - 8*w1 + w1^2 for the integral J of the turn).
The core proves the atom by its own exact rules (J' = 0 is a differential invariant) or drops
it; nothing here decides. Sizes are bounded by counts, not a clock.
"""

from __future__ import annotations

import itertools

import sympy
from sympy.polys.matrices import DomainMatrix

from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import Node, cmp
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.odes import conjuncts
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy

MAX_VARS = 4
MAX_PARAMETERS = 3
DEGREES = (1, 2)
MAX_ENTRIES = 1200  # rows x columns of the linear system over QQ(k): each solve a fraction of a second
_FLIPPED = {">=": "<=", ">": "<", "<=": ">=", "<": ">", "==": "=="}

_cache: dict[tuple, list[Node]] = {}


def integral_atoms(theorem: Theorem, ode: ODE) -> list[Node]:
    """Atoms from the parametric first integrals of the ODE that hold at its start, or [] (a
    field over QQ, a field that is not polynomial, too many variables or parameters).
    Deterministic; cached per input."""
    key = (ode.key, theorem.assumptions.key)
    if key not in _cache:
        if len(_cache) > 256:
            _cache.clear()
        try:
            _cache[key] = _atoms(theorem, ode)
        except Exception:  # noqa: BLE001 - a proposer must never stop a proof
            _cache[key] = []
    return _cache[key]


def _atoms(theorem: Theorem, ode: ODE) -> list[Node]:
    table = SympyTable()
    xs = [table.symbol(v) for v in ode.variables]
    field = [sympy.expand(to_sympy(f, table)) for _, f in ode.eqs]
    params = sorted(set().union(*(f.free_symbols for f in field)) - set(xs), key=str)
    if (not params or len(params) > MAX_PARAMETERS or len(xs) > MAX_VARS
            or not all(f.is_polynomial(*xs, *params) for f in field)):
        return []
    start = _fixed(theorem, ode, table)
    premises = [a for a in conjuncts(theorem.assumptions)
                if a.op == "cmp" and a.payload in _FLIPPED and a.args[0].sort.is_numeric]
    atoms: list[Node] = []
    for J in first_integrals(field, xs, params):
        at_start = sympy.expand(J.subs(start))
        if not at_start.free_symbols & set(xs):
            atoms.append(cmp("==", from_sympy(J, table), from_sympy(at_start, table)))
            continue
        for premise in premises:
            atom = _from_premise(J, at_start, premise, start, xs, table)
            if atom is not None:
                atoms.append(atom)
    return atoms


def first_integrals(field: list[sympy.Expr], xs: list[sympy.Symbol],
                    params: list[sympy.Symbol]) -> list[sympy.Expr]:
    """A basis (over QQ(params)) of the non-constant first integrals of degree <= max(DEGREES),
    each a polynomial in xs and params with no content in params, checked J' = 0 exactly."""
    K = sympy.QQ.frac_field(*params)
    found: dict[str, sympy.Expr] = {}
    for d in DEGREES:
        monomials = [e for e in itertools.product(range(d + 1), repeat=len(xs)) if 0 < sum(e) <= d]
        images = [sympy.Poly(_lie(_monomial(xs, e), field, xs), *xs) for e in monomials]
        rows = sorted({e for im in images for e in im.as_dict()})
        if not rows or len(rows) * len(monomials) > MAX_ENTRIES:
            continue
        M = DomainMatrix([[K.convert(im.as_dict().get(e, 0)) for im in images] for e in rows],
                         (len(rows), len(monomials)), K)
        kernel = M.nullspace().to_Matrix()
        for i in range(kernel.shape[0]):
            J = sympy.together(sum(kernel[i, j] * _monomial(xs, e) for j, e in enumerate(monomials)))
            J = _primitive(sympy.numer(J), xs)
            if J is not None and sympy.expand(_lie(J, field, xs)) == 0:
                found.setdefault(str(J), J)
    return list(found.values())


def _monomial(xs, e) -> sympy.Expr:
    return sympy.Mul(*(x**k for x, k in zip(xs, e)))


def _lie(p: sympy.Expr, field: list[sympy.Expr], xs: list[sympy.Symbol]) -> sympy.Expr:
    return sum(sympy.diff(p, x) * f for x, f in zip(xs, field))


def _primitive(J: sympy.Expr, xs: list[sympy.Symbol]) -> sympy.Expr | None:
    """J over ZZ[params] without its content in the parameters (4*k^6*J0 is J0), leading
    coefficient positive; None for a constant."""
    poly = sympy.Poly(sympy.expand(J), *xs)
    if poly.is_ground:
        return None
    content = sympy.gcd_list([sympy.factor(c) for c in poly.coeffs()])
    J = sympy.expand(sympy.cancel(poly.as_expr() / content))
    lead = sympy.Poly(J, *xs).LC()
    return -J if lead.as_coeff_Mul()[0] < 0 else J


def _fixed(theorem: Theorem, ode: ODE, table: SympyTable) -> dict[sympy.Symbol, sympy.Expr]:
    """The ODE's variables an assumption fixes to a number or a term of symbols the ODE does
    not move (`x1 = 0`, `cos = 1`, `v = w1`)."""
    moving = {v.payload for v in ode.variables}
    out: dict[sympy.Symbol, sympy.Expr] = {}
    for atom in conjuncts(theorem.assumptions):
        if atom.op != "cmp" or atom.payload != "==" or not atom.args[0].sort.is_numeric:
            continue
        for var, value in (atom.args, atom.args[::-1]):
            if var.op == "var" and var.payload in moving and not _mentions(value, moving):
                out.setdefault(table.symbol(var), to_sympy(value, table))
    return out


def _mentions(n: Node, names: set[str]) -> bool:
    return (n.op == "var" and n.payload in names) or any(_mentions(a, names) for a in n.args)


def _from_premise(J, at_start, premise: Node, start, xs, table: SympyTable) -> Node | None:
    """`J op c` when the premise `a op b` is, at the start, (J - c)/lam op 0 for a rational
    lam > 0 (lam < 0 flips op); None otherwise."""
    try:
        E = sympy.expand(to_sympy(premise.args[0] - premise.args[1], table).subs(start))
    except TypeError:
        return None
    if not E.free_symbols & set(xs):
        return None
    E_poly, J_poly = sympy.Poly(E, *xs), sympy.Poly(at_start, *xs)
    monomial = next((m for m in E_poly.monoms() if any(m)), None)
    if monomial is None or J_poly.coeff_monomial(monomial) == 0:
        return None
    lam = sympy.cancel(J_poly.coeff_monomial(monomial) / E_poly.coeff_monomial(monomial))
    if not lam.is_Rational or lam == 0:
        return None
    c = sympy.expand(at_start - lam * E)
    if c.free_symbols & set(xs):
        return None
    op = premise.payload if lam > 0 else _FLIPPED[premise.payload]
    return cmp(op, from_sympy(J, table), from_sympy(c, table))
