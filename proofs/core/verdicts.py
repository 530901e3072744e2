"""Turning solver answers into verdicts (soundness-critical, kept small).

proved   : z3 found the obligation's negation unsatisfiable.
refuted  : z3 produced a state, and that state, substituted into the obligation, makes it
           false when evaluated exactly (rationals) or with rational intervals (algebraic
           numbers); only for quantified obligations do we fall back to z3's own evaluation
           of its model, and we say so.
unknown  : anything else — budgets spent, solver give-ups, a model that does not re-check.

`decide_theorem` is the one place a theorem's verdict is made, from its obligations'
verdicts and the evidence of a violating run.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, fields
from typing import Any

from certiloop.proofs.core.exact import truth
from certiloop.proofs.core.interval import Interval, show_value
from certiloop.proofs.core.solver import ArrayValue, SolverAnswer


@dataclass
class ObligationResult:
    id: str
    path: str
    verdict: str  # proved | refuted | unknown
    seconds: float
    backend: str = "z3"
    kind: str = "safety"  # as the obligation's: safety | defined | vacuity
    reason: str = ""
    counterexample: dict[str, str] | None = None
    check: str = ""  # how a counterexample was confirmed
    rule: str = ""  # the incomplete rule it depends on (see vcgen.Obligation.rule); a label only
    raw_model: dict[str, Any] | None = field(default=None, repr=False)
    # the form z3 proved (the obligation or a weakening of it), for a second opinion (cvc5)
    proved_formula: Any = field(default=None, repr=False)

    def to_json(self) -> dict[str, Any]:
        # field by field: asdict would deep-copy the proved formula's whole term tree first,
        # which cost a fifth of the gate's main process
        skip = ("raw_model", "proved_formula")
        return {f.name: copy.deepcopy(getattr(self, f.name)) for f in fields(self) if f.name not in skip}


def exactness(model: dict[str, Any]) -> str:
    def approx(v: Any) -> bool:
        if isinstance(v, Interval):
            return True
        if isinstance(v, ArrayValue):
            return any(approx(x) for x in v.entries.values()) or approx(v.default)
        return False

    return "interval arithmetic" if any(approx(v) for v in model.values()) else "exact rationals"


def readable(model: dict[str, Any]) -> dict[str, str]:
    shown = {k: v for k, v in model.items() if not k.startswith("#")}
    return {name: show_value(v) for name, v in sorted(shown.items(), key=lambda kv: _order(kv[0]))}


def _order(name: str) -> tuple:
    base, _, n = name.partition("@")
    return (1 if n else 0, int(n) if n.isdigit() else 0, base)


def judge(ob_id: str, path: str, formula, answer: SolverAnswer, seconds: float) -> ObligationResult:
    if answer.status == "unsat":
        return ObligationResult(ob_id, path, "proved", seconds)
    if answer.status == "unknown":
        return ObligationResult(ob_id, path, "unknown", seconds, reason=answer.reason)
    model = answer.model or {}
    holds = truth(formula, model)
    cex = readable(model)
    if holds is False:
        return ObligationResult(ob_id, path, "refuted", seconds, counterexample=cex,
                                check=exactness(model), raw_model=model)
    if holds is True:
        return ObligationResult(
            ob_id, path, "unknown", seconds, counterexample=cex,
            reason="BUG: z3's counterexample does not falsify the obligation when re-checked exactly",
        )
    if answer.model_falsifies:
        return ObligationResult(ob_id, path, "refuted", seconds, counterexample=cex,
                                check="z3 model evaluation (quantified obligation)", raw_model=model)
    return ObligationResult(ob_id, path, "unknown", seconds, counterexample=cex, raw_model=model,
                            reason="z3 reported a counterexample that could not be confirmed")


# --------------------------------------------------------------------------- theorems


@dataclass
class RunEvidence:
    """What is known about a violating run the refuter found."""

    rechecked: bool  # the run falsifies the loop-unrolled claim in exact arithmetic
    replayed: bool  # the interpreter, run independently from the same start, violates the guarantee
    flows_confirmed: bool  # every closed-form flow agrees with a numerical integration
    detail: str = ""
    # instead of a run: the claim's negation is proved at the counterexample state (a diamond,
    # a modality or quantifier inside a formula; refute/negation.py)
    negation_proved: bool = False

    @property
    def confirmed(self) -> bool:
        return (self.rechecked and self.replayed and self.flows_confirmed) or self.negation_proved


@dataclass
class Decision:
    verdict: str  # proved | refuted | unknown
    reason: str = ""
    ill_defined: bool = False  # a division in the claim itself can be by zero (a counterexample shows it)
    inconsistent: bool = False  # every obligation proved, yet a confirmed violating run: a certiloop bug


def decide_theorem(obligations: list[ObligationResult], run: RunEvidence | None,
                   no_run_why: str = "") -> Decision:
    """proved iff every obligation is proved; refuted iff a violating run was found, re-checked,
    replayed and its flows confirmed (and the claim is well-defined); unknown otherwise."""
    failed = [r for r in obligations if r.verdict != "proved"]
    confirmed = run is not None and run.confirmed
    if not failed:
        if confirmed:
            return Decision("unknown", "INTERNAL INCONSISTENCY: every obligation is proved, yet a violating "
                            f"run was found and confirmed ({run.detail}); please report this certiloop bug",
                            inconsistent=True)
        return Decision("proved")
    undefined = [r for r in failed if r.kind == "defined"]
    if undefined:
        first = undefined[0]
        shown = ", ".join(f"{k} = {v}" for k, v in (first.counterexample or {}).items())
        # a state past an incomplete rule (a loop invariant, dW) may be one no run reaches, and
        # a side condition stricter than the claim needs ("guarded") may fail where it is not taken
        ill = first.verdict == "refuted" and not first.rule
        at = f" ({shown})" if shown else ""
        head = "ill-defined" if ill else "not shown well-defined"
        if "division" not in first.path:  # a translation's side condition (Theorem.well_defined)
            refuted = first.verdict == "refuted"
            how = (f"it fails{at}" if ill else f"it fails{at}, where the claim may not take it"
                   if refuted else f"it is not shown ({first.reason})")
            return Decision("unknown", f"{head}: {first.path}: {how}", ill_defined=ill)
        how = (f"it can be by zero{at}" if ill else f"it is not shown nonzero past {first.rule}"
               if first.verdict == "refuted" else f"it is not shown nonzero ({first.reason})")
        return Decision("unknown", f"{head}: {first.path}: a division in the claim itself, and {how}",
                        ill_defined=ill)
    if confirmed and run.negation_proved:
        return Decision("refuted", "the claim is false at the state shown: its negation is proved there")
    if confirmed:
        return Decision("refuted", "a run that violates the guarantee was found, re-checked exactly, "
                        "replayed and its flows confirmed")
    first = failed[0]
    shown = "rule failed" if first.verdict == "refuted" and first.rule else first.verdict
    why = f"{first.path}: {shown}{': ' + first.reason if first.reason else ''}"
    if run is not None:
        return Decision("unknown", f"{len(failed)} obligation(s) not proved (first: {why}); a violating run "
                        f"was found but could not be confirmed: {run.detail}")
    return Decision("unknown", f"{len(failed)} obligation(s) not proved (first: {why}); {no_run_why}")
