"""Quantifier handling for families: skolemise the goal, instantiate the hypotheses.

An obligation `H1 ∧ ... ∧ Hn -> G` with `G = ∀j φ(j)` is valid iff `H -> φ(c)` is, for a
fresh constant c (skolemisation). A hypothesis `∀j ψ(j)` may be replaced by any of its
instances `ψ(t)` (weakening), so the quantifier-free result, if valid, proves the original.
Instances use, per bound variable, the goal's skolem constants of its sort and, for index
and integer sorts, every symbol of that sort in the obligation (e.g. the boundary being
processed); on a second attempt real variables also take the real symbols of the goal
(e.g. a flow's duration). This is how per-boundary reasoning about "every boundary
processed so far" reaches nlsat without quantifiers.
"""

from __future__ import annotations

import itertools

from certiloop.models.lang.memos import NodeMemo, substitute_shared
from certiloop.models.lang.terms import INT, REAL, And, Implies, Node, Var, free_vars, substitute

MAX_INSTANCES = 64


_QUANTIFIED = NodeMemo()


def has_quantifier(n: Node) -> bool:
    if n.op in ("forall", "exists"):
        return True
    if not n.args:
        return False
    got = _QUANTIFIED.get(n)
    return _QUANTIFIED.put(n, any(has_quantifier(a) for a in n.args)) if got is None else got


class _Skolem:
    def __init__(self) -> None:
        self.count = 0
        self.constants: list[Node] = []

    def fresh(self, v: Node) -> Node:
        self.count += 1
        c = Var(f"{v.payload.split('@')[0]}@sk{self.count}", v.sort)
        self.constants.append(c)
        return c


def _split_goal(goal: Node, hyps: list[Node], sk: _Skolem) -> Node:
    """Move implications' left sides into hyps and skolemise universal goals."""
    if goal.op == "forall":
        env = {v.payload: sk.fresh(v) for v in goal.payload}
        return _split_goal(substitute(goal.args[0], env), hyps, sk)
    if goal.op == "implies":
        hyps.extend(_conjuncts(goal.args[0]))
        return _split_goal(goal.args[1], hyps, sk)
    if goal.op == "and":
        parts = [_split_goal_sub(g, sk) for g in goal.args]
        return And(*parts)
    return goal


def _split_goal_sub(goal: Node, sk: _Skolem) -> Node:
    local: list[Node] = []
    g = _split_goal(goal, local, sk)
    return Implies(And(*local), g) if local else g


def _conjuncts(f: Node) -> list[Node]:
    return [c for a in (f.args if f.op == "and" else (f,)) for c in _conjuncts_inner(a)]


def _conjuncts_inner(f: Node) -> list[Node]:
    return list(f.args) if f.op == "and" else [f]


def _prenex(h: Node) -> tuple[tuple[Node, ...], Node]:
    """∀x (A -> ∀y B)  ==>  (x, y), A -> B  (only through ∀, ∧-free implications)."""
    if h.op == "forall":
        inner_vars, body = _prenex(h.args[0])
        return tuple(h.payload) + inner_vars, body
    if h.op == "implies":
        inner_vars, body = _prenex(h.args[1])
        if inner_vars:
            clash = {v.payload for v in inner_vars} & set(free_vars(h.args[0]))
            if not clash:
                return inner_vars, Implies(h.args[0], body)
    return (), h


def instantiate(formula: Node, wide: bool = False, keep_goal_exists: bool = False,
                record: list | None = None) -> Node | None:
    """A quantifier-free formula that implies `formula` (None: no quantifiers, or an ∃ goal).
    keep_goal_exists: instantiate the hypotheses and keep a goal's remaining quantifiers
    (instances of hypotheses are implied by them, so this still only weakens).
    record, if given, receives one entry per hypothesis of the result, for a certificate:
    k (the k-th hypothesis kept) or (k, terms) (its instance at those terms)."""
    if not has_quantifier(formula):
        return None
    sk = _Skolem()
    hyps: list[Node] = []
    goal = _split_goal(formula, hyps, sk)
    ground = free_vars(And(*hyps, goal))
    in_goal = [g for g in free_vars(goal).values() if g.sort == REAL and "@sk" not in g.payload]
    out: list[Node] = []
    for k, h in enumerate(hyps):
        variables, body = _prenex(h)
        if not variables:
            if not has_quantifier(h):  # a hypothesis we cannot instantiate is dropped (weakening)
                out.append(h)
                if record is not None:
                    record.append(k)
            continue
        pools = []
        for v in variables:
            pool = [c for c in sk.constants if c.sort == v.sort]
            if v.sort == REAL:
                if wide:  # e.g. the duration of a flow, at which a "whole step" fact is needed
                    pool += in_goal[:8]
            elif not v.sort.is_array:
                pool += [g for g in ground.values() if g.sort == v.sort and "@sk" not in g.payload]
                if v.sort == INT:
                    pool = pool[:12]
            pools.append(pool)
        if any(not p for p in pools):
            continue  # nothing to instantiate with: dropping a hypothesis is a sound weakening
        for combo in itertools.islice(itertools.product(*pools), MAX_INSTANCES):
            instance = substitute_shared(body, {v.payload: t for v, t in zip(variables, combo)})
            if not has_quantifier(instance):
                out.append(instance)
                if record is not None:
                    record.append((k, combo))
    if has_quantifier(goal) and not keep_goal_exists:
        return None
    return Implies(And(*out), goal)
