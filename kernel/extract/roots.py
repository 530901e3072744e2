"""Solving a test for the value it pins down: `x := *; ?a*x + b = 0` becomes x = -b/a guarded
by a != 0 (`solve`, for the vectorised code), and for the scalar code `solutions` also solves
quadratics, giving each root (+sqrt first, then -sqrt, then the linear case where a symbolic
leading coefficient vanishes) with its guards, in the order the generated code tries them.
sympy and the core's symbolic bridge are imported only when an equation is solved."""

from __future__ import annotations

from dataclasses import dataclass

from certiloop.kernel.extract.errors import ExtractError, brief
from certiloop.models.lang.terms import Node


def solve(atom: Node, name: str) -> tuple[Node, Node]:
    """(x, a) with atom ⟺ x = value when a ≠ 0, for a linear equation a·x + b = 0."""
    import sympy

    from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy

    if atom.op != "cmp" or atom.payload != "==" or not atom.args[0].sort.is_numeric:
        raise ExtractError(f"`{name} := *` must be pinned by an equation, not by `{atom}`")
    table = SympyTable()
    try:
        g = sympy.expand(to_sympy(atom.args[0] - atom.args[1], table))
    except TypeError:
        raise ExtractError(f"cannot solve `{brief(atom)}` for `{name}`: not arithmetic") from None
    xs = [s for s in g.free_symbols if _is(table.atom(s), name)]
    if len(xs) != 1:
        raise ExtractError(f"cannot solve `{atom}` for `{name}`")
    x = xs[0]
    a, b = sympy.expand(sympy.diff(g, x)), sympy.expand(g.subs(x, 0))
    if x in a.free_symbols:
        raise ExtractError(f"`{atom}` is not linear in `{name}`")
    return from_sympy(-b / a if b != 0 else sympy.Integer(0), table), from_sympy(a, table)


def _is(atom: Node, name: str) -> bool:
    if atom.op == "var":
        return atom.payload == name
    return atom.op == "select" and atom.args[0].payload == name


@dataclass
class Root:
    """One solution of an equation for x: guards (formulas), then the value."""

    guards: list[Node]
    kind: str  # "value" | "sqrt+" | "sqrt-" | "quad+" | "quad-"
    parts: tuple[Node, ...]
    note: str = ""


def solutions(atom: Node, name: str) -> list[Root]:
    """The solutions of an equation that pins `name`, in the order they are tried: a
    linear a·x + b = 0 has one (guarded by a ≠ 0); a quadratic has two, the one with
    +sqrt first (guarded by a ≠ 0 and a non-negative discriminant), then the linear one
    where a symbolic leading coefficient vanishes. Anything else is refused."""
    import sympy

    from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy

    if atom.op != "cmp" or atom.payload != "==" or not atom.args[0].sort.is_numeric:
        raise ExtractError(f"`{name} := *` must be pinned by an equation before `{brief(atom)}` reads it")
    table = SympyTable()
    try:
        g = sympy.expand(to_sympy(atom.args[0] - atom.args[1], table))
    except TypeError:
        raise ExtractError(f"cannot solve `{brief(atom)}` for `{name}`: not arithmetic") from None
    xs = [s for s in g.free_symbols if _is(table.atom(s), name)]
    if len(xs) != 1:
        raise ExtractError(f"cannot solve `{brief(atom)}` for `{name}`")
    x = xs[0]
    try:
        poly = sympy.Poly(g, x)
    except sympy.PolynomialError:
        raise ExtractError(f"`{brief(atom)}` is not polynomial in `{name}`") from None
    if poly.degree() not in (1, 2):
        raise ExtractError(f"`{brief(atom)}` has degree {poly.degree()} in `{name}`: only linear and "
                           "quadratic equations are solved")
    a2, a1, a0 = (sympy.expand(poly.coeff_monomial(x**d)) for d in (2, 1, 0))
    back = lambda e: from_sympy(sympy.together(e), table)  # noqa: E731

    def nonzero(c) -> list[Node]:
        return [] if c.is_number else [back(c) != 0]

    try:
        return _roots(poly.degree(), a2, a1, a0, back, nonzero)
    except TypeError:  # from_sympy: a term the model language cannot write
        raise ExtractError(f"cannot solve `{brief(atom)}` for `{name}`") from None


def _roots(degree: int, a2, a1, a0, back, nonzero) -> list[Root]:
    if degree == 1:
        return [Root(nonzero(a1), "value", (back(-a0 / a1),))]
    import sympy

    roots: list[Root]
    if a1 == 0:
        radicand = sympy.together(-a0 / a2)
        roots = [Root([*nonzero(a2), back(radicand) >= 0], kind, (back(radicand),), note)
                 for kind, note in (("sqrt+", ""), ("sqrt-", " (negative root)"))]
    else:
        disc = sympy.expand(a1**2 - 4 * a2 * a0)
        roots = [Root([*nonzero(a2), back(disc) >= 0], kind, (back(a1), back(disc), back(a2)), note)
                 for kind, note in (("quad+", ""), ("quad-", " (second root)"))]
    if not a2.is_number and a1 != 0:
        roots.append(Root([back(a2) == 0, *nonzero(a1)], "value", (back(-a0 / a1),), " (linear case)"))
    return roots
