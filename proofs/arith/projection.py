"""Choosing abbreviation instances for the projection (outside the trusted core: any choice
is sound, `proofs.core.abstraction` checks what matters).

Obligations are over SSA symbols (p@3 is p after a loop), so each abbreviation is
instantiated for every version of its symbols that occurs.
"""

from __future__ import annotations

import itertools

from certiloop.models.lang.memos import substitute_shared
from certiloop.models.lang.terms import Node, Var, free_vars
from certiloop.proofs.core.abstraction import Instance

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
        combos = (c for c in itertools.product(*pools) if _consistent(dict(zip(names, c)), versions))
        for combo in itertools.islice(combos, MAX_INSTANCES):
            env = dict(zip(names, combo))
            family = (name, tuple(env[n].payload for n in names if n not in params))
            out.append(Instance(Var(f"{name}@abs{len(out)}"), substitute_shared(definition, env),
                                family, tuple(env[p] for p in params)))
    return out


def _suffix(sym: Node) -> str:
    return sym.payload.partition("@")[2]


def _consistent(env: dict[str, Node], versions: dict[str, list[Node]]) -> bool:
    """Symbols of one state go together: if x takes version @N and y has a version @N,
    y must take it too (p@7 with f@7, not p@7 with the initial f)."""
    chosen = {_suffix(v) for v in env.values() if _suffix(v)}
    for name, v in env.items():
        have = {_suffix(x) for x in versions.get(name, ())}
        for n in chosen & have:
            if _suffix(v) != n:
                return False
    return True


