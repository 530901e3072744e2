"""Where a loop may sit inside a formula: the shapes the proof core takes apart.

A guarantee may hold a box with a loop, `[a*]P`, wherever it is *positive*: reached from the
top through `&`, the right of `->`, a disjunction whose other parts hold no loop, `\\forall`,
`\\exists` (proved with a witness term, see `Theorem.witnesses`), or the postcondition of
another box. There the core proves it by the loop rule, as it proves the theorem's own
program. Anywhere else, a diamond `<a*>P` (liveness: it needs a variant), a negation, the
left of `->`, an equivalence, the loop is refused with the reason.
"""

from __future__ import annotations

from certiloop.models.lang.programs import Program, Test, children, is_loop_free
from certiloop.models.lang.terms import MODALITIES, Node


def has_loop_modality(f: Node) -> bool:
    """Does a modality inside f (or a test inside its programs) hold a loop?"""
    if f.op in MODALITIES and (not is_loop_free(f.payload) or tests_have_loops(f.payload)):
        return True
    return any(has_loop_modality(a) for a in f.args)


def tests_have_loops(p: Program) -> bool:
    if isinstance(p, Test):
        return has_loop_modality(p.cond)
    return any(tests_have_loops(q) for q in children(p))


def loop_nesting_problem(f: Node) -> str | None:
    """Why the loops inside the guarantee f cannot be proved where they sit, or None."""
    if not has_loop_modality(f):
        return None
    op = f.op
    if op == "and":
        return next((why for a in f.args if (why := loop_nesting_problem(a))), None)
    if op == "implies":
        if has_loop_modality(f.args[0]):
            return "a loop on the left of `->` (an assumption about all runs of a loop)"
        return loop_nesting_problem(f.args[1])
    if op == "or":
        looping = [a for a in f.args if has_loop_modality(a)]
        if len(looping) > 1:
            return "loops in two parts of a disjunction"
        return loop_nesting_problem(looping[0])
    if op in ("forall", "exists"):
        return loop_nesting_problem(f.args[0])
    if op == "box":
        if tests_have_loops(f.payload):
            return "a loop inside a test `?..` of a program"
        return loop_nesting_problem(f.args[0])
    if op == "diamond":
        return "a loop inside a diamond `<..>` (liveness needs a variant)"
    if op == "not":
        return "a loop under a negation"
    return "a loop inside an equivalence `<->`" if op == "iff" else f"a loop inside `{op}`"
