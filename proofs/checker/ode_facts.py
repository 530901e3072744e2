"""The checker's own ODE facts: Lie derivatives, differential-invariant premises, a recorded
solution checked by differentiation, and "the domain holds along the solution".

Terms go to sympy and back through a table of symbols; every result is a model term over the
program names of the ODE's variables. A division reaches here only where a leaf of its own
shows the denominator nonzero (a well-defined leaf, or a premise's `d != 0`).
"""

from __future__ import annotations

from fractions import Fraction

import sympy

from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import (
    TRUE,
    And,
    ForAll,
    Implies,
    Node,
    Not,
    Or,
    Real,
    add,
    cmp,
    const,
    free_vars,
    mul,
    substitute,
    term,
)
from certiloop.proofs.checker.defined import denominators, divides, modal


class NotCheckable(Exception):
    """A rule or shape the checker does not cover yet: exit 1, never an acceptance."""


class Table:
    """Atomic subterms (symbols) <-> sympy symbols, numbered in order of first use."""

    def __init__(self) -> None:
        self.by_key: dict[tuple, sympy.Symbol] = {}
        self.back: dict[sympy.Symbol, Node] = {}

    def symbol(self, atom: Node) -> sympy.Symbol:
        s = self.by_key.get(atom.key)
        if s is None:
            text = "".join(c if c.isalnum() else "_" for c in str(atom))[:24]
            s = self.by_key[atom.key] = sympy.Symbol(f"a{len(self.by_key)}_{text}", real=True)
            self.back[s] = atom
        return s


def to_sympy(n: Node, table: Table) -> sympy.Expr:
    if n.op == "const":
        return sympy.Rational(n.payload.numerator, n.payload.denominator)
    if n.op in ("var", "select", "store"):
        return table.symbol(n)  # an array read is a symbol (lie_derivative checks that it is constant)
    if n.op in ("+", "*"):
        return (sympy.Add if n.op == "+" else sympy.Mul)(*(to_sympy(a, table) for a in n.args))
    if n.op == "neg":
        return -to_sympy(n.args[0], table)
    if n.op == "/":
        return to_sympy(n.args[0], table) / to_sympy(n.args[1], table)
    if n.op == "^":
        return to_sympy(n.args[0], table) ** n.payload
    raise NotCheckable(f"the term `{n}` ({n.op}) in an ODE rule")


def from_sympy(e: sympy.Expr, table: Table) -> Node:
    if e.is_Rational:
        return const(Fraction(int(e.p), int(e.q)))
    if e.is_Symbol:
        return table.back[e]
    if e.is_Add:
        return add(*(from_sympy(a, table) for a in e.args))
    if e.is_Mul:
        num, den = sympy.fraction(e)
        if den != 1:
            return from_sympy(num, table) / from_sympy(den, table)
        return mul(*(from_sympy(a, table) for a in e.args))
    if e.is_Pow and e.exp.is_Integer:
        power = term(from_sympy(e.base, table)) ** abs(int(e.exp))
        return power if int(e.exp) >= 0 else const(1) / power
    raise NotCheckable(f"the sympy expression {e} as a model term")


def lie_derivative(f: Node, ode: ODE) -> Node:
    """d/dt f along the ODE: sum of df/dx * x' (symbols without an equation are constant)."""
    table = Table()
    e = to_sympy(f, table)
    moving = {v.payload for v, rhs in ode.eqs if not (rhs.op == "const" and rhs.payload == 0)}
    if any(atom.op != "var" and set(free_vars(atom)) & moving for atom in table.back.values()):
        raise NotCheckable(f"the derivative of `{f}`, which reads an array at an index the flow moves")
    total = sympy.Integer(0)
    for v, rhs in ode.eqs:  # the symbol of v before those of its right-hand side, as sympy orders by name
        total += sympy.diff(e, table.symbol(v)) * to_sympy(rhs, table)
    return from_sympy(sympy.simplify(sympy.expand(total)), table)


