"""Refutation by proof: a state at which the claim's negation is proved.

Some claims are false for a reason no single run shows: a diamond (`<{x'=a, y'=b}>x=y`: no
run reaches the goal), a modality or a real quantifier inside a formula
(`[{x'=1}]x'=1 -> x'=1`, `\\forall x [x:=0]x>=0 -> [x:=0]\\forall x x>=0`). The run-based
refuter cannot replay those, since what makes a state a counterexample is a fact about every
run or every value. For such a claim a candidate state s (the model of a failed obligation)
is confirmed by *proving*, with the obligations and solvers of any other theorem, that

    x = s(x) for every symbol x of the claim   ->   not claim

Soundness: that theorem's `proved` is as trustworthy as any other, and instantiated at s it
says the claim is false at s. Where the candidate came from does not matter.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from certiloop.models.lang.programs import Loop, Program, Test, children, skip
from certiloop.models.lang.terms import (
    BOOL,
    INT,
    And,
    Box,
    Diamond,
    Exists,
    ForAll,
    Implies,
    ModelError,
    Node,
    Not,
    Or,
    cmp,
    const,
    free_vars,
)
from certiloop.models.lang.theorem import Theorem

FLIPPED = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "==": "!=", "!=": "=="}
MAX_CANDIDATES = 3  # distinct states tried, each a whole proof attempt
MAX_SMALL = 6  # small states tried when there is no solver model


def claim(theorem: Theorem) -> Node:
    """The theorem as one formula: assumptions -> [program] guarantee."""
    program = theorem.program
    if isinstance(program, Test) and program.cond.op == "true":
        return Implies(theorem.assumptions, theorem.guarantee)
    return Implies(theorem.assumptions, Box(program, theorem.guarantee))


def negate(f: Node) -> Node:
    """not f with the negation pushed inwards through connectives, modalities and
    quantifiers (so that a negated diamond becomes a box the ODE rules apply to)."""
    if f.op == "not":
        return f.args[0]
    if f.op == "cmp" and f.payload in FLIPPED and f.args[0].sort != BOOL:
        return cmp(FLIPPED[f.payload], *f.args)
    if f.op == "implies":
        return And(f.args[0], negate(f.args[1]))
    if f.op == "and":
        return Or(*(negate(a) for a in f.args))
    if f.op == "or":
        return And(*(negate(a) for a in f.args))
    if f.op == "box":
        return Diamond(f.payload, negate(f.args[0]))
    if f.op == "diamond":
        return Box(f.payload, negate(f.args[0]))
    if f.op == "forall":
        return Exists(f.payload, negate(f.args[0]))
    if f.op == "exists":
        return ForAll(f.payload, negate(f.args[0]))
    return Not(f)


def _value(sym: Node, raw: Any) -> Any:
    """The candidate's value for `sym` as an exact constant, or None if it has none."""
    if sym.sort == BOOL:
        return raw if isinstance(raw, bool) else None
    if isinstance(raw, bool) or sym.sort.is_array or not sym.sort.is_numeric:
        return None
    try:
        value = Fraction(raw) if not isinstance(raw, str) else Fraction(raw.strip())
    except (TypeError, ValueError, ZeroDivisionError):
        return None
    if sym.sort == INT and value.denominator != 1:
        return None
    return value


def filled(theorem: Theorem, state: dict[str, Any]) -> dict[str, Any] | None:
    """The candidate's exact value for every symbol of the claim (0 or false where it has
    none), or None when one is not an exact number (an algebraic value, an array, an index)."""
    out = {}
    for name, sym in sorted(free_vars(claim(theorem)).items()):
        value = _value(sym, state.get(name, False if sym.sort == BOOL else 0))
        if value is None:
            return None
        out[name] = value
    return out


def pinned(theorem: Theorem, state: dict[str, Any]) -> Node:
    """x = s(x) for every symbol of the claim, s a `filled` state."""
    symbols = free_vars(claim(theorem))
    return And(*(symbols[n] if v is True else Not(symbols[n]) if v is False
                 else cmp("==", symbols[n], const(v)) for n, v in state.items()))


