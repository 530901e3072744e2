"""Case analysis on the guards of case-split definitions: the prover splits a hard leaf this
way, and the checker rebuilds the same cases from the leaf alone (a certificate names no guard).

abs, min and max become disjunctions `a >= 0 & ... | a < 0 & ...`. An obligation `H -> G` is
valid iff `H & C -> G` is for every combination C of truth values of some atoms: the
combinations are exhaustive, so together the cases are equivalent to the obligation. Which
atoms is a heuristic (the guards of such disjunctions); soundness does not depend on it.
z3's nonlinear procedure can find each case far easier than the whole: in KeYmaera X's STTT
tutorial example 10, each of four cases takes about 100,000 resource units, the whole more
than 30,000,000.
"""

from __future__ import annotations

from itertools import product

from certiloop.models.lang.terms import QUANTIFIERS, And, Implies, Node, Not

MAX_GUARDS = 3  # at most 8 cases
COMPLEMENT = {(">=", "<"), ("<", ">="), ("<=", ">"), (">", "<="), ("==", "!="), ("!=", "==")}


def guards(f: Node) -> list[Node]:
    """The first conjuncts of two-way disjunctions `c & .. | c' & ..` with c' the complement
    of c (same sides), outside quantifiers, in order of appearance, each once."""
    found: dict[tuple, Node] = {}

    def walk(n: Node) -> None:
        if n.op in QUANTIFIERS:
            return
        if n.op == "or" and len(n.args) == 2 and all(d.op == "and" for d in n.args):
            c1, c2 = n.args[0].args[0], n.args[1].args[0]
            if (c1.op == c2.op == "cmp" and (c1.payload, c2.payload) in COMPLEMENT
                    and c1.args[0].key == c2.args[0].key and c1.args[1].key == c2.args[1].key):
                found.setdefault(c1.key, c1)
        for a in n.args:
            walk(a)

    walk(f)
    return list(found.values())


def case_formulas(formula: Node) -> list[Node] | None:
    """`H & C -> G` for every combination C of the first MAX_GUARDS guards of `H -> G`, or
    None when it has none."""
    if formula.op != "implies":
        return None
    chosen = guards(formula)[:MAX_GUARDS]
    if not chosen:
        return None
    hypotheses, goal = formula.args
    return [Implies(And(hypotheses, *(g if holds else Not(g) for g, holds in zip(chosen, signs))), goal)
            for signs in product((True, False), repeat=len(chosen))]