def atom_polynomial(atom: Node) -> tuple[Node, str]:
    """(p, op) with the comparison equivalent to `p op 0`, op one of >=, >, ==, !=."""
    if atom.op != "cmp":
        raise NotCheckable(f"the differential invariant `{atom}` (not a comparison)")
    a, b = atom.args
    if atom.payload in ("<=", "<"):
        return b - a, {"<=": ">=", "<": ">"}[atom.payload]
    return a - b, atom.payload


def premise(atom: Node, ode: ODE, method: str, cofactor: Node | None) -> Node | None:
    """What the rule must show inside the domain for the atom to stay true along the flow
    (None: nothing, a Darboux identity checked here). A guard C in `C -> atom` must not
    mention the flow's variables (it is then constant along it)."""
    if atom.op == "implies":
        guard, core = atom.args
        if set(free_vars(guard)) & {v.payload for v in ode.variables} or modal(guard):
            raise NotCheckable(f"the guarded invariant `{atom}` whose guard changes along the flow")
        inner = premise(core, ode, method, cofactor)
        return None if inner is None else Implies(guard, inner)
    p, op = atom_polynomial(atom)
    dp = lie_derivative(p, ode)
    weak = ">=" if op in (">=", ">") else "=="
    if method == "dI":  # p' >= 0 keeps p >= 0 and p > 0; p' = 0 keeps p = 0 and p != 0
        return cmp(weak, dp, 0)
    if method == "dbx" and cofactor is not None and divides(cofactor):
        # g = n/d is continuous where d != 0, and p' - g p = N/D is >= 0 (= 0) where D != 0 and
        # N D >= 0 (= 0): then p' = g p (>=) keeps the sign of p as for a polynomial g
        table = Table()
        g = sympy.cancel(sympy.together(to_sympy(cofactor, table)))
        rest = sympy.cancel(sympy.together(to_sympy(dp, table) - g * to_sympy(p, table)))
        (num, den), g_den = sympy.fraction(rest), sympy.fraction(g)[1]
        parts = [] if g_den.is_number else [cmp("!=", from_sympy(g_den, table), 0)]
        if num != 0:
            parts += [] if den.is_number else [cmp("!=", from_sympy(den, table), 0)]
            parts.append(cmp(weak, from_sympy(sympy.expand(num * den), table), 0))
        return And(*parts)
    if method == "dbx" and cofactor is not None and cofactor.sort.is_numeric:
        table = Table()  # p' - g p >= 0 (= 0): the sign of p never changes (Darboux)
        rest = sympy.expand(to_sympy(dp, table) - to_sympy(cofactor, table) * to_sympy(p, table))
        return None if sympy.cancel(rest) == 0 else cmp(weak, from_sympy(rest, table), 0)
    if method == "barrier" and op in (">", ">="):  # where p = 0, p increases (p' > 0)
        return Implies(cmp("==", p, 0), cmp(">", dp, 0))
    if method == "progress" and op == ">=" and not divides(p) and not any(divides(f) for _, f in ode.eqs):
        # leaving p >= 0 needs a last zero: a rest point (f = 0: a polynomial field stays there),
        # or p' > 0, or p' = 0 with p'' > 0, each making p > 0 just after it
        rest = And(*(cmp("==", f, 0) for _, f in ode.eqs))
        ddp = lie_derivative(dp, ode)
        return Implies(cmp("==", p, 0), Or(rest, cmp(">", dp, 0), And(cmp("==", dp, 0), cmp(">", ddp, 0))))
    if method == "nonzero" and not divides(p):  # p never 0 in the domain: p keeps its initial sign
        return cmp("!=", p, 0)
    raise NotCheckable(f"rule {method} for `{atom}` not checkable yet")


