"""Well-definedness of a formula that holds modalities: along the runs of their programs.

Expanding [a]P or <a>P first (wp.py) and then asking wd.defined of the result loses
divisions: sympy solves `x' = y/y` as x + s, an assignment that nothing reads vanishes. So
`x = 0 & y = 0 -> <{x' = y*(1/y)}> x >= 1` would be proved, though the flow's speed is
0*(1/0). Here a modality is defined where every run of its program evaluates only defined
terms, each statement in the state it runs in, and its postcondition is defined where each
run ends: for a diamond too, as wd.defined reads an expanded diamond's `\\exists` (for every
value). Connectives are read left to right as in wd.defined. An ODE's right-hand sides and
domain must be defined wherever it may go inside its domain (any values of its variables),
and a loop's body anywhere its writes may lead: stricter than their runs need, so a
failure of those is no proof that the claim divides by zero (`may_overstate`).
"""

from __future__ import annotations

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test, written
from certiloop.models.lang.terms import (
    MODALITIES,
    QUANTIFIERS,
    TRUE,
    And,
    ForAll,
    Implies,
    Node,
    Not,
    substitute,
)
from certiloop.proofs.core.bounded import ITERATIONS, bounded
from certiloop.proofs.core.odes import solvable
from certiloop.proofs.core.wd import defined, defined_term, has_division
from certiloop.proofs.core.wp import box, expand_modalities, flow_solution, has_modality, root_name, update


def defined_modal(f: Node, names) -> Node:
    """The states in which f, modalities included, is evaluated without dividing by 0."""
    if not has_modality(f):
        return defined(f)
    op = f.op
    if op in MODALITIES:
        return along(f.payload, defined_modal(f.args[0], names), names)
    if op in QUANTIFIERS:
        body = defined_modal(f.args[0], names)
        return TRUE if body.op == "true" else ForAll(f.payload, body)
    if op == "and":
        return _left_to_right(f.args, _all_hold, names)
    if op == "or":
        return _left_to_right(f.args, _all_fail, names)
    if op == "implies":
        a, b = f.args
        return And(defined_modal(a, names), Implies(_condition(a, names), defined_modal(b, names)))
    return And(*(defined_modal(a, names) for a in f.args))  # not, iff


def _left_to_right(args, reached, names) -> Node:
    # `and` reaches a part where the earlier ones hold, `or` where they fail
    holds = [_condition(a, names, reached is _all_hold) for a in args]
    return And(*(Implies(reached(holds[:k]), defined_modal(a, names)) for k, a in enumerate(args)))


def _all_hold(earlier):
    return And(*earlier)


def _all_fail(earlier):
    return And(*(Not(e) for e in earlier))


def _condition(f: Node, names, holds: bool = True) -> Node:
    """f, where the check asks definedness only in the states where f holds (holds) or
    fails: a loop (or a flow without a polynomial solution) in its modalities is bounded
    (bounded.py) to a weaker f, or a stronger one where it must fail, so the check asks it in
    more states than needed, never fewer (may_overstate says so)."""
    return expand_modalities(bounded(f, ITERATIONS, solvable, assumed=holds), names)


def along(p: Program, after: Node, names) -> Node:
    """Every run of p evaluates only defined terms, and `after` holds where it ends."""
    if isinstance(p, Assign):
        return And(*(defined_term(t) for t in (p.value, *_indices(p.target))),
                   substitute(after, update(p.target, p.value)))
    if isinstance(p, Havoc):
        if after.op == "true" and not _indices(p.target):
            return TRUE
        fresh = names.fresh(root_name(p.target), p.target.sort, "chosen")
        return And(*(defined_term(t) for t in _indices(p.target)),
                   ForAll(fresh, substitute(after, update(p.target, fresh))))
    if isinstance(p, Test):
        return And(defined_modal(p.cond, names), Implies(_condition(p.cond, names), after))
    if isinstance(p, Seq):
        for q in reversed(p.parts):
            after = along(q, after, names)
        return after
    if isinstance(p, Choice):
        return And(*(along(q, after, names) for q in p.alternatives))
    if isinstance(p, ODE):
        region = And(defined(p.domain), Implies(p.domain, And(*(defined(f) for _, f in p.eqs))))
        if region.op != "true":
            region = _anywhere(p.variables, region, names)
        if after.op == "true":
            return region
        solved = flow_solution(p)[1] is not None
        ends = box(p, after, names) if solved else _anywhere(p.variables, Implies(p.domain, after), names)
        return And(region, ends)
    if isinstance(p, Loop):  # anywhere the loop's writes may lead: its body defined, and `after`
        inside = And(along(p.body, TRUE, names), after)
        return _anywhere(list(written(p.body).values()), inside, names)
    raise TypeError(p)


def may_overstate(f: Node) -> bool:
    """Does defined_modal(f) ask more than f's runs need (an ODE whose statements divide, or
    without a polynomial solution, or a loop: checked for any values of their variables)?"""
    if f.op in MODALITIES and _region_checked(f.payload):
        return True
    return any(may_overstate(a) for a in f.args)


def _region_checked(p: Program) -> bool:
    if isinstance(p, ODE):  # its region, or where it ends without a polynomial solution
        return any(has_division(g) for g in (p.domain, *(f for _, f in p.eqs))) or flow_solution(p)[1] is None
    if isinstance(p, Loop):
        return True
    if isinstance(p, Test):
        return may_overstate(p.cond)
    parts = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else ()
    return any(_region_checked(q) for q in parts)


def _anywhere(variables, f: Node, names) -> Node:
    """f for any values of the variables (fresh symbols, universally quantified)."""
    if f.op == "true":
        return f
    fresh = {v.payload: names.fresh(v, v.sort, "anywhere") for v in variables}
    body = substitute(f, fresh)
    for v in fresh.values():
        body = ForAll(v, body)
    return body


def _indices(target: Node) -> tuple[Node, ...]:
    idx: list[Node] = []
    while target.op == "select":
        idx[:0] = target.args[1:]
        target = target.args[0]
    return tuple(idx)
