"""ODE reasoning: polynomial solutions, Lie derivatives, and "the domain holds along the flow".

All results are model terms over the *program* names of the ODE's variables (their values
at the start of the flow) and a duration symbol; callers substitute the current state.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import (
    MODALITIES,
    TRUE,
    And,
    ForAll,
    Implies,
    ModelError,
    Node,
    Not,
    Or,
    Real,
    cmp,
    const,
    free_vars,
    substitute,
)
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy
from certiloop.proofs.core.wd import denominators, has_division

_SOLUTIONS: dict[tuple, dict[str, Node] | None] = {}


def polynomial_solution(ode: ODE, s: Node) -> dict[str, Node] | None:
    """x_i(s) for every ODE variable if the system's solution is polynomial in time, else None.

    Works for the triangular (nilpotent) systems the case studies use, e.g.
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
    if any(e.has(sympy.zoo, sympy.nan, sympy.oo) for e in rhs.values()):
        return None  # a division by 0 (1/(0*x)): no solution; the definedness check says why
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


# (term, ODE equations) -> derivative. A pure function; the ODE planner asks it again for
# the same atoms each round (IJRR17 Corollary 1.3: 1,106 calls of 40 ms, most repeats).
_DERIVATIVES: dict[tuple, Node] = {}
_MAX_DERIVATIVES = 20_000


def lie_derivative(f: Node, ode: ODE) -> Node:
    """The time derivative of the term f along the ODE (non-ODE symbols are constant). An
    array read whose index the flow moves (`a[x]` under x' = 1) has no derivative we know,
    so it is refused rather than read as a constant."""
    key = (f.key, tuple((v.key, rhs.key) for v, rhs in ode.eqs))
    got = _DERIVATIVES.get(key)
    if got is None:
        if len(_DERIVATIVES) >= _MAX_DERIVATIVES:
            _DERIVATIVES.clear()
        got = _DERIVATIVES[key] = _derivative(f, ode)
    return got


def _derivative(f: Node, ode: ODE) -> Node:
    table = SympyTable()
    e = to_sympy(f, table)
    moving = {v.payload for v, rhs in ode.eqs if not (rhs.op == "const" and rhs.payload == 0)}
    for atom in table.atoms():
        if atom.op != "var" and set(free_vars(atom)) & moving:
            raise ModelError(f"`{atom}` reads an array where the ODE moves its index: its derivative "
                             "along the flow is unknown")
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


# (domain, solution) -> holds_along at the duration _TAU: a pure function, asked again for each
# path through a program that reaches the ODE (a 6-mode hybrid automaton: 600 times per proof)
_ALONG: dict[tuple, Node] = {}
_MAX_ALONG = 5_000
_TAU = Real("tau@along")  # users cannot write '@'


