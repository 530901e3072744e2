"""ODE reasoning: polynomial solutions, Lie derivatives, and "the domain holds along the flow".

All results are model terms over the *program* names of the ODE's variables (their values
at the start of the flow) and a duration symbol; callers substitute the current state.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import (
    TRUE,
    And,
    ForAll,
    Implies,
    ModelError,
    Node,
    Not,
    Real,
    cmp,
    const,
    substitute,
)
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy
from certiloop.proofs.core.wd import has_division

_SOLUTIONS: dict[tuple, dict[str, Node] | None] = {}


def polynomial_solution(ode: ODE, s: Node) -> dict[str, Node] | None:
    """x_i(s) for every ODE variable if the system's solution is polynomial in time, else None.

    Works for the triangular (nilpotent) systems the seeds use, e.g.
    p' = G*f*k, f' = fp, t' = 1: repeatedly integrate an equation whose right-hand side
    only mentions already-solved variables (substituted all at once, never one after the
    other). The result is used only after `check_solution` has differentiated it back: its
    derivative must equal the right-hand side along it, and at s = 0 it must be the start.
    Returns None for systems of another shape (x' = y, y' = -x; p' = G*p/D*f).
    """
    key = (ode.key, s.key)
    if key not in _SOLUTIONS:
        _SOLUTIONS[key] = _solve(ode, s)
    return _SOLUTIONS[key]


def _solve(ode: ODE, s: Node) -> dict[str, Node] | None:
    table = SympyTable()
    ssym = table.symbol(s)
    start = {v.name: table.symbol(v) for v in ode.variables}  # a variable's value at s = 0
    rhs = {v.name: to_sympy(f, table) for v, f in ode.eqs}
    if ssym in set().union(*(e.free_symbols for e in rhs.values())):
        return None  # the flow's own clock symbol cannot appear in the model
    solved: dict[str, sympy.Expr] = {}
    pending = [v.name for v in ode.variables]  # the model's order: deterministic
    while pending:
        ready = [n for n in pending
                 if not (rhs[n].free_symbols & {start[m] for m in pending})]
        if not ready:
            return None  # a cycle (x' = y, y' = x) or self-dependence (x' = x)
        for name in ready:
            along = rhs[name].xreplace({start[m]: solved[m] for m in solved})  # simultaneous
            if not along.is_polynomial(ssym):
                return None
            solved[name] = sympy.expand(start[name] + sympy.integrate(along, (ssym, 0, ssym)))
            pending.remove(name)
    if not check_solution(rhs, start, solved, ssym):
        raise AssertionError(f"certiloop bug: the solution of {ode} does not differentiate back")
    return {name: from_sympy(expr, table) for name, expr in solved.items()}


def check_solution(rhs: dict, start: dict, solution: dict, s) -> bool:
    """The independent check of a closed form: d/ds x_i(s) = f_i(x(s)) identically, and
    x_i(0) = x_i, for every variable, decided by exact rational-function arithmetic."""
    at_solution = {start[n]: solution[n] for n in solution}
    for name, x in solution.items():
        if sympy.cancel(sympy.diff(x, s) - rhs[name].xreplace(at_solution)) != 0:
            return False
        if sympy.cancel(x.xreplace({s: 0}) - start[name]) != 0:
            return False
    return set(solution) == set(rhs)


def lie_derivative(f: Node, ode: ODE) -> Node:
    """The time derivative of the term f along the ODE (non-ODE symbols are constant)."""
    table = SympyTable()
    e = to_sympy(f, table)
    total = sympy.Integer(0)
    for v, rhs in ode.eqs:
        total += sympy.diff(e, table.symbol(v)) * to_sympy(rhs, table)
    return from_sympy(sympy.simplify(sympy.expand(total)), table)


def dI_condition(inv: Node, ode: ODE) -> Node:
    """What the differential-invariant rule must show inside the domain for `inv`."""
    if inv.op == "and":
        return And(*(dI_condition(a, ode) for a in inv.args))
    if inv.op == "true":
        return TRUE
    if inv.op != "cmp":
        raise ModelError(
            f"differential invariant `{inv}` must be a conjunction of =, !=, <=, <, >=, > comparisons"
        )
    a, b = inv.args
    da, db = lie_derivative(a, ode), lie_derivative(b, ode)
    # a != b: a - b is constant along the flow when (a - b)' = 0
    op = {"<": "<=", ">": ">=", "!=": "=="}.get(inv.payload, inv.payload)
    return cmp(op, da, db)


# --------------------------------------------------------------------------- domain along flow


def holds_along(domain: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    """∀s∈[0,τ] domain(x(s)), as a quantifier-free formula when it can be done exactly.

    Atoms affine in s hold on [0,τ] iff they hold at both ends; quadratic atoms also need
    the vertex checked; anything else keeps the quantifier (exact, but harder for z3).
    """
    conj = domain.args if domain.op == "and" else (domain,)
    parts = []
    for atom in conj:
        exact = _atom_along(atom, solution, tau, s)
        if exact is None:
            body = Implies(And(const(0) <= s, s <= tau), substitute(atom, solution))
            parts.append(ForAll(s, body))
        else:
            parts.append(exact)
    return And(*parts)


def _atom_along(atom: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node | None:
    if atom.op == "true":
        return TRUE
    if atom.op != "cmp":
        return None
    op = atom.payload
    a, b = (substitute(x, solution) for x in atom.args)
    table = SympyTable()
    ssym = table.symbol(s)
    g = sympy.expand(to_sympy(a, table) - to_sympy(b, table))
    if not g.is_polynomial(ssym):
        return None
    poly = sympy.Poly(g, ssym)
    deg = poly.degree()
    at0 = from_sympy(g.subs(ssym, 0), table)
    atT = from_sympy(g.subs(ssym, table.symbol(tau)), table)
    if deg <= 0:
        return cmp(op, at0, 0)
    if op in ("==", "!="):
        return None
    ends = And(cmp(op, at0, 0), cmp(op, atT, 0))
    if deg == 1:
        return ends
    if deg > 2:
        return None
    # g = c s^2 + b s + a0 >= 0 (or > 0) on [0, τ]: also rule out an interior minimum below 0.
    sign = 1 if op in (">=", ">") else -1
    c2, c1, c0 = (sign * coeff for coeff in poly.all_coeffs())
    c, bb, a0 = (from_sympy(sympy.sympify(x), table) for x in (c2, c1, c0))
    strict = op in (">", "<")
    disc_bad = (4 * c * a0 - bb * bb <= 0) if strict else (4 * c * a0 - bb * bb < 0)
    interior_min_bad = And(c > 0, 0 < -bb, -bb < 2 * c * tau, disc_bad)
    return And(ends, Not(interior_min_bad))


def solvable(ode: ODE) -> bool:
    return polynomial_solution(ode, Real("s@probe")) is not None



# --------------------------------------------------------------------------- invariant atoms
#
# A differential invariant is proved atom by atom, as a differential-cut chain: each atom's
# premise may assume the domain and the atoms before it, never itself or a later one. An atom
# `a op b` is read as `p op' 0` with p a polynomial (rational) term:
#   a >= b, a > b : p = a - b          a <= b, a < b : p = b - a          a = b, a != b : p = a - b
# and proved by one of these rules (the rule and any cofactor come from outside the core, as a
# plan; each is sound for every choice, so a bad plan can only fail to prove):
#   dI       p' >= 0 (>=, >), p' = 0 (=, !=)                           inside the domain
#   dbx g    p' >= g*p (>=, >), p' = g*p (=, !=), g a polynomial      inside the domain
#            (Darboux: (p*exp(-∫g))' = (p' - g*p)*exp(-∫g), so the sign of p never changes;
#            when p' - g*p is identically 0 the premise is decided here, exactly, by sympy)
#   barrier  p = 0 -> p' > 0, for > only (p > 0 until a first zero, where p' <= 0)

METHODS = ("dI", "dbx", "barrier")


@dataclass(frozen=True)
class OdeStep:
    """One link of a differential-cut chain: an atom and the rule that proves it."""

    atom: Node
    method: str = "dI"
    cofactor: Node | None = None


def default_chain(ode: ODE) -> tuple[OdeStep, ...]:
    """The annotated invariants atom by atom, in the author's order: a Darboux identity
    where one exists (complete for that atom), else dI."""
    steps = []
    for atom in (a for inv in ode.invariants for a in conjuncts(inv)):
        exact, _ = cofactors(atom, ode)
        steps.append(OdeStep(atom, "dbx", exact) if exact is not None else OdeStep(atom))
    return tuple(steps)


def atom_polynomial(atom: Node) -> tuple[Node, str]:
    """(p, op) with the atom equivalent to `p op 0`, op in >=, >, ==, !=."""
    if atom.op != "cmp":
        raise ModelError(f"differential invariant `{atom}` must be a conjunction of comparisons")
    a, b = atom.args
    op = atom.payload
    if op in ("<=", "<"):
        return b - a, {"<=": ">=", "<": ">"}[op]
    return a - b, op


def conjuncts(f: Node) -> tuple[Node, ...]:
    """The atoms of a conjunction, in order (`true` has none)."""
    if f.op == "and":
        return tuple(x for a in f.args for x in conjuncts(a))
    if f.op == "true":
        return ()
    return (f,)


def _polynomial_in(e: sympy.Expr) -> bool:
    """A polynomial over QQ in all its symbols (no division by anything but a number)."""
    _, den = sympy.fraction(sympy.cancel(e))
    return den.is_number and den != 0


def cofactors(atom: Node, ode: ODE) -> tuple[Node | None, Node | None]:
    """(exact, quotient): a polynomial g with p' = g*p identically, if one exists, and the
    quotient of p' by p in QQ[all symbols] (a guess for dbx g). Either may be None."""
    p, _ = atom_polynomial(atom)
    table = SympyTable()
    ps = sympy.expand(to_sympy(p, table))
    dp = sympy.expand(to_sympy(lie_derivative(p, ode), table))
    if ps == 0 or not _polynomial_in(ps) or not _polynomial_in(dp):
        return None, None
    ratio = sympy.cancel(dp / ps)
    exact = from_sympy(sympy.expand(ratio), table) if _polynomial_in(ratio) else None
    gens = sorted(ps.free_symbols | dp.free_symbols, key=str)
    if not gens:
        return exact, None
    if ps.is_number or dp == 0:
        return exact, None
    try:
        quotients, _ = sympy.reduced(dp, [ps], *gens, domain=sympy.QQ)
    except sympy.polys.polyerrors.PolynomialError:  # not a polynomial over QQ after all: no guess
        return exact, None
    q = quotients[0] if quotients else sympy.Integer(0)
    quotient = from_sympy(sympy.expand(q), table) if q != 0 else None
    return exact, quotient


def darboux_identity(p: Node, g: Node, ode: ODE) -> bool:
    """p' - g*p == 0 identically, decided by exact rational-function arithmetic."""
    table = SympyTable()
    diff = to_sympy(lie_derivative(p, ode), table) - to_sympy(g, table) * to_sympy(p, table)
    return sympy.cancel(sympy.expand(diff)) == 0


def atom_premise(atom: Node, ode: ODE, method: str, cofactor: Node | None = None) -> Node | None:
    """What `method` must show inside the domain (and after the earlier atoms) for the atom
    to be invariant; None when nothing is left to show (a Darboux identity, checked here)."""
    p, op = atom_polynomial(atom)
    dp = lie_derivative(p, ode)
    if method == "dI":
        return cmp(">=" if op in (">=", ">") else "==", dp, 0)
    if method == "dbx":
        if cofactor is None or has_division(cofactor) or not cofactor.sort.is_numeric:
            raise ValueError(f"dbx for `{atom}` needs a polynomial cofactor, got {cofactor}")
        if darboux_identity(p, cofactor, ode):
            return None
        table = SympyTable()
        rest = sympy.expand(to_sympy(dp, table) - to_sympy(cofactor, table) * to_sympy(p, table))
        return cmp(">=" if op in (">=", ">") else "==", from_sympy(rest, table), 0)
    if method == "barrier":
        if op != ">":
            raise ValueError(f"the barrier rule proves strict inequalities only, not `{atom}`")
        return Implies(cmp("==", p, 0), cmp(">", dp, 0))
    raise ValueError(f"unknown ODE rule {method!r}")
