"""Replay a prover counterexample in the interpreter: the independent check of `refuted`.

The prover's refutation is a run of the loop-unrolled program found by z3 and re-checked
by its own exact evaluator. Here the *interpreter* — different code: compiled closures,
open values, real loops — runs the model from the same initial state, taking the same
alternatives, nondeterministic values and ODE durations, and must see the guarantee
violated. Exact rationals where the counterexample is rational; where z3 chose algebraic
numbers (a unit normal (1/2, -√3/2)) the replay runs in floating point and the violation
must exceed the search's tolerance.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from certiloop.falsify.choosers import Chooser, Diverged
from certiloop.falsify.depth import FLOAT_TOLERANCE
from certiloop.falsify.evaluate import Blocked, Table
from certiloop.falsify.flows import Inexact, confirm_numerically
from certiloop.falsify.interpreter import Interpreter, Rejected, Run
from certiloop.models.lang.programs import Loop, children
from certiloop.models.lang.theorem import Theorem


@dataclass
class ReplayOutcome:
    violated: bool
    message: str  # what happened, for the CLI
    run: Run | None = None
    flows_confirmed: bool = False  # every closed-form flow agrees with a numerical integration

    def to_json(self) -> dict[str, Any]:
        return {"violated": self.violated, "message": self.message, "flows_confirmed": self.flows_confirmed}


def replay_refutation(theorem: Theorem, refutation) -> ReplayOutcome:
    """Replay, then confirm the run's closed-form flows numerically."""
    outcome = _replay(theorem, refutation)
    if not outcome.violated or outcome.run is None:
        return outcome
    flows = outcome.run.closed_form_flows
    for ode, before, tau, after in flows:
        disagreement = confirm_numerically(ode, before, tau, after)
        if disagreement:
            return ReplayOutcome(True, f"{outcome.message}; but a flow on it does not check: {disagreement}",
                                 outcome.run, flows_confirmed=False)
    checked = f"; {len(flows)} flow(s) confirmed by numerical integration" if flows else ""
    return ReplayOutcome(True, outcome.message + checked, outcome.run, flows_confirmed=True)


def _replay(theorem: Theorem, refutation) -> ReplayOutcome:
    values = Values(refutation.raw_initial)
    try:
        initial = values.state()
        exact = values.all_rational
        chooser = TraceChooser(refutation.trace, values, _loop_labels(theorem.program))
        interp = Interpreter(theorem, exact=exact, max_steps=max(1, chooser.outer_steps(theorem)))
        # the prover checked the assumptions exactly; in floating point an algebraic state
        # on an edge (n·n = 1, a bound met with equality) may miss it by rounding
        run = interp.run(chooser, initial, checked=not exact)
    except (Diverged, Rejected, Blocked, Inexact, KeyError, ValueError) as exc:
        return ReplayOutcome(False, f"the counterexample does not replay in the interpreter: {exc}")
    if run.violated is None:
        return ReplayOutcome(False, "the counterexample replays but does not violate the guarantee "
                             "in the interpreter", run)
    if values.all_rational:
        return ReplayOutcome(True, f"replayed in the interpreter (exact): {run.violated}", run)
    worst = min(run.checkpoints[-1].margins.values(), default=0.0)
    if worst < -FLOAT_TOLERANCE * max(1.0, values.scale):
        return ReplayOutcome(True, f"replayed in the interpreter (floating point): {run.violated}", run)
    return ReplayOutcome(False, f"the floating-point replay violates the guarantee only by {-worst:.3g}, "
                         "within rounding", run)


def replay_witness(theorem: Theorem, witness) -> ReplayOutcome:
    """Replay a vacuity witness run: the interpreter must take every decision of it and
    reach its end. `violated` here means: the run replayed to the end."""
    values = Values(witness.raw_initial)
    try:
        initial = values.state()
        chooser = TraceChooser(witness.trace, values, _loop_labels(theorem.program))
        steps = max(1, chooser.outer_steps(theorem))
        interp = Interpreter(theorem, exact=values.all_rational, max_steps=steps)
        run = interp.run(chooser, initial, checked=not values.all_rational)
    except (Diverged, Rejected, Blocked, Inexact, KeyError, ValueError) as exc:
        return ReplayOutcome(False, f"the witness run does not replay in the interpreter: {exc}")
    if chooser.at < len(chooser.events):
        return ReplayOutcome(False, "the interpreter stopped before the end of the witness run", run)
    how = "exact" if values.all_rational else "floating point"
    return ReplayOutcome(True, f"a witness run from {_shown(witness.initial)} replays in the interpreter "
                         f"({how}, {len(witness.shown)} statements)", run)


def _shown(initial: dict[str, str]) -> str:
    text = ", ".join(f"{k} = {v}" for k, v in list(initial.items())[:6])
    return text + (", ..." if len(initial) > 6 else "") if text else "any state"


