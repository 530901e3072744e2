"""ODE reasoning: polynomial solutions, Lie derivatives, and "the domain holds along the flow".

All results are model terms over the *program* names of the ODE's variables (their values
at the start of the flow) and a duration symbol; callers substitute the current state.
"""

from __future__ import annotations

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
    if inv.op != "cmp" or inv.payload == "!=":
        raise ModelError(
            f"differential invariant `{inv}` must be a conjunction of =, <=, <, >=, > comparisons"
        )
    a, b = inv.args
    da, db = lie_derivative(a, ode), lie_derivative(b, ode)
    op = {"<": "<=", ">": ">="}.get(inv.payload, inv.payload)
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

