"""Bridge between model terms and sympy (for ODE solutions, Lie derivatives, polynomials)."""

from __future__ import annotations

from fractions import Fraction

import sympy

from certiloop.models.lang.terms import Node, add, const, mul, term


class SympyTable:
    """Maps atomic subterms (symbols, array reads) to sympy symbols and back."""

    def __init__(self) -> None:
        self._by_key: dict[tuple, sympy.Symbol] = {}
        self._back: dict[sympy.Symbol, Node] = {}

    def symbol(self, atom: Node) -> sympy.Symbol:
        s = self._by_key.get(atom.key)
        if s is None:
            s = sympy.Symbol(f"a{len(self._by_key)}_{_safe(str(atom))}", real=True)
            self._by_key[atom.key] = s
            self._back[s] = atom
        return s

    def atom(self, s: sympy.Symbol) -> Node:
        return self._back[s]

    def atoms(self) -> list[Node]:
        """The subterms read as symbols so far."""
        return list(self._back.values())


def _safe(text: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in text)[:24]


def to_sympy(n: Node, table: SympyTable) -> sympy.Expr:
    op = n.op
    if op == "const":
        f: Fraction = n.payload
        return sympy.Rational(f.numerator, f.denominator)
    if op in ("var", "select", "store"):
        return table.symbol(n)
    if op == "+":
        return sympy.Add(*(to_sympy(a, table) for a in n.args))
    if op == "*":
        return sympy.Mul(*(to_sympy(a, table) for a in n.args))
    if op == "neg":
        return -to_sympy(n.args[0], table)
    if op == "/":
        return to_sympy(n.args[0], table) / to_sympy(n.args[1], table)
    if op == "^":
        return to_sympy(n.args[0], table) ** n.payload
    raise TypeError(f"not an arithmetic term: {n}")


def from_sympy(e: sympy.Expr, table: SympyTable) -> Node:
    if e.is_Rational:
        return const(Fraction(int(e.p), int(e.q)))
    if e.is_Symbol:
        return table.atom(e)
    if e.is_Add:
        return add(*(from_sympy(a, table) for a in e.args))
    if e.is_Mul:
        num, den = sympy.fraction(e)
        if den != 1:
            return from_sympy(num, table) / from_sympy(den, table)
        return mul(*(from_sympy(a, table) for a in e.args))
    if e.is_Pow and e.exp.is_Integer:
        if int(e.exp) >= 0:
            return term(from_sympy(e.base, table)) ** int(e.exp)
        return const(1) / (term(from_sympy(e.base, table)) ** int(-e.exp))
    raise TypeError(f"cannot turn sympy expression {e} into a model term")
