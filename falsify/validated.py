"""Confirm a violating run through flows without a closed form, by validated numerics.

The run's recorded decisions are replayed with exact rationals, as in the exact replay,
except that a flow without a closed form (or one starting from an interval) is followed by
a validated enclosure (`enclosure.py`) and its end state becomes intervals
(`intervals.py`). Every test the replay passes then holds for every point of the boxes,
the evolution domain holds on every box the flow sweeps, and the guarantee counts as
violated only where it is false on the whole box. The true run (a real solution of each
ODE, from exact start values, for exact durations) is therefore a run of the program that
violates the guarantee. Anything undecided makes a test block or a checkpoint pass, so the
replay can fail to confirm a true violation, never confirm a false one.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from certiloop.falsify.choosers import Diverged, Scripted
from certiloop.falsify.enclosure import CannotEnclose, TaylorSystem, enclose
from certiloop.falsify.evaluate import Blocked, Table
from certiloop.falsify.flows import Flow, Inexact
from certiloop.falsify.interpreter import Interpreter, Rejected
from certiloop.falsify.intervals import IntervalValue, Uncertain
from certiloop.models.lang.programs import ODE
from certiloop.models.lang.theorem import Theorem


class EnclosingInterpreter(Interpreter):
    """The exact interpreter, with enclosures where a flow has no closed form."""

    def __init__(self, theorem: Theorem, max_steps: int, families: tuple[int, int]) -> None:
        super().__init__(theorem, exact=True, max_steps=max_steps, families=families)
        self._systems: dict[int, TaylorSystem] = {}
        self.steps = 0  # Taylor steps in all
        self.width = 0.0  # widest interval at the end of an enclosed flow
        self.enclosed = 0  # flows followed by enclosures
        self.why = ""  # why the last enclosure failed
        guarantee = self.guarantee

        def unless_certainly_false(s):  # undecided at a checkpoint: the run goes on, as the float run did
            try:
                return guarantee(s)
            except Uncertain:
                return True
        self.guarantee = unless_certainly_false

    def _ode(self, p: ODE, s: dict[str, Any]) -> None:
        flow = self._flows.get(id(p))
        if flow is None:
            flow = self._flows[id(p)] = Flow(p, self.c)
        if flow.solution is not None and not has_intervals(s):
            return super()._ode(p, s)  # exact, in closed form
        for f in (*flow.rhs, *(self.c(v) for v in p.variables)):
            self._value(f, s)
        if not self._holds(flow.domain_holds, s, p.domain):
            raise Blocked("evolution domain false")
        tau = Fraction(self.chooser.duration(lambda u: 0.0))
        try:
            system = self._system(p)
            params = [_iv(self._value(self.c(atom), s)) for atom in system.param_atoms]
            box = enclose(system, system.start([_iv(s[n]) for n in system.names], params), params, tau)
        except CannotEnclose as exc:
            self.why = str(exc)
            raise Uncertain(f"no enclosure of {p}: {exc}") from None
        trial = dict(s)
        # all along, on every swept box: the domain holds, and the right-hand side as written is
        # defined (the enclosed system is sympy's form of it, where x/x is 1 and a pole can vanish)
        for swept in box.path:
            trial.update({n: IntervalValue(x) for n, x in zip(system.names, swept)})
            try:
                inside = flow.along_holds(trial)
                for f in flow.rhs if inside else ():
                    f(trial)
            except (Blocked, ArithmeticError):  # Uncertain, a division by a box holding 0
                inside = False
            if not inside:
                self.why = (f"the evolution domain {p.domain} does not certainly hold along the enclosure, "
                            "or the right-hand side may divide by 0 there")
                raise Blocked(self.why)
        self.steps += box.steps
        self.width = max(self.width, box.width)
        self.enclosed += 1
        s.update({n: IntervalValue(x) for n, x in zip(system.names, box.end)})
        self.time = self.time + tau

    def _system(self, p: ODE) -> TaylorSystem:
        system = self._systems.get(id(p))
        if system is None:
            system = self._systems[id(p)] = TaylorSystem(p)
        return system


RETREATS = (20, 10)  # a run stopped at a domain's edge or near a blow-up is tried again with
# every flow 2^-20 (then 2^-10) of its duration shorter: float event times miss the edge by
# rounding, and an enclosure can decide nothing on it


def confirm_enclosed(theorem: Theorem, script, max_steps: int, families: tuple[int, int],
                     initial: dict[str, Any] | None = None, retreat: bool = False) -> tuple[str, str]:
    """(how the run was confirmed with interval enclosures, "") or ("", why it was not).
    With `retreat`, a run that fails is tried again with its flows slightly shorter (a
    different run, itself fully checked; the message says so)."""
    check, why = _confirm(theorem, script, max_steps, families, initial)
    for bits in RETREATS if retreat and not check else ():
        share = 1 - Fraction(1, 2**bits)
        shorter = [(k, Fraction(v) * share if k == "duration" else v) for k, v in script]
        check, _ = _confirm(theorem, shorter, max_steps, families, initial)
        if check:
            return f"{check}, on the run with every flow stopped 2^-{bits} of its duration earlier", ""
    return check, why


def _confirm(theorem: Theorem, script, max_steps: int, families: tuple[int, int],
             initial: dict[str, Any] | None) -> tuple[str, str]:
    interp = None
    try:
        interp = EnclosingInterpreter(theorem, max_steps, families)
        run = interp.run(Scripted(script), initial)
    except (Diverged, Inexact, Rejected, Blocked, CannotEnclose, ArithmeticError) as exc:
        return "", (interp.why if interp else "") or f"the replay stopped: {exc}"
    except Exception as exc:  # noqa: BLE001 - e.g. an interval where only a number will do (an
        # array index): no confirmation, and the reason shown, never a crash of the search
        return "", f"the interval replay failed: {type(exc).__name__}: {exc}"
    if run.violated is None or interp.enclosed == 0:
        return "", interp.why or "the guarantee is not certainly violated on the enclosure"
    return (f"confirmed with interval enclosures ({interp.enclosed} flow(s), {interp.steps} Taylor steps, "
            f"max width {interp.width:.1g})"), ""


def _iv(v: Any) -> Any:
    return v.iv if isinstance(v, IntervalValue) else v


def has_intervals(state: dict[str, Any]) -> bool:
    return any(isinstance(v, IntervalValue) or (isinstance(v, Table) and any(
        isinstance(x, IntervalValue) for x in v.cells.values())) for v in state.values())
