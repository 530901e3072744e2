"""Where a loop may sit inside a formula: the shapes the proof core takes apart.

A guarantee may hold a box with a loop, `[a*]P`, wherever it is *positive*: reached from the
top through `&`, the right of `->`, a disjunction whose other parts hold no loop, `\\forall`,
`\\exists` (proved with a witness term, see `Theorem.witnesses`), or the postcondition of
another box. There the core proves it by the loop rule, as it proves the theorem's own
program. A diamond `<a*>P` in such a place is proved by its runs with a few iterations (fewer
runs, so a proof is a proof; liveness in general needs a variant, which certiloop does not
search for), if P and the tests of a hold no loop.

A negation over a loop is first pushed inward (`positive_form`: `!<a*>P` is `[a*]!P`), and an
equivalence becomes two implications. What is left in a negative place, the left of `->` or
the disjuncts of `|` other than the last one holding a loop, is *assumed*: the core may use it
only weakened to runs with a few iterations ([a*]P implies [a]P), which is sound for a proof.
Refused with the reason: a loop inside a formula of a program (a test, an ODE domain, an
annotation), inside a diamond's postcondition, or before a later disjunct that divides.
"""

from __future__ import annotations

from typing import Callable

from certiloop.models.lang.programs import ODE, Assign, Havoc, Loop, Program, Test, children, is_loop_free
from certiloop.models.lang.terms import BOOL, MODALITIES, Box, Diamond, Node, Not


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


def positive_form(f: Node, inside: Callable[[Node], bool] = None) -> Node:
    """f with each negation over a part `inside` selects (by default: one holding a loop)
    pushed inward, `!<a>P` as `[a]!P`, `![a]P` as `<a>!P`, De Morgan, `!\\forall` as
    `\\exists!`, `!(A -> B)` as `A & !B`, and each such equivalence as two implications.
    Every step is an equivalence that evaluates the same parts in the same order (read left
    to right), so the claim and where it is defined do not change. The connectives are built
    as written (no `P | true` simplified away, which would skip P's definedness)."""
    inside = inside or has_loop_modality
    if not inside(f):
        return f
    op = f.op
    if op == "not":
        return _negated(f.args[0], inside)
    if op == "iff":
        a, b = f.args
        return Node("and", (positive_form(Node("implies", (a, b), BOOL), inside),
                            positive_form(Node("implies", (b, a), BOOL), inside)), BOOL)
    if op in ("and", "or", "implies", "forall", "exists"):
        return Node(op, tuple(positive_form(a, inside) for a in f.args), f.sort, f.payload)
    if op == "box":
        return Box(f.payload, positive_form(f.args[0], inside))
    if op == "diamond":
        return Diamond(f.payload, positive_form(f.args[0], inside))
    return f


def _negated(f: Node, inside: Callable[[Node], bool]) -> Node:
    """The positive form of !f."""
    if not inside(f):
        return Not(f)
    op = f.op
    if op == "not":
        return positive_form(f.args[0], inside)
    if op == "and":
        return Node("or", tuple(_negated(a, inside) for a in f.args), BOOL)
    if op == "or":
        return Node("and", tuple(_negated(a, inside) for a in f.args), BOOL)
    if op == "implies":
        return Node("and", (positive_form(f.args[0], inside), _negated(f.args[1], inside)), BOOL)
    if op == "iff":
        return _negated(positive_form(f, inside), inside)
    if op in ("forall", "exists"):
        flipped = "exists" if op == "forall" else "forall"
        return Node(flipped, (_negated(f.args[0], inside),), BOOL, f.payload)
    if op == "box":
        return Diamond(f.payload, _negated(f.args[0], inside))
    if op == "diamond":
        return Box(f.payload, _negated(f.args[0], inside))
    return Not(f)


def loop_nesting_problem(f: Node, risky: frozenset[str] = frozenset()) -> str | None:
    """Why the loops inside the guarantee f cannot be proved where they sit, or None. risky:
    symbols defined only where an argument allows (a translation's square roots), which count
    as divisions."""
    return _nesting_problem(positive_form(f), risky)


def _nesting_problem(f: Node, risky: frozenset[str]) -> str | None:
    if not has_loop_modality(f):
        return None
    op = f.op
    if op == "and":
        return next((why for a in f.args if (why := _nesting_problem(a, risky))), None)
    if op == "implies":  # a loop on the left is assumed (weakened), checked like any formula
        return _assumed_problem(f.args[0]) or _nesting_problem(f.args[1], risky)
    if op == "or":
        looping = [n for n, a in enumerate(f.args) if has_loop_modality(a)]
        proved = looping[-1]  # the others are assumed false
        if proved < len(f.args) - 1 and any(divides(a, risky) for a in f.args[proved:]):
            # proved as `!(others) -> that part`, which evaluates the later parts first
            return "a loop in a disjunct before a later one, with a division among them (read left to right)"
        others = [a for n, a in enumerate(f.args) if n != proved]
        return (next((why for a in others if (why := _assumed_problem(a))), None)
                or _nesting_problem(f.args[proved], risky))
    if op in ("forall", "exists"):
        return _nesting_problem(f.args[0], risky)
    if op == "box":
        if tests_have_loops(f.payload):
            return "a loop inside a formula of a program (a test, an ODE domain, an annotation)"
        return _nesting_problem(f.args[0], risky)
    if op == "diamond":
        if has_loop_modality(f.args[0]) or tests_have_loops(f.payload):
            return "a loop inside a diamond's postcondition or inside a formula of its program"
        return None
    return f"a loop inside `{op}`"  # pragma: no cover - positive_form leaves no other shape


def _assumed_problem(f: Node) -> str | None:
    """Why a formula the core assumes cannot be weakened to one without loops, or None."""
    if f.op in MODALITIES and tests_have_loops(f.payload):
        return "a loop inside a formula of a program (a test, an ODE domain, an annotation)"
    return next((why for a in f.args if (why := _assumed_problem(a))), None)
