"""A second opinion on a theorem's proofs: cvc5 re-checks every form z3 proved.

z3 proves an obligation, or a trusted weakening of it (instantiated, lowered, abstracted);
`ObligationResult.proved_formula` is the form it proved. cvc5 reads that form through our
own SMT-LIB printer and its own parser, so a bug in z3, in our z3 translation or in z3's
printer cannot hide behind itself. A cvc5 model of the negation (it "disagrees") is a
soundness alarm; cvc5 giving up within its deterministic budget is only "not confirmed".
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

from certiloop.proofs.core.verdicts import ObligationResult


@dataclass
class SecondOpinion:
    confirmed: list[str] = field(default_factory=list)  # obligation ids cvc5 confirmed
    unconfirmed: list[tuple[str, str]] = field(default_factory=list)  # (id, why cvc5 gave no answer)
    disagreements: list[tuple[str, str]] = field(default_factory=list)  # (id, cvc5's counter-model)
    resources: int = 0  # cvc5 resource units spent (deterministic)
    seconds: float = 0.0

    @property
    def checked(self) -> int:
        return len(self.confirmed) + len(self.unconfirmed) + len(self.disagreements)

    @property
    def summary(self) -> str:
        text = f"cvc5 confirmed {len(self.confirmed)}/{self.checked} proved obligations"
        if self.disagreements:
            text += f"; DISAGREES on {', '.join(i for i, _ in self.disagreements)}"
        if self.unconfirmed:
            text += f"; {len(self.unconfirmed)} not confirmed within its budget"
        return text

    def to_json(self) -> dict[str, Any]:
        return {"confirmed": len(self.confirmed), "checked": self.checked,
                "unconfirmed": [{"id": i, "why": w} for i, w in self.unconfirmed],
                "disagreements": [{"id": i, "cvc5_model": m} for i, m in self.disagreements],
                "resources": self.resources, "seconds": round(self.seconds, 3)}


def second_opinion(obligations: list[ObligationResult], rlimit: int | None = None) -> SecondOpinion:
    """cvc5 on every proved obligation's proved form (needs certiloop[crosscheck])."""
    from certiloop.proofs.arith.crosscheck import DEFAULT_RLIMIT, cross_check

    start = time.perf_counter()
    opinion = SecondOpinion()
    for ob in obligations:
        if ob.verdict != "proved" or ob.proved_formula is None:
            continue
        check = cross_check(ob.proved_formula, DEFAULT_RLIMIT if rlimit is None else rlimit)
        opinion.resources += check.resources
        if check.status == "confirmed":
            opinion.confirmed.append(ob.id)
        elif check.status == "disagrees":
            opinion.disagreements.append((ob.id, check.detail))
        else:
            opinion.unconfirmed.append((ob.id, check.detail))
    opinion.seconds = time.perf_counter() - start
    return opinion