def check_solution(ode: ODE, solution: dict[str, Node], s: Node) -> str | None:
    """Why `solution` is not the ODE's solution through its start (None: it is): for each
    variable x_i(0) = x_i and d/ds x_i(s) = f_i(x(s)), by exact polynomial arithmetic."""
    if set(solution) != {v.payload for v in ode.variables}:
        return "the solution does not give exactly the ODE's variables"
    table = Table()
    ssym = table.symbol(s)
    if any(s.payload in free_vars(f) for _, f in ode.eqs):
        return f"the ODE mentions the solution's time {s.payload}"
    along = {table.symbol(v): to_sympy(solution[v.payload], table) for v in ode.variables}
    for v, rhs in ode.eqs:
        x = along[table.symbol(v)]
        if sympy.cancel(x.xreplace({ssym: 0}) - table.symbol(v)) != 0:
            return f"{v.payload}(0) is not {v.payload}"
        if sympy.cancel(sympy.diff(x, ssym) - to_sympy(rhs, table).xreplace(along)) != 0:
            return f"d/ds {v.payload}(s) is not its right-hand side along the solution"
    return None


def runs_along(ode: ODE, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    """Following the solution for tau is a run: the domain holds all along, and each
    denominator of the right-hand side keeps its sign (> 0 or < 0) all along."""
    dividing = {d.key: d for _, f in ode.eqs for d in denominators(f)}
    return And(holds_along(ode.domain, solution, tau, s), *(_keeps_sign(d, solution, tau, s)
                                                            for d in dividing.values()))


def _keeps_sign(d: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    return Or(*(_along_or_quantified(cmp(op, d, 0), solution, tau, s) for op in (">", "<")))


def _along_or_quantified(atom: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    exact = _atom_along(atom, solution, tau, s)
    return exact if exact is not None else \
        ForAll(s, Implies(And(const(0) <= s, s <= tau), substitute(atom, solution)))


TAU = Real("tau@along")  # the duration while the formula is built (sympy orders terms by name)


def holds_along(domain: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    """For all s in [0, tau], domain(x(s)): an atom affine in s by its two ends, a quadratic
    one also by its vertex, anything else with the quantifier kept."""
    return substitute(_holds_along(domain, solution, TAU, s), {TAU.payload: tau})


def _holds_along(domain: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    parts = []
    for atom in domain.args if domain.op == "and" else (domain,):
        if atom.op == "cmp":  # a divided atom holds on a run only where its denominators stay nonzero
            parts += [_keeps_sign(d, solution, tau, s) for d in denominators(atom)]
        parts.append(_along_or_quantified(atom, solution, tau, s))
    return And(*parts)


def _atom_along(atom: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node | None:
    if atom.op == "true":
        return TRUE
    if atom.op != "cmp":
        return None
    op = atom.payload
    table = Table()
    ssym = table.symbol(s)
    a, b = (to_sympy(substitute(x, solution), table) for x in atom.args)
    g = sympy.expand(a - b)
    if not g.is_polynomial(ssym):
        return None
    poly = sympy.Poly(g, ssym)
    at0, at_tau = from_sympy(g.subs(ssym, 0), table), from_sympy(g.subs(ssym, table.symbol(tau)), table)
    if poly.degree() <= 0:
        return cmp(op, at0, 0)
    if op in ("==", "!=") or poly.degree() > 2:
        return None
    ends = And(cmp(op, at0, 0), cmp(op, at_tau, 0))
    if poly.degree() == 1:
        return ends
    # c s^2 + b s + a0 (sign-adjusted to >=, >) keeps its sign on [0, tau] unless its vertex
    # lies inside with a negative (non-positive, for >) value there
    sign = 1 if op in (">=", ">") else -1
    c, bb, a0 = (from_sympy(sympy.sympify(sign * k), table) for k in poly.all_coeffs())
    disc_bad = (4 * c * a0 - bb * bb <= 0) if op in (">", "<") else (4 * c * a0 - bb * bb < 0)
    return And(ends, Not(And(c > 0, 0 < -bb, -bb < 2 * c * tau, disc_bad)))