def runs_along(ode: ODE, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    """Is following the solution for τ a run of the ODE: its domain holds all along, and its
    right-hand side as written is defined all along (x' = x/x has the solution x0 + s, but no
    run through x = 0, where x' is undefined)?"""
    dividing = {d.key: d for _, f in ode.eqs for d in denominators(f)}
    rates = [keeps_sign_along(d, solution, tau, s) for d in dividing.values()]
    return And(holds_along(ode.domain, solution, tau, s), *rates)


def holds_along(domain: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    """∀s∈[0,τ] domain(x(s)), as a quantifier-free formula when it can be done exactly.

    Atoms affine in s hold on [0,τ] iff they hold at both ends; quadratic atoms also need
    the vertex checked; anything else keeps the quantifier (exact, but harder for z3). An
    atom that divides also needs each denominator nonzero all along: sympy cancels x/x to 1
    before the degree is read, and the domain x/x >= 1 holds on no run through x = 0.
    """
    key = (domain.key, tuple(sorted((n, x.key) for n, x in solution.items())), s.key)
    got = _ALONG.get(key)
    if got is None:
        if len(_ALONG) >= _MAX_ALONG:
            _ALONG.clear()
        got = _ALONG[key] = _holds_along(domain, solution, _TAU, s)
    return substitute(got, {_TAU.payload: tau})


def _holds_along(domain: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    conj = domain.args if domain.op == "and" else (domain,)
    parts = []
    for atom in conj:
        # a run holds every conjunct at every point, so each is evaluated all along (the
        # left-to-right reading asks no less); an atom that is not a comparison keeps its
        # quantifier, and with it its divisions
        if atom.op == "cmp":
            parts += [keeps_sign_along(d, solution, tau, s) for d in denominators(atom)]
        exact = _atom_along(atom, solution, tau, s)
        if exact is None:
            body = Implies(And(const(0) <= s, s <= tau), substitute(atom, solution))
            parts.append(ForAll(s, body))
        else:
            parts.append(exact)
    return And(*parts)


def keeps_sign_along(d: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    """d(x(s)) != 0 for all s in [0,τ]: as d is continuous along the flow, d > 0 all along or
    d < 0 all along."""
    return Or(*(_along_atom_or_quantified(cmp(op, d, 0), solution, tau, s) for op in (">", "<")))


def _along_atom_or_quantified(atom: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    exact = _atom_along(atom, solution, tau, s)
    if exact is not None:
        return exact
    return ForAll(s, Implies(And(const(0) <= s, s <= tau), substitute(atom, solution)))


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
#   barrier  p = 0 -> p' > 0, for > and >= (p > 0 until a first zero, where p' <= 0; p >= 0
#            until a last time p = 0 before p < 0, where again p' <= 0. The weak premise
#            p = 0 -> p' >= 0 would be unsound for >=: -x^2 >= 0 under x' = 1)
#   progress p = 0 -> (f = 0 | p' > 0 | p' = 0 & p'' > 0), for >=, with p and the field f
#            polynomials (KeYmaera X's ODEinv reaches the same by higher Lie derivatives). A
#            flow leaving p >= 0 has a last time t* with p = 0, p < 0 just after. If f = 0
#            there, the state is an equilibrium and, f being polynomial (locally Lipschitz),
#            the flow stays at it (p = 0 after t*). Else p∘x is C^2 at t*, and p' > 0, or
#            p' = 0 with p'' > 0, makes p > 0 just after t*. Each contradicts leaving. The
#            weak p'' >= 0 would be unsound (-x^3 >= 0 under x' = 1 from 0), and so would any
#            component of f = 0 for the whole (-x^2 >= 0 under x' = 1, y' = 0)
#   nonzero  p != 0, p a polynomial                                  inside the domain
#            (p is continuous along a flow that never leaves the region where p != 0, so by
#            the intermediate value theorem p keeps the sign it starts with; for = and !=
#            the atom holds trivially: no flow starts on p = 0, or p != 0 throughout)
# An atom may be guarded, `C -> a op b`, when C does not mention the ODE's variables: C is
# then constant along the flow, so the guarded atom is proved by proving `a op b` under C
# (premise `C -> premise`; where C is false the atom holds throughout). KeYmaera X's
# `v'=0 -> v=old(v)` annotations are of this kind once v' is read as its right-hand side.

METHODS = ("dI", "dbx", "barrier", "progress", "nonzero")


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
    for atom in annotated_atoms(ode):
        exact, _ = cofactors(atom, ode)
        steps.append(OdeStep(atom, "dbx", exact) if exact is not None else OdeStep(atom))
    return tuple(steps)


def annotated_atoms(ode: ODE) -> list[Node]:
    """The author's invariants atom by atom. KeYmaera X selects an invariant for one of the
    flows a program reaches by a guard on its differential symbols, `(v'=-g+a*v^2 -> J)`,
    which reads `-g+r*v^2 = -g+a*v^2 -> J` along the flow. Such a guard mentions the flow's
    variables, so it is replaced by the condition that it holds identically along the flow:
    every coefficient of the difference, as a polynomial in the flow's variables, is 0
    (`r = a`). That condition is constant along the flow and implies the original one, so the
    atom is weaker than the author's; it is a hint all the same, proved like any other."""
    return [_selected(a, ode) for inv in ode.invariants for a in conjuncts(inv)]


def _selected(atom: Node, ode: ODE) -> Node:
    guard, core = guarded(atom)
    names = {v.payload for v in ode.variables}
    if guard is None or not set(free_vars(guard)) & names:
        return atom
    equations = conjuncts(guard)
    if not all(c.op == "cmp" and c.payload == "==" and c.args[0].sort.is_numeric for c in equations):
        return atom  # the core refuses it, naming the guard
    table = SympyTable()
    moving = [table.symbol(v) for v in ode.variables]
    conditions: list[Node] = []
    for c in equations:
        numerator, _ = sympy.fraction(sympy.together(to_sympy(c.args[0] - c.args[1], table)))
        numerator = sympy.expand(numerator)
        if numerator == 0:
            continue
        try:
            coefficients = sympy.Poly(numerator, *moving).coeffs()
        except sympy.polys.polyerrors.PolynomialError:
            return atom
        conditions += [cmp("==", from_sympy(k, table), 0) for k in coefficients]
    if any(k.args[0].op == "const" for k in conditions):
        # never identically (`x = 0 -> v = 0`): a guard on the state, not a choice of flow,
        # which the core refuses, naming it
        return atom
    return Implies(And(*conditions), core)


def _modal(f: Node) -> bool:
    return f.op in MODALITIES or any(_modal(a) for a in f.args)


def guarded(atom: Node) -> tuple[Node | None, Node]:
    """(C, a) for a guarded atom `C -> a`, else (None, atom)."""
    if atom.op == "implies":
        return atom.args[0], atom.args[1]
    return None, atom


def atom_polynomial(atom: Node) -> tuple[Node, str]:
    """(p, op) with the (guarded) atom's comparison equivalent to `p op 0`, op in >=, >, ==, !=."""
    atom = guarded(atom)[1]
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
    if f.op == "implies" and f.args[1].op == "and":  # C -> a & b: a guarded atom each
        return tuple(Implies(f.args[0], x) for x in conjuncts(f.args[1]))
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


# (atom, ODE equations, method, cofactor) -> premise: a pure function, asked again for every
# path through the program that reaches the ODE, each planning round
_PREMISES: dict[tuple, Node | None] = {}
_MAX_PREMISES = 20_000


def atom_premise(atom: Node, ode: ODE, method: str, cofactor: Node | None = None) -> Node | None:
    """What `method` must show inside the domain (and after the earlier atoms) for the atom
    to be invariant; None when nothing is left to show (a Darboux identity, checked here)."""
    key = (atom.key, tuple((v.key, rhs.key) for v, rhs in ode.eqs), method,
           None if cofactor is None else cofactor.key)
    if key in _PREMISES:
        return _PREMISES[key]
    got = _atom_premise(atom, ode, method, cofactor)  # a refusal raises, and is not kept
    if len(_PREMISES) >= _MAX_PREMISES:
        _PREMISES.clear()
    _PREMISES[key] = got
    return got


def _atom_premise(atom: Node, ode: ODE, method: str, cofactor: Node | None = None) -> Node | None:
    guard, core = guarded(atom)
    if guard is not None:
        moving = set(free_vars(guard)) & {v.payload for v in ode.variables}
        if moving or _modal(guard):
            raise ModelError(f"differential invariant `{atom}`: its condition must stay constant along "
                             f"the flow (it mentions {', '.join(sorted(moving)) or 'a modality'})")
        inner = _atom_premise(core, ode, method, cofactor)
        return None if inner is None else Implies(guard, inner)
    p, op = atom_polynomial(atom)
    dp = lie_derivative(p, ode)
    if method == "dI":
        return cmp(">=" if op in (">=", ">") else "==", dp, 0)
    if method == "dbx":
        if cofactor is None or not cofactor.sort.is_numeric:
            raise ValueError(f"dbx for `{atom}` needs a cofactor term, got {cofactor}")
        if has_division(cofactor):
            return _rational_darboux_premise(p, dp, op, cofactor)
        if darboux_identity(p, cofactor, ode):
            return None
        table = SympyTable()
        rest = sympy.expand(to_sympy(dp, table) - to_sympy(cofactor, table) * to_sympy(p, table))
        return cmp(">=" if op in (">=", ">") else "==", from_sympy(rest, table), 0)
    if method == "barrier":
        if op not in (">", ">="):
            raise ValueError(f"the barrier rule proves inequalities only, not `{atom}`")
        return Implies(cmp("==", p, 0), cmp(">", dp, 0))
    if method == "progress":
        if op != ">=":
            raise ValueError(f"the progress rule proves closed inequalities only, not `{atom}`")
        if has_division(p) or any(has_division(rhs) for _, rhs in ode.eqs):
            raise ValueError(f"the progress rule needs a polynomial and a polynomial field, not `{atom}`")
        ddp = lie_derivative(dp, ode)
        at_rest = And(*(cmp("==", rhs, 0) for _, rhs in ode.eqs))
        return Implies(cmp("==", p, 0), Or(at_rest, cmp(">", dp, 0), And(cmp("==", dp, 0), cmp(">", ddp, 0))))
    if method == "nonzero":
        if has_division(p):  # a quotient need not be continuous: its denominator may vanish
            raise ValueError(f"the nonzero rule needs a polynomial, not `{atom}`")
        return cmp("!=", p, 0)
    raise ValueError(f"unknown ODE rule {method!r}")


def _rational_darboux_premise(p: Node, dp: Node, op: str, cofactor: Node) -> Node:
    """dbx with a rational cofactor g = n/d: along a flow inside the region where d != 0, g is
    continuous, so p' = g p (p' >= g p) still keeps p = 0 (the sign of p), as for a polynomial
    g. The premise, free of division: d != 0, and p' - g p = N/D with D != 0 and N D = 0
    (N D >= 0)."""
    table = SympyTable()
    g = sympy.cancel(sympy.together(to_sympy(cofactor, table)))
    _, g_den = sympy.fraction(g)
    rest = sympy.cancel(sympy.together(to_sympy(dp, table) - g * to_sympy(p, table)))
    num, den = sympy.fraction(rest)
    parts = [] if g_den.is_number else [cmp("!=", from_sympy(g_den, table), 0)]
    if num != 0:
        if not den.is_number:
            parts.append(cmp("!=", from_sympy(den, table), 0))
        parts.append(cmp(">=" if op in (">=", ">") else "==", from_sympy(sympy.expand(num * den), table), 0))
    return And(*parts)


def rational_cofactor(atom: Node, ode: ODE) -> Node | None:
    """A guess n/d for dbx when p' is a rational function N/d: n is the quotient of N by p
    modulo the domain's polynomial equalities (`y = x^2`), so p' = (n/d) p wherever the
    domain holds. None when p' is a polynomial or there is no such quotient."""
    p, _ = atom_polynomial(atom)
    table = SympyTable()
    ps = sympy.expand(to_sympy(p, table))
    dp = sympy.cancel(sympy.together(to_sympy(lie_derivative(p, ode), table)))
    num, den = sympy.fraction(dp)
    if den.is_number or ps.is_number or not _polynomial_in(ps) or not _polynomial_in(num):
        return None
    num = sympy.expand(num)
    for a in conjuncts(ode.domain):  # an equality `v = q` with v of degree 1: substitute q for v
        if a.op != "cmp" or a.payload != "==" or not a.args[0].sort.is_numeric:
            continue
        e = sympy.expand(to_sympy(a.args[0] - a.args[1], table))
        for v in sorted(e.free_symbols, key=str):
            c = e.coeff(v, 1)
            if c.is_number and c != 0 and sympy.degree(e, v) == 1:
                num = sympy.expand(num.subs(v, -(e - c * v) / c))
                break
    gens = sorted(num.free_symbols | ps.free_symbols, key=str)
    try:
        quotient, remainder = sympy.div(num, ps, *gens, domain=sympy.QQ)
    except sympy.polys.polyerrors.PolynomialError:
        return None
    if remainder != 0 or quotient == 0:
        return None
    return from_sympy(quotient / den, table)
