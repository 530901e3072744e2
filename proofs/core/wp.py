"""Exact [a]P and <a>P for loop-free programs (used for modalities inside formulas, for the
vacuity check, and by the refuter on loop unrollings).

`unsolvable` says what to do with an ODE whose solution is not polynomial:
  "error": refuse (needed where an over-approximation of the runs is required);
  "drop":  ignore its runs — an under-approximation, sound for finding a counterexample
           (a violating run among fewer runs is a violating run) and for proving <a>P;
  "stay":  (for <a>P only) keep just its run of duration 0, also an under-approximation.
"""

from __future__ import annotations

import copy
import math

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import (
    FALSE,
    MODALITIES,
    TRUE,
    And,
    Exists,
    ForAll,
    Implies,
    ModelError,
    Node,
    Or,
    Var,
    free_vars,
    rebuild,
    store,
    substitute,
)
from certiloop.proofs.core.odes import polynomial_solution, runs_along


def has_modality(f: Node) -> bool:
    return f.op in MODALITIES or any(has_modality(a) for a in f.args)


def expand_modalities(f: Node, names, positive: bool = False) -> Node:
    """Replace every [a]P / <a>P (a loop-free) by its first-order equivalent.

    positive=True says f is a goal read with its free symbols universally quantified: a
    [.] reached through ∧, ∨, the right of ->, and ∀ only may then use free fresh symbols
    (so a counterexample shows their values) instead of quantifiers."""
    if not has_modality(f):
        return f
    if f.op == "box":
        return box(f.payload, expand_modalities(f.args[0], names, positive), names, quantify=not positive)
    if f.op == "diamond":
        return diamond(f.payload, expand_modalities(f.args[0], names), names)
    if f.op in ("forall", "exists"):
        keep = positive and f.op == "forall"
        return Node(f.op, (expand_modalities(f.args[0], names, keep),), f.sort, f.payload)
    if f.op in ("and", "or"):
        return rebuild(f, tuple(expand_modalities(a, names, positive) for a in f.args))
    if f.op == "implies":
        left, right = f.args
        return rebuild(f, (expand_modalities(left, names), expand_modalities(right, names, positive)))
    return rebuild(f, tuple(expand_modalities(a, names) for a in f.args))


def update(target: Node, value: Node) -> dict[str, Node]:
    if target.op == "var":
        return {target.payload: value}
    idx: list[Node] = []
    root = target
    while root.op == "select":
        idx[:0] = root.args[1:]
        root = root.args[0]
    return {root.payload: store(root, tuple(idx), value)}


def root_name(target: Node) -> Node:
    while target.op == "select":
        target = target.args[0]
    return target


def box(p: Program, post: Node, names, quantify: bool = True, unsolvable: str = "error",
        record: dict[int, str] | None = None) -> Node:
    """[p]post. With quantify=False, x := * and ODE durations become free fresh symbols,
    which is equivalent only where the result stands in positive position at top level
    (the refuter's use); their values then appear in the solver's model, and `record`
    maps each statement occurrence (by id) to its symbol so a run can be replayed."""
    again = lambda q, post: box(q, post, names, quantify, unsolvable, record)  # noqa: E731
    if isinstance(p, Assign):
        return substitute(post, update(p.target, p.value))
    if isinstance(p, Havoc):
        fresh = names.fresh(root_name(p.target), p.target.sort, "chosen")
        if record is not None:
            record[id(p)] = fresh.payload
        body = substitute(post, update(p.target, fresh))
        return ForAll(fresh, body) if quantify else body
    if isinstance(p, Test):  # a modal test (?[a]P) by its first-order equivalent
        return Implies(expand_modalities(p.cond, names), post)
    if isinstance(p, Seq):
        for q in reversed(p.parts):
            post = again(q, post)
        return post
    if isinstance(p, Choice):
        return And(*(again(q, post) for q in p.alternatives))
    if isinstance(p, ODE):
        flow = _flow(p, names, unsolvable)
        if flow is None:
            return TRUE
        tau, along, end = flow
        if record is not None:
            record[id(p)] = tau.payload
        body = Implies(And(tau >= 0, along), substitute(post, end))
        return ForAll(tau, body) if quantify else body
    if isinstance(p, Loop):
        raise ModelError("a loop inside a formula's [.] needs an invariant: make it the theorem's program")
    raise TypeError(p)


