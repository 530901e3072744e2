"""Subterm abstraction: rewrite atoms in terms of named abbreviations, then generalise.

Given an abbreviation a == e(x) (e.g. d0 == (p - r)·n), each atom g(x) ⋈ 0 is reduced
modulo a - e(x) (a Gröbner-basis normal form with x eliminated first). Where the reduced
form no longer mentions the eliminated symbols, the atom is replaced by it, and `a` is a
fresh symbol. This is sound: the abstracted formula φ'(x, a) satisfies φ'(x, e(x)) ≡ φ(x),
so if φ' holds for every a, φ holds. It is the paper's projection onto d0, fn, fnp: three
real numbers per boundary instead of nine coordinates.

Obligations are over SSA symbols (p@3 is p after a loop), so each abbreviation is
instantiated for every version of its symbols that occurs.
"""

from __future__ import annotations

import itertools

import sympy

from certiloop.models.terms import Node, Var, cmp, free_vars, rebuild, substitute

from .symbolic import SympyTable, from_sympy, to_sympy

MAX_INSTANCES = 16


def _versions(formula: Node) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for name in free_vars(formula):
        out.setdefault(name.split("@")[0], []).append(name)
    return out


def _instances(abbrevs: dict[str, Node], formula: Node) -> list[tuple[Node, Node]]:
    """(fresh symbol, definition over the formula's symbols) for each usable instance."""
    versions = _versions(formula)
    out: list[tuple[Node, Node]] = []
    for name, definition in abbrevs.items():
        syms = sorted(free_vars(definition))
        if not all(s in versions for s in syms):
            continue
        combos = list(itertools.product(*(versions[s] for s in syms)))[:MAX_INSTANCES]
        for k, combo in enumerate(combos):
            env = {s: Var(v, free_vars(definition)[s].sort) for s, v in zip(syms, combo)}
            out.append((Var(f"{name}@abs{k}"), substitute(definition, env)))
    return out


def abstract(formula: Node, abbrevs: dict[str, Node]) -> Node | None:
    """The abstracted formula, or None when no atom could be rewritten."""
    if not abbrevs or _has_binder(formula):
        return None
    inst = _instances(abbrevs, formula)
    if not inst:
        return None
    table = SympyTable()
    abbrev_syms = [table.symbol(a) for a, _ in inst]
    relations = [table.symbol(a) - sympy.expand(to_sympy(e, table)) for a, e in inst]
    eliminate = sorted({s for rel in relations for s in rel.free_symbols} - set(abbrev_syms), key=str)
    changed = [False]

    def rewrite(n: Node) -> Node:
        if n.op == "cmp" and n.args[0].sort.is_numeric:
            g = sympy.expand(to_sympy(n.args[0], table) - to_sympy(n.args[1], table))
            if not (g.free_symbols & set(eliminate)):
                return n
            try:
                _, rem = sympy.reduced(g, relations, *eliminate, *abbrev_syms, order="lex")
            except (sympy.PolynomialError, sympy.polys.polyerrors.PolificationFailed):
                return n
            if rem.free_symbols & set(eliminate):
                return n
            changed[0] = True
            return cmp(n.payload, from_sympy(sympy.expand(rem), table), 0)
        if n.op in ("and", "or", "not", "implies", "iff"):
            return rebuild(n, tuple(rewrite(a) for a in n.args))
        return n

    out = rewrite(formula)
    return out if changed[0] else None


def _has_binder(n: Node) -> bool:
    return n.op in ("forall", "exists") or any(_has_binder(a) for a in n.args)
