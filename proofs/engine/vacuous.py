"""Is a proof vacuous? `A -> [a]P` holds for every P when no state meets A, or when no run of
`a` gets through its first control step (a test that always fails). Such a proof says nothing,
so `prove` reports it ("vacuous: ...", exit 1) unless the user allows it.

Both checks are proofs, never guesses: the assumptions are unsatisfiable when z3 proves their
negation valid; the first control step blocks every run when `A -> [prefix; body] false` has
every obligation proved (prefix: what runs before the program's first loop, body: that loop's
body; a loop-free program is checked whole). A flow that nothing after it in the step can block
is read as its run of duration 0, the test of its domain: a flow has a run from a state exactly
when its domain holds there, so this changes nothing about blocking and keeps the check to the
control step's arithmetic. A flow followed by a test (`{t' = 1 & t <= eps}; ?t = eps`) stays a
flow: its longer runs may pass the test where the run of duration 0 does not. A check that is
not proved leaves the proof standing: this can only add a warning, never take one away."""

from __future__ import annotations

from dataclasses import replace

from certiloop.models.lang.printing import show
from certiloop.models.lang.programs import ODE, Choice, Loop, Program, Seq, Test, children, seq
from certiloop.models.lang.terms import FALSE, MODALITIES, ModelError, Node, Not
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vcgen import TooManyObligations, generate
from certiloop.proofs.engine.budget import Budget
from certiloop.proofs.engine.discharge import discharge_one

# a share of the proof's budget for each obligation of the checks: a check not proved with it
# leaves the proof standing, and sbs.ctrl2's blocked-step claim, unknown either way, cost 2.5 s
# at an eighth
SHARE = 64
MAX_OBLIGATIONS = 400


def first_step(program: Program) -> Program | None:
    """What runs up to the end of the first iteration of the program's first loop, or the whole
    program when it has no loop at its top level; None when the program starts with nothing
    but a loop whose first iteration is the same as the program (no prefix to add)."""
    parts = program.parts if isinstance(program, Seq) else (program,)
    for k, part in enumerate(parts):
        if isinstance(part, Loop):
            prefix = parts[:k]
            return seq(*prefix, part.body) if prefix else part.body
    return program


def zero_duration(program: Program, blocks_after: bool = False) -> Program:
    """The program with every flow that nothing after it can block (`blocks_after`: what runs
    after `program` may) replaced by the test of its domain (its run of duration 0)."""
    if isinstance(program, ODE):
        return program if blocks_after else Test(program.domain)
    if isinstance(program, Seq):
        parts, after = [], blocks_after
        for part in reversed(program.parts):
            parts.append(zero_duration(part, after))
            after = after or may_block(part)
        return replace(program, parts=tuple(reversed(parts)))
    if isinstance(program, Loop):  # an iteration is followed by the next one
        return replace(program, body=zero_duration(program.body, blocks_after or may_block(program.body)))
    if isinstance(program, Choice):
        alternatives = tuple(zero_duration(a, blocks_after) for a in program.alternatives)
        return replace(program, alternatives=alternatives)
    return program


def may_block(program: Program) -> bool:
    """Can a run of the program stop short from some state: it holds a test, or a flow with an
    evolution domain (over-approximated: a test inside a loop counts too)."""
    stack = [program]
    while stack:
        p = stack.pop()
        if isinstance(p, Test) or (isinstance(p, ODE) and p.domain.op != "true"):
            return True
        stack.extend(children(p))
    return False


def has_modality(f: Node) -> bool:
    return f.op in MODALITIES or any(has_modality(a) for a in f.args)


def vacuity(theorem: Theorem, budget: Budget) -> str:
    """Why a proof of `theorem` is vacuous, or "" when neither check proves it is (a function of
    the theorem and the budget alone, so the prover may run it on a worker beside the proof)."""
    budget = budget.share(SHARE)
    if not has_modality(theorem.assumptions):  # a modality is the rules' to expand, not z3's
        try:
            answer = check_valid(Not(theorem.assumptions), budget.rlimit)
        except (TypeError, ValueError, ModelError):  # a form z3 is not given: no verdict either way
            answer = None
        if answer is not None and answer.status == "unsat":
            return f"the assumptions are unsatisfiable: no state meets {show(theorem.assumptions)}"
    step = first_step(theorem.program)
    if step is None:
        return ""
    blocked = replace(theorem, name=f"{theorem.name} (vacuity)", program=zero_duration(step), guarantee=FALSE,
                      expected="proved", check_nonblocking=False)
    try:
        obligations = generate(blocked, limit=MAX_OBLIGATIONS)
    except (TooManyObligations, ModelError):  # a step the rules cannot split: no verdict either way
        return ""
    # the guarantee's obligation (`false`) comes last and is the one a run refutes: try it first
    if obligations and all(discharge_one(ob, budget).verdict == "proved" for ob in obligations[::-1]):
        return ("no run gets through the first control step: every branch's tests fail for every "
                "state the assumptions allow")
    return ""
