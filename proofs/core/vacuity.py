"""Vacuity: a proof of [ctrl*]safe says nothing if the control step can block, so prove
that from every state the step can start in, it has at least one run.

The step is cut at its `foreach` loops into loop-free segments and loop bodies:

  * a segment S entered with facts F:     F -> <S> true
  * a foreach body B (after the pick of an unprocessed element i) entered with facts F:
        F ∧ J ∧ ¬done(i) ∧ member(i) -> <B> true

where J is the loop's invariant. The facts at a foreach's head are J (the safety proof
shows it holds there) and the conjuncts of the earlier facts whose symbols nothing since
has written; after the loop they add ∀j (member(j) -> done(j)). That a foreach always has a
finishing run is a lemma about its shape, not an obligation: its prefix `done := *; ?∀j
¬done(j)` has the all-false family as a run; each iteration has a run from every head
state (the body obligation above) and marks one more of the finitely many elements done,
without changing which are members; so after |family| iterations every member is done and
the exit test holds. The verdict is therefore conditional on the safety proof, as it must
be: unreachable states may block.

Existentials from x := * are eliminated where a test pins x by a linear equation (u*D = d0
is solvable when D ≠ 0, and then every solution must lead on): see `witnessed`. ∃
distributes over the branches of a choice, so each branch is treated on its own.
"""

from __future__ import annotations

import sympy

from certiloop.models.lang.programs import Havoc, Loop, Program, Seq, Test, seq, written
from certiloop.models.lang.terms import TRUE, And, Exists, Implies, Node, Not, Or, cmp, free_vars, rebuild
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy
from certiloop.proofs.core.vcgen import Names, Obligation
from certiloop.proofs.core.wp import diamond, expand_modalities

LABEL = "control step has a run"


def nonblocking_obligations(theorem: Theorem) -> list[Obligation]:
    """The obligations whose validity shows the theorem's loop body never blocks (given
    the safety proof); empty if the program is not a loop."""
    program = theorem.program
    if not isinstance(program, Loop):
        return []
    names = Names()
    stable = [c for c in _conjuncts(expand_modalities(theorem.assumptions, names))
              if not set(free_vars(c)) & set(written(program))]
    facts = stable + _conjuncts(program.invariant if program.invariant is not None else theorem.guarantee)
    out: list[Obligation] = []

    def emit(path: str, hyps: list[Node], prog: Program) -> None:
        runs = diamond(prog, TRUE, names, unsolvable="stay", family_witnesses=True)
        goal = witnessed(read_over_write(runs))
        out.append(Obligation(f"v{len(out) + 1}", f"{LABEL} / {path}", Implies(And(*hyps), goal),
                              theorem.name, theorem.abbreviations))

    parts = list(program.body.parts) if isinstance(program.body, Seq) else [program.body]
    segment: list[Program] = []
    exit_tests: set[int] = set()  # a foreach's exit test holds after it: no obligation
    for k, part in enumerate(parts):
        if k in exit_tests:
            continue
        if not isinstance(part, Loop):
            segment.append(part)
            continue
        if part.each is None or not _foreach_prefix(segment, part):
            return []  # a loop that is not a foreach: no argument that it can finish
        segment = segment[:-2]  # done := *; ?∀¬done: the all-false family is its run
        if segment:
            emit(_describe(segment), facts, seq(*segment))
        changed = set(written(seq(*segment, part)))
        invariant = part.invariant if part.invariant is not None else TRUE
        head = [c for c in facts if not set(free_vars(c)) & changed] + _conjuncts(invariant)
        pick, body = part.body.parts[:2], seq(*part.body.parts[2:])
        if not (isinstance(pick[0], Havoc) and isinstance(pick[1], Test)):
            raise ValueError("foreach loop body without its pick")
        each = part.each
        emit(f"{part.label} body", head + [Not(each.done(each.index)), each.member], body)
        facts = head + [_exit_test(parts, k)]
        exit_tests.add(k + 1)
        segment = []
    if segment:
        emit(_describe(segment), facts, seq(*segment))
    return out


def _foreach_prefix(segment: list[Program], loop: Loop) -> bool:
    return (len(segment) >= 2 and isinstance(segment[-2], Havoc) and isinstance(segment[-1], Test)
            and segment[-2].target.same(loop.each.done))


def _exit_test(parts: list[Program], k: int) -> Node:
    exit_test = parts[k + 1] if k + 1 < len(parts) else None
    if not isinstance(exit_test, Test):
        raise ValueError("foreach loop without its exit test")
    return exit_test.cond


def _describe(segment: list[Program]) -> str:
    text = str(seq(*segment)).split("\n")[0].strip().rstrip(";")
    return f"statements from `{text}`" if len(segment) > 1 else f"`{text}`"


def _conjuncts(f: Node) -> list[Node]:
    if f.op == "and":
        return [c for a in f.args for c in _conjuncts(a)]
    return [] if f.op == "true" else [f]


# --------------------------------------------------------------------------- witnesses


def read_over_write(f: Node) -> Node:
    """a{i := v}[i] -> v (same index written and read), so that u{i := u@3}[i]*D = d0 is
    seen as the linear equation u@3*D = d0 it is."""
    if not f.args:
        return f
    f = rebuild(f, tuple(read_over_write(a) for a in f.args))
    if f.op == "select" and f.args[0].op == "store":
        stored = f.args[0].args
        read, written_at = f.args[1:], stored[1:-1]
        if len(read) == len(written_at) and all(a.same(b) for a, b in zip(read, written_at)):
            return stored[-1]
    return f


def witnessed(f: Node) -> Node:
    """A quantifier-lighter formula that implies f: ∃x (a·x + b = 0 ∧ ψ), with a free of x,
    becomes  a ≠ 0 ∧ (a·x + b = 0 -> ψ)  with x left free. That is sound because x is a
    fresh symbol in positive position (free symbols of an obligation are universally
    quantified, and ∀x distributes over ∧, ∨ and the right of ->), and a ≠ 0 makes the
    equation solvable. No division appears, so the arithmetic stays polynomial."""
    if f.op == "exists":
        return _exists(list(f.payload), witnessed(f.args[0]))
    if f.op in ("and", "or"):
        return (And if f.op == "and" else Or)(*(witnessed(a) for a in f.args))
    return f


def _exists(variables: list[Node], body: Node) -> Node:
    if body.op == "or":  # ∃x (a ∨ b)  ≡  ∃x a ∨ ∃x b
        return Or(*(_exists(variables, d) for d in body.args))
    left = []
    for x in variables:
        if x.payload not in free_vars(body):
            continue
        slope = _linear_slope(x, body)
        if slope is None:
            left.append(x)
        else:
            a, equation = slope
            body = And(cmp("!=", a, 0), Implies(equation, body))
    return Exists(left, body) if left else body


def _linear_slope(x: Node, body: Node) -> tuple[Node, Node] | None:
    """(a, the equation) for a conjunct equation a·x + b = 0 with a free of x."""
    if x.sort.is_array:
        return None
    for c in _conjuncts(body):
        if c.op == "cmp" and c.payload == "==" and x.payload in free_vars(c):
            table = SympyTable()
            expr = sympy.expand(to_sympy(c.args[0], table) - to_sympy(c.args[1], table))
            xs = table.symbol(x)
            if sympy.degree(expr, xs) == 1:
                slope = expr.coeff(xs, 1)
                if xs not in slope.free_symbols:
                    return from_sympy(slope, table), c
    return None