def negation_at(theorem: Theorem, state: dict[str, Any]) -> list[Theorem]:
    """Theorems that together say `x = s(x) ... -> not claim` for a `filled` state s: the
    pinned state meets the assumptions, and from it the negated rest holds, split like a .kyx
    Problem (a leading box becomes the program, so the ODE rules and invariant search apply)."""
    from certiloop.models.kyx.reader import split_problem

    pin = pinned(theorem, state)
    rest = claim(theorem)
    premise = rest.args[0] if rest.op == "implies" else None
    body = rest.args[1] if rest.op == "implies" else rest
    out = []
    if premise is not None:
        out.append(Theorem(name=f"{theorem.name} (the state meets the assumptions)", assumptions=pin,
                           program=skip(), guarantee=premise, expected="proved", unroll=1))
        pin = And(pin, premise)
    negated = negate(body)
    if _large_diamond_loop(negated):
        # a box loop's negation is a diamond, proved by a few unrolled iterations: for a small
        # loop that is cheap and finds states the run search's samples miss (2 of the
        # soundness suite's false loop claims); nested or large loops' unrollings multiply
        # (IJRR17's Theorem 9: 55 s, Theorem 5: 3 s -> 16 s), so those are left to the search
        raise ModelError("the negation holds a large loop inside a diamond: left to the run search")
    assumptions, program, guarantee = split_problem(Implies(pin, negated))
    # the claim's side conditions come along: a lifted root's (kyx/lifting.py) makes the lifted
    # flow's runs the original's, without which its box has fewer runs and its negation
    # would be proved where the claim is true (`x = 0 -> <{x' = sqrt(x^2) + 1}> x >= 1`)
    out.append(Theorem(name=f"{theorem.name} (negation at a state)", assumptions=assumptions, program=program,
                       guarantee=guarantee, expected="proved", unroll=1, well_defined=theorem.well_defined,
                       defined_if=theorem.defined_if))
    return out


SMALL_LOOP = 8  # statements in a loop's body for its negation to be tried unrolled


def _large_diamond_loop(f: Node) -> bool:
    if f.op == "diamond" and _large_loop(f.payload, inside=False):
        return True
    return any(_large_diamond_loop(a) for a in f.args)


def _large_loop(p: Program, inside: bool) -> bool:
    if isinstance(p, Loop):
        return inside or _statements(p.body) > SMALL_LOOP or _large_loop(p.body, True)
    return any(_large_loop(q, inside) for q in children(p))


def _statements(p: Program) -> int:
    parts = children(p)
    return sum(_statements(q) for q in parts) if parts else 1


def candidates(theorem: Theorem, models: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Distinct `filled` candidate states from solver models (their other symbols dropped)."""
    out: list[dict[str, Any]] = []
    for model in models:
        state = filled(theorem, model)
        if state is not None and state not in out:
            out.append(state)
    return out[:MAX_CANDIDATES]


def small_states(theorem: Theorem) -> list[dict[str, Any]]:
    """Candidates when no solver model is at hand: the values the assumptions fix (`y = 2`),
    the other symbols all 0, 1 or -1, then one of them at 1 or -1 and the rest 0; MAX_SMALL
    in all."""
    names = sorted(n for n, sym in free_vars(claim(theorem)).items() if sym.sort != BOOL)
    fixed = _fixed_by_assumptions(theorem)
    names = [n for n in names if n not in fixed]
    tries = [{n: v for n in names} for v in (0, 1, -1)]
    tries += [{**{n: 0 for n in names}, one: v} for one in names for v in (1, -1)]
    out: list[dict[str, Any]] = []
    for state in tries:
        state = filled(theorem, {**state, **fixed})
        if state is not None and state not in out:
            out.append(state)
    return out[:MAX_SMALL]


def _fixed_by_assumptions(theorem: Theorem) -> dict[str, Fraction]:
    """symbol -> c for every conjunct `symbol = c` (c a number) of the assumptions."""
    parts = theorem.assumptions.args if theorem.assumptions.op == "and" else (theorem.assumptions,)
    out = {}
    for part in parts:
        if part.op == "cmp" and part.payload == "==":
            a, b = part.args
            if a.op == "var" and b.op == "const":
                out[a.payload] = Fraction(b.payload)
            elif b.op == "var" and a.op == "const":
                out[b.payload] = Fraction(a.payload)
    return out