def _loop_labels(p) -> set[str]:
    out = {p.label} if isinstance(p, Loop) else set()
    for q in children(p):
        out |= _loop_labels(q)
    return out


class Values:
    """The prover's values converted for the interpreter: index elements (B!1) become
    0, 1, ...; arrays become tables; algebraic numbers floats."""

    def __init__(self, raw: dict[str, Any]) -> None:
        self.raw = raw
        self.elements: dict[str, dict[str, int]] = {}
        for name, value in raw.items():
            if name.startswith("#universe:"):
                self.elements[name.split(":", 1)[1]] = {str(e): k for k, e in enumerate(value)}
        self.all_rational = True
        self.scale = 1.0

    def element(self, x: Any) -> Any:
        if isinstance(x, str):
            sort = x.split("!", 1)[0]
            table = self.elements.setdefault(sort, {})
            return table.setdefault(x, len(table))
        return x

    def convert(self, value: Any) -> Any:
        from certiloop.proofs.core.interval import Interval
        from certiloop.proofs.core.solver import ArrayValue

        if isinstance(value, ArrayValue):
            cells = {tuple(self.element(i) for i in k): self.convert(v) for k, v in value.entries.items()}
            default = self.convert(value.default) if value.default is not None else None
            return Table(cells, default)
        if isinstance(value, bool):
            return value
        if isinstance(value, (int, Fraction)):
            self.scale = max(self.scale, abs(float(value)))
            return Fraction(value)
        if isinstance(value, Interval):
            self.all_rational = False
            mid = (Fraction(value.lo) + Fraction(value.hi)) / 2
            self.scale = max(self.scale, abs(float(mid)))
            return mid
        return self.element(value)

    def state(self) -> dict[str, Any]:
        out = {}
        for name, value in self.raw.items():
            if name.startswith("#universe:"):
                continue
            out[name] = self.convert(value)
        for sort, table in self.elements.items():
            out[f"#universe:{sort}"] = range(len(table))
        if not self.all_rational:
            out = {k: _to_float(v) for k, v in out.items()}
        return out

    def number(self, value: Any) -> Any:
        v = self.convert(value)
        return float(v) if not self.all_rational and isinstance(v, Fraction) else v


def _to_float(v: Any) -> Any:
    if isinstance(v, Fraction):
        return float(v)
    if isinstance(v, Table):
        return Table({k: _to_float(x) for k, x in v.cells.items()},
                     _to_float(v.default) if v.default is not None else None)
    return v


_ITERATION = re.compile(r"^(.*) (iteration \d+|ends)$")


class TraceChooser(Chooser):
    """Answers the interpreter's questions from the prover's run: the alternatives it took,
    the values of its nondeterministic assignments and its ODE durations, in order. Loop
    unrolling choices ("boundary loop iteration 2") are not decisions of the interpreter,
    whose loops run as loops."""

    def __init__(self, trace, values: Values, loop_labels: set[str]) -> None:
        self.values = values
        self.events = []
        self.iterations: dict[str, int] = {}
        for step in trace:
            if step.kind == "choice":
                m = _ITERATION.match(step.target)
                if m and m.group(1) in loop_labels:
                    if m.group(2) != "ends":
                        self.iterations[m.group(1)] = self.iterations.get(m.group(1), 0) + 1
                    continue
            if step.kind in ("choice", "havoc", "ode"):
                self.events.append(step)
        self.at = 0

    def outer_steps(self, theorem: Theorem) -> int:
        from certiloop.falsify.interpreter import outer_loop

        top = outer_loop(theorem.program)
        return self.iterations.get(top.label, 0) if top is not None else 0

    def _next(self, kind: str):
        if self.at >= len(self.events):
            raise Diverged(f"the interpreter needs a {kind} the prover's run does not have")
        step = self.events[self.at]
        if step.kind != kind:
            raise Diverged(f"the interpreter needs a {kind} where the prover's run has "
                           f"`{step.what}`")
        self.at += 1
        return step

    def pick_label(self, labels):
        step = self._next("choice")
        if step.target not in labels:
            raise Diverged(f"the prover took `{step.target}`, the interpreter is at a choice of {labels}")
        return labels.index(step.target)

    def havoc_value(self, target: str):
        step = self._next("havoc")
        if step.target != target:
            raise Diverged(f"the prover assigned `{step.target}`, the interpreter `{target}`")
        return self.values.number(step.value)

    def duration(self, longest):
        return self.values.number(self._next("ode").value)

    def integer(self, what: str, lo: int, hi: int) -> int:
        if what == "control steps":
            return hi
        raise Diverged(f"the interpreter needs a decision ({what}) the prover's run does not record")

    def real(self, what):  # a value the prover never constrained: any will do, 0 as in z3
        return 0.0

    def slack(self, strict):
        raise Diverged("no initial state is drawn in a replay")

    def fraction(self):
        raise Diverged("ODE durations come from the prover's run")

    def flag(self, what):
        if what == "iterate":
            return False
        return False
