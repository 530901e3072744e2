"""Refutation: find a real run that violates the guarantee.

A failed induction step only says an invariant is not inductive; it does not make a
design unsafe. So a theorem is `refuted` only by a *run*: the loops are unrolled to at
most `depth` iterations and the exact [a]P of that loop-free program is checked (ODEs by
their polynomial solution with the domain held along the whole flow; ODEs without one are
left out, which only removes runs). A model of the negation is an initial state satisfying
the assumptions plus the nondeterministic choices and durations of a violating run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Havoc,
    Program,
    Seq,
    Test,
    program_symbols,
    seq,
    test,
)
from certiloop.models.lang.terms import BOOL, TRUE, And, Implies, Var, free_vars, substitute
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.exact import Undecided, evaluate, index_value, truth
from certiloop.proofs.core.interval import show_value
from certiloop.proofs.core.odes import runs_along
from certiloop.proofs.core.solver import ArrayValue, check_valid
from certiloop.proofs.core.vcgen import Names, executed
from certiloop.proofs.core.verdicts import exactness, judge, readable
from certiloop.proofs.core.wp import expand_modalities, flow_solution, unroll
from certiloop.proofs.engine.budget import Budget
from certiloop.proofs.refute.bmc import Encoder
from certiloop.proofs.refute.finite import model_back, over_family
from certiloop.proofs.refute.initial_reads import read_first


@dataclass
class Step:
    """One statement of the violating run that matters to a reader."""

    path: str  # the choices taken so far, e.g. "ctrl1 loop iteration 1 / past boundary, towards"
    what: str  # "fyp := -1", "ODE for 1 s"
    state: dict[str, str]  # the theorem's symbols after the statement
    # for an independent replay (falsify.replay): what was decided here, with the raw value
    kind: str = "assign"  # assign | havoc | ode | choice
    target: str = ""  # the assigned symbol or cell, or the choice's label
    value: Any = None  # havoc: the value chosen; ode: the duration

    def to_json(self) -> dict[str, Any]:
        return {"path": self.path, "what": self.what, "state": self.state}


@dataclass
class Refutation:
    depth: int  # loop iterations of the violating run
    initial: dict[str, str]  # the theorem's symbols at the start
    trace: list[Step]
    violated: str  # the guarantee and its value at the end
    check: str
    seconds: float
    raw_initial: dict[str, Any] = field(default_factory=dict)  # exact values, for replays
    # the theorem's index-free abbreviations at the start (e.g. n1·n2 for two planes)
    frame: dict[str, str] = field(default_factory=dict)

    @property
    def shown(self) -> list[Step]:
        """The steps a reader wants (choices are visible in the paths)."""
        return [s for s in self.trace if s.kind != "choice"]

    def _repr_html_(self) -> str:
        """Notebook display: the run as `certiloop prove` prints it."""
        from html import escape

        from certiloop.proofs.engine.display import run_lines

        return "<pre>" + escape("\n".join(run_lines(self.to_json()))) + "</pre>"

    def to_json(self) -> dict[str, Any]:
        return {"depth": self.depth, "initial": self.initial,
                "frame": self.frame, "trace": [s.to_json() for s in self.shown], "violated": self.violated,
                "check": self.check, "seconds": round(self.seconds, 4)}


# a small-family attempt finds a run cheaply or not at all: half a run search's budget
# (sbs.ctrl2_dynamic_join_anywhere's depth-1 run needs about 5M units)
FAMILY_SHARE = 2


def refute(theorem: Theorem, budget: Budget) -> tuple[Refutation | None, str]:
    """(refutation, "") if a violating run was found and re-checked, else (None, why not).
    Every attempt has a deterministic z3 budget, so the outcome does not depend on load."""
    if executed(theorem.guarantee):
        return None, ("no run is searched for a guarantee that holds a loop, or a flow without a "
                      "polynomial solution, inside a formula")
    start = time.perf_counter()
    budget = budget.for_runs()
    why = f"no violating run with at most {theorem.unroll} loop iterations"
    family_sort = index_sort(theorem)
    depths = range(1, theorem.unroll + 1)
    scenarios = (*theorem.scenarios, None)
    # cheap shortcuts first (the most restricted scenario, small concrete families, at every
    # depth), the general search last
    attempts = [(d, s, m) for s in scenarios for d in depths for m in range(d, 0, -1)] if family_sort else []
    attempts += [(d, s, None) for d in depths for s in scenarios]
    for depth, scenario, size in attempts:
        names = Names()
        pre = expand_modalities(And(theorem.assumptions, scenario if scenario is not None else TRUE), names)
        post = expand_modalities(theorem.guarantee, names)
        program = unroll(theorem.program, depth)
        encoder = Encoder(names)
        run, final = encoder.run(program, {})
        claim = Implies(And(pre, *run), substitute(post, final))
        record = encoder.record
        shortcut = scenario is not None or size is not None
        share = budget.share(FAMILY_SHARE) if size is not None else budget
        if size is not None:
            model = search_family(claim, family_sort, size, share)
            if model is None:
                continue
        else:
            answer = check_valid(claim, share.rlimit, share.wall_s)
            if answer.status == "unknown":
                if shortcut:
                    continue
                return None, f"refutation search at depth {depth}: {answer.reason}"
            if answer.status == "unsat":
                continue
            verdict = judge("run", "", claim, answer, 0.0)
            if verdict.verdict != "refuted":
                if shortcut:
                    continue
                return None, f"run at depth {depth} did not re-check: {verdict.reason}"
            model = answer.model or {}
        check = "exact rationals" if exactness(model) == "exact rationals" else exactness(model)
        initial = {k: v for k, v in model.items() if "@" not in k}
        replay = Replay(model, record, pre, post)
        try:
            trace = replay.run(program, initial)
        except Undecided as exc:
            trace, reason = None, str(exc)
        else:
            reason = "no choice of branches reproduces it"
        if trace is None:  # re-checked, yet not reconstructed exactly (e.g. algebraic values on an edge)
            why = f"a run at depth {depth} re-checked, but its steps could not be reconstructed: {reason}"
            continue
        # the model may hold live z3 handles (array lookups): keep only plain text
        return Refutation(depth, replay.start, trace, f"{theorem.guarantee} is false at the end",
                          check, time.perf_counter() - start, replay.raw_start,
                          _frame(theorem, {k: replay.raw_start[k] for k in replay.start})), ""
    return None, why


def _frame(theorem: Theorem, start: dict[str, Any]) -> dict[str, str]:
    """Index-free abbreviations evaluated on the start state (`n1n2 = nx1*nx2 + ny1*ny2`)."""
    out = {}
    for name, definition in theorem.abbreviations.items():
        if set(free_vars(definition)) <= set(start):
            out[f"{name.rstrip('_')} = {definition}"] = show_value(evaluate(definition, start))
    return out


def index_sort(theorem: Theorem) -> str | None:
    for sym in {**program_symbols(theorem.program), **free_vars(theorem.guarantee)}.values():
        sort = sym.sort.domain[0] if sym.sort.is_array else sym.sort
        if not sort.is_numeric and sort != BOOL and not sort.is_array:
            return sort.name
    return None


def search_family(claim, sort_name: str, size: int, budget: Budget) -> dict[str, Any] | None:
    """A state over a family of `size` elements that falsifies the claim, checked exactly
    on the original (quantified) claim, or None."""
    found = over_family(claim, sort_name, size)
    if found is None:
        return None
    lowered, reads = found
    answer = check_valid(lowered, budget.rlimit, budget.wall_s)
    if answer.status != "sat":
        return None
    state = model_back(answer.model or {}, reads, claim, sort_name, size)
    return state if truth(claim, state) is False else None


class Replay:
    """Re-run the unrolled program on the solver's initial state and choices, exactly
    (rationals, or rational intervals for algebraic numbers), to recover the run that
    violates the guarantee. Choices are resolved by depth-first search; a test that fails
    (or cannot be decided) closes that branch."""

    def __init__(self, model: dict[str, Any], record: dict[int, str], pre, post) -> None:
        self.model, self.record, self.pre, self.post = model, record, pre, post
        self.start: dict[str, str] = {}

    def run(self, program: Program, state: dict[str, Any]) -> list[Step] | None:
        # Symbols absent from the solver's formula cannot affect the violation, nor can
        # those the run writes before reading (z3 picks arbitrary start values for them,
        # which would only confuse a reader): any value will do, and 0 is z3's default.
        needed = read_first(seq(test(self.pre), program, test(self.post)))
        state = {k: v for k, v in state.items() if k in needed or k.startswith("#")}
        self.start = self._show(state)
        for name, sym in program_symbols(program).items():
            state.setdefault(name, _zero(sym.sort))
        self.raw_start = {k: plain(v) for k, v in state.items() if "@" not in k}
        return self._exec(program, state, (), [], self._at_end)

    def _at_end(self, state, path, steps):
        return steps if truth(self.post, state) is False else None

    def _show(self, state) -> dict[str, str]:
        return readable({k: v for k, v in state.items() if "@" not in k and not k.startswith("#")})

    def _exec(self, p: Program, state, path, steps, k):
        if isinstance(p, Assign):
            new = _assign(state, p.target, evaluate(p.value, state))
            step = Step(" / ".join(path), f"{p.target} := {p.value}", self._show(new),
                        "assign", str(p.target))
            return k(new, path, steps + [step])
        if isinstance(p, Havoc):
            # a choice absent from the solver's formula cannot matter; 0 stands in for it
            value = self.model.get(self.record.get(id(p), ""), _zero(p.target.sort))
            new = _assign(state, p.target, value)
            step = Step(" / ".join(path), f"{p.target} := {show_value(value)}", self._show(new),
                        "havoc", str(p.target), plain(value))
            return k(new, path, steps + [step])
        if isinstance(p, Test):
            return k(state, path, steps) if truth(p.cond, state) is True else None
        if isinstance(p, Seq):
            return self._seq(p.parts, state, path, steps, k)
        if isinstance(p, Choice):
            for label, alt in zip(p.labels, p.alternatives):
                # the label scopes the branch only; what follows the choice is back at `path`
                taken = Step(" / ".join(path + (label,)), f"choose {label}", {}, "choice", label)
                found = self._exec(alt, state, path + (label,), steps + [taken],
                                   lambda st, _pa, sp: k(st, path, sp))
                if found is not None:
                    return found
            return None
        if isinstance(p, ODE):
            name = self.record.get(id(p))
            if name is None:  # an ODE the refuter left out: no runs through it
                return None
            s, sol = flow_solution(p)
            tau = Var(name)
            duration = self.model.get(name, Fraction(0))
            env = dict(state, **{name: duration})
            if truth(runs_along(p, sol, tau, s), env) is not True:
                return None
            new = dict(state)
            for var, x in sol.items():
                new[var] = evaluate(substitute(x, {s.payload: tau}), env)
            step = Step(" / ".join(path), f"follow the ODE for {show_value(duration)} s", self._show(new),
                        "ode", "", plain(duration))
            return k(new, path, steps + [step])
        raise TypeError(p)

    def _seq(self, parts, state, path, steps, k):
        if not parts:
            return k(state, path, steps)
        return self._exec(parts[0], state, path, steps,
                          lambda st, pa, sp: self._seq(parts[1:], st, pa, sp, k))


def plain(value: Any) -> Any:
    """A value without live solver handles (so it can cross processes)."""
    if isinstance(value, ArrayValue):
        return ArrayValue(dict(value.entries), value.default)
    return value


def _zero(sort) -> Any:
    if sort.is_array:
        return ArrayValue({}, _zero(sort.range))
    return False if sort == BOOL else Fraction(0)


def _assign(state: dict[str, Any], target, value) -> dict[str, Any]:
    new = dict(state)
    if target.op == "var":
        new[target.payload] = value
        return new
    idx: list = []
    root = target
    while root.op == "select":
        idx[:0] = root.args[1:]
        root = root.args[0]
    arr = state.get(root.payload)
    if not isinstance(arr, ArrayValue):
        arr = ArrayValue({}, None)
    entries = dict(arr.entries)
    entries[tuple(index_value(evaluate(i, state)) for i in idx)] = value
    new[root.payload] = ArrayValue(entries, arr.default)
    return new