def diamond(p: Program, post: Node, names, unsolvable: str = "error", family_witnesses: bool = False) -> Node:
    """<p>post: some run of p ends in a state satisfying post.

    A whole family chosen by F := * cannot be quantified in our logic; with
    family_witnesses the runs kept are those choosing one of the same-sorted families the
    rest mentions (F := G): an under-approximation, sound for proving <p>post."""
    if isinstance(p, Assign):
        return substitute(post, update(p.target, p.value))
    if isinstance(p, Havoc) and p.target.op == "var" and p.target.sort.is_array and family_witnesses:
        name = p.target.payload
        same = [v for n, v in free_vars(post).items() if v.sort == p.target.sort and n != name]
        return Or(*(substitute(post, {name: g}) for g in same)) if same else FALSE
    if isinstance(p, Havoc):
        fresh = names.fresh(root_name(p.target), p.target.sort, "chosen")
        return Exists(fresh, substitute(post, update(p.target, fresh)))
    if isinstance(p, Test):
        return And(expand_modalities(p.cond, names), post)
    if isinstance(p, Seq):
        for q in reversed(p.parts):
            post = diamond(q, post, names, unsolvable, family_witnesses)
        return post
    if isinstance(p, Choice):
        return Or(*(diamond(q, post, names, unsolvable, family_witnesses) for q in p.alternatives))
    if isinstance(p, ODE):
        flow = _flow(p, names, "drop" if unsolvable == "stay" else unsolvable)
        if flow is None:  # "stay": the run that follows the flow for no time
            return And(p.domain, post) if unsolvable == "stay" else FALSE
        tau, along, end = flow
        return Exists(tau, And(tau >= 0, along, substitute(post, end)))
    if isinstance(p, Loop):
        raise ModelError("a loop inside a formula's <.> is not supported")
    raise TypeError(p)


def flow_solution(p: ODE) -> tuple[Node, dict[str, Node] | None]:
    s = Var("s@flow")
    return s, polynomial_solution(p, s)


def _flow(p: ODE, names, unsolvable: str):
    s, sol = flow_solution(p)
    if sol is None:
        if unsolvable == "drop":
            return None
        raise ModelError(
            f"the ODE {{{', '.join(v.payload for v in p.variables)}}} has no polynomial solution, "
            "so it cannot be used inside a formula's modality"
        )
    tau = names.fresh("t", why="ODE duration")
    along = runs_along(p, sol, tau, s)
    end = {name: substitute(x, {s.name: tau}) for name, x in sol.items()}
    return tau, along, end


def unrolled_paths(p: Program, depth: int) -> int:
    """How many paths `unroll(p, depth)` has: a loop whose body has b paths gets
    1 + b + ... + b^depth, so nested loops multiply fast."""
    if isinstance(p, Seq):
        return math.prod(unrolled_paths(q, depth) for q in p.parts)
    if isinstance(p, Choice):
        return sum(unrolled_paths(q, depth) for q in p.alternatives)
    if isinstance(p, Loop):
        body = unrolled_paths(p.body, depth)
        return sum(body ** n for n in range(depth + 1))
    return 1


def unroll(p: Program, depth: int) -> Program:
    """Replace every loop a* by the runs with at most `depth` iterations of a.

    Every statement occurrence in the result is a distinct object, so a replay can tell
    the iterations apart."""
    from certiloop.models.lang.programs import choice, seq, skip

    if isinstance(p, Seq):
        return seq(*(unroll(q, depth) for q in p.parts))
    if isinstance(p, Choice):
        return Choice(tuple(unroll(q, depth) for q in p.alternatives), p.labels)
    if isinstance(p, Loop):
        runs: Program = skip()
        for n in range(depth, 0, -1):
            runs = choice((f"{p.label} ends", skip()),
                          (f"{p.label} iteration {n}", seq(unroll(p.body, depth), runs)))
        return runs
    return copy.copy(p)
