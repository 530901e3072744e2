"""Where a loop may sit inside a formula: the shapes the proof core takes apart.

A guarantee may hold a box with a loop, `[a*]P`, wherever it is *positive*: reached from the
top through `&`, the right of `->`, a disjunction whose other parts hold no loop, `\\forall`,
`\\exists` (proved with a witness term, see `Theorem.witnesses`), or the postcondition of
another box. There the core proves it by the loop rule, as it proves the theorem's own
program. A diamond `<a*>P` in such a place is proved by its runs with a few iterations (fewer
runs, so a proof is a proof; liveness in general needs a variant, which certiloop does not
search for), if P and the tests of a hold no loop. Anywhere else, a negation, the left of
`->`, an equivalence, the loop is refused with the reason.
"""

from __future__ import annotations

from certiloop.models.lang.programs import ODE, Assign, Havoc, Loop, Program, Test, children, is_loop_free
from certiloop.models.lang.terms import MODALITIES, Node


def has_loop_modality(f: Node) -> bool:
    """Does a modality inside f (or a formula inside its programs) hold a loop?"""
    if f.op in MODALITIES and (not is_loop_free(f.payload) or tests_have_loops(f.payload)):
        return True
    return any(has_loop_modality(a) for a in f.args)


def tests_have_loops(p: Program) -> bool:
    """Does a formula inside the program (a test, an ODE's domain or annotation, a loop's
    invariant) hold a loop inside a modality?"""
    return any(has_loop_modality(f) for f in _formulas(p)) or any(tests_have_loops(q) for q in children(p))


def modal_domains(p: Program) -> bool:
    """Does an ODE of the program have a modality in its domain or annotations?"""
    if isinstance(p, ODE) and any(_modal(f) for f in (p.domain, *p.invariants)):
        return True
    return any(modal_domains(q) for q in children(p))


def _modal(f: Node) -> bool:
    return f.op in MODALITIES or any(_modal(a) for a in f.args)


def _formulas(p: Program) -> list[Node]:
    if isinstance(p, Test):
        return [p.cond]
    if isinstance(p, ODE):
        return [p.domain, *p.invariants]
    if isinstance(p, Loop) and p.invariant is not None:
        return [p.invariant]
    return []


def divides(f: Node, risky: frozenset[str] = frozenset()) -> bool:
    """Does f (with the programs inside its modalities) divide by anything but a nonzero
    number, or mention a risky symbol? Where it does, the order in which its parts are
    evaluated matters."""
    if f.op == "/" and not (f.args[1].op == "const" and f.args[1].payload != 0):
        return True
    if f.op == "var" and f.payload in risky:
        return True
    if f.op in MODALITIES and _program_divides(f.payload, risky):
        return True
    return any(divides(a, risky) for a in f.args)


def _program_divides(p: Program, risky: frozenset[str] = frozenset()) -> bool:
    parts: list[Node] = []
    if isinstance(p, (Assign, Havoc)):
        parts = [p.target] + ([p.value] if isinstance(p, Assign) else [])
    elif isinstance(p, Test):
        parts = [p.cond]
    elif isinstance(p, ODE):
        parts = [p.domain, *p.invariants, *(rhs for _, rhs in p.eqs)]
    elif isinstance(p, Loop) and p.invariant is not None:
        parts = [p.invariant]
    return any(divides(f, risky) for f in parts) or any(_program_divides(q, risky) for q in children(p))


def loop_nesting_problem(f: Node, risky: frozenset[str] = frozenset()) -> str | None:
    """Why the loops inside the guarantee f cannot be proved where they sit, or None. risky:
    symbols defined only where an argument allows (a translation's square roots), which count
    as divisions."""
    if not has_loop_modality(f):
        return None
    op = f.op
    if op == "and":
        return next((why for a in f.args if (why := loop_nesting_problem(a, risky))), None)
    if op == "implies":
        if has_loop_modality(f.args[0]):
            return "a loop on the left of `->` (an assumption about all runs of a loop)"
        return loop_nesting_problem(f.args[1], risky)
    if op == "or":
        looping = [n for n, a in enumerate(f.args) if has_loop_modality(a)]
        if len(looping) > 1:
            return "loops in two parts of a disjunction"
        if looping[0] < len(f.args) - 1 and any(divides(a, risky) for a in f.args[looping[0]:]):
            # proved as `!(others) -> loop part`, which evaluates the later parts first
            return "a loop in a disjunct before a later one, with a division among them (read left to right)"
        return loop_nesting_problem(f.args[looping[0]], risky)
    if op in ("forall", "exists"):
        return loop_nesting_problem(f.args[0], risky)
    if op == "box":
        if tests_have_loops(f.payload):
            return "a loop inside a formula of a program (a test, an ODE domain, an annotation)"
        return loop_nesting_problem(f.args[0], risky)
    if op == "diamond":
        if has_loop_modality(f.args[0]) or tests_have_loops(f.payload):
            return "a loop inside a diamond's postcondition or inside a formula of its program"
        return None
    if op == "not":
        return "a loop under a negation"
    return "a loop inside an equivalence `<->`" if op == "iff" else f"a loop inside `{op}`"
