"""The verification gate: every model must meet the verdict its author expects.

A proved model must have every obligation proved; a refuted model must come with a
replayed violating run. `unknown` (a timeout, a solver give-up) never passes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from certiloop.models.theorem import Theorem

from .engine import Prover, TheoremResult


@dataclass
class GateEntry:
    result: TheoremResult

    @property
    def passed(self) -> bool:
        return self.result.verdict == self.result.expected

    @property
    def message(self) -> str:
        r = self.result
        if self.passed:
            return "as expected"
        if r.verdict == "unknown":
            return f"expected {r.expected}, but the proof is unknown: {r.reason}"
        if r.expected == "refuted":
            return "expected refuted, but it PROVED: the unsafe design now looks safe"
        failed = [o for o in r.obligations if o.verdict != "proved"]
        where = f" at {failed[0].path}" if failed else ""
        return f"expected proved, but it is {r.verdict}{where}: {r.reason}"

    def to_json(self) -> dict[str, Any]:
        return {**self.result.to_json(), "passed": self.passed, "message": self.message}


def run_gate(theorems: list[Theorem], prover: Prover, on_model=None) -> list[GateEntry]:
    entries = []
    for theorem in theorems:
        entry = GateEntry(prover.prove(theorem))
        entries.append(entry)
        if on_model:
            on_model(entry)
    return entries
