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
from dataclasses import dataclass

import sympy

from certiloop.models.terms import REAL, And, Implies, Node, Var, cmp, free_vars, rebuild, substitute

from .symbolic import SympyTable, from_sympy, to_sympy

MAX_INSTANCES = 16


def _versions(formula: Node) -> dict[str, list[Node]]:
    out: dict[str, list[Node]] = {}
    for name, sym in free_vars(formula).items():
        out.setdefault(name.split("@")[0], []).append(sym)
    return out


def abbreviation_instances(abbrevs: dict[str, Node], formula: Node) -> list[Instance]:
    """(fresh symbol, definition over the formula's symbols) for each usable instance.

    A definition's symbols are matched with every SSA version of them in the formula; a
    symbol of an index sort that the formula lacks is a parameter (e.g. the boundary b in
    d0(b) = (p - r(b))·n(b)) and takes every index symbol of its sort in the formula."""
    if not abbrevs:
        return []
    versions = _versions(formula)
    by_sort: dict[str, list[Node]] = {}
    for sym in free_vars(formula).values():
        by_sort.setdefault(str(sym.sort), []).append(sym)
    out: list[Instance] = []
    for name, definition in abbrevs.items():
        syms = free_vars(definition)
        pools, params = [], []
        for s, node in sorted(syms.items()):
            if s in versions:
                pools.append(versions[s])
            elif not node.sort.is_numeric and not node.sort.is_array and str(node.sort) in by_sort:
                pools.append(by_sort[str(node.sort)])
                params.append(s)
            else:
                pools = []
                break
        if not pools:
            continue
        names = sorted(syms)
        for combo in itertools.islice(itertools.product(*pools), MAX_INSTANCES):
            env = dict(zip(names, combo))
            family = (name, tuple(env[n].payload for n in names if n not in params))
            out.append(Instance(Var(f"{name}@abs{len(out)}"), substitute(definition, env),
                                family, tuple(env[p] for p in params)))
    return out


@dataclass(frozen=True)
class Instance:
    """An abbreviation instance: `symbol` stands for `definition`; instances of one family
    differ only in their index parameters, so equal indices mean equal values."""

    symbol: Node
    definition: Node
    family: tuple = ()
    indices: tuple = ()

    def with_definition(self, definition: Node) -> "Instance":
        return Instance(self.symbol, definition, self.family, self.indices)


def congruences(inst: list[Instance], index_term=lambda t: t) -> list[Node]:
    """(b1 = b2) -> (a1 = a2) for instances of one family at index symbols b1, b2."""
    facts = []
    for a, b in itertools.combinations(inst, 2):
        if a.family == b.family and a.indices and [x.key for x in a.indices] != [y.key for y in b.indices]:
            same = And(*(cmp("==", index_term(x), index_term(y)) for x, y in zip(a.indices, b.indices)))
            facts.append(Implies(same, cmp("==", a.symbol, b.symbol)))
    return facts


def lower_term(t: Node) -> Node:
    """The same renaming of array reads and index symbols as `lowering.lower` applies."""
    from .lowering import read_name

    if t.op == "select":
        return Var(read_name(t), t.sort)
    if t.op == "var" and not t.sort.is_array and not t.sort.is_numeric and t.sort.name != "Bool":
        return Var(t.payload, REAL)
    if not t.args:
        return t
    return rebuild(t, tuple(lower_term(a) for a in t.args))


def abstract(formula: Node, inst: list[Instance], extra_facts: list[Node] = ()) -> Node | None:
    """The abstracted formula, or None when no atom could be rewritten. `extra_facts`
    (true whenever the abbreviations equal their definitions) become hypotheses."""
    if not inst or _has_binder(formula):
        return None
    table = SympyTable()
    abbrev_syms = [table.symbol(i.symbol) for i in inst]
    relations = [table.symbol(i.symbol) - sympy.expand(to_sympy(i.definition, table)) for i in inst]
    defined = [rel.free_symbols - {a} for rel, a in zip(relations, abbrev_syms)]
    eliminate = sorted({s for rel in relations for s in rel.free_symbols} - set(abbrev_syms), key=str)
    changed = [False]

    def rewrite(n: Node) -> Node:
        if n.op == "cmp" and n.args[0].sort.is_numeric:
            g = sympy.expand(to_sympy(n.args[0], table) - to_sympy(n.args[1], table))
            if not (g.free_symbols & set(eliminate)):
                return n
            # only instances built from this atom's own symbols (right SSA versions, right
            # boundary): two instances with one leading monomial would derail the division
            mine = [k for k, syms in enumerate(defined) if syms <= g.free_symbols]
            if not mine:
                return n
            rels = [relations[k] for k in mine]
            gens = sorted(set().union(*(defined[k] for k in mine)), key=str)
            try:
                _, rem = sympy.reduced(g, rels, *gens, *(abbrev_syms[k] for k in mine), order="lex")
            except (sympy.PolynomialError, sympy.polys.polyerrors.PolificationFailed):
                return n
            if rem.free_symbols & set(gens):
                return n
            changed[0] = True
            return cmp(n.payload, from_sympy(sympy.expand(rem), table), 0)
        if n.op in ("and", "or", "not", "implies", "iff"):
            return rebuild(n, tuple(rewrite(a) for a in n.args))
        return n

    out = rewrite(formula)
    if not changed[0]:
        return None
    return Implies(And(*extra_facts), out) if extra_facts else out


def _has_binder(n: Node) -> bool:
    return n.op in ("forall", "exists") or any(_has_binder(a) for a in n.args)
