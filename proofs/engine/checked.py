"""A proved theorem's proof re-checked by the separate proof checker (proofs/checker): its
certificate is written from the proof, turned into JSON text and read back exactly as
`certiloop check-proof` reads a file, then checked. Used by `prove --check` and by the gate,
which reports `proved` only for proofs the checker accepted."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class CheckedProof:
    accepted: bool
    message: str  # the checker's: "accepted: ..." or why it rejected, naming the first failing step
    certificate: dict[str, Any] | None  # the certificate checked, as JSON data


NO_CERTIFICATE = "rejected: the proof has no certificate to check"


def check_proof(proof: tuple | None, results: list) -> CheckedProof:
    """proof: a TheoremResult's `proof` (the theorem and the ODE plan it was proved with);
    results: its obligations' results (which leaves were proved through a weakening)."""
    if proof is None:
        return CheckedProof(False, NO_CERTIFICATE, None)
    from certiloop.proofs.checker import check
    from certiloop.proofs.engine.certificate_writer import certificate

    doc = json.loads(json.dumps(certificate(*proof, results)))
    outcome = check(doc)
    return CheckedProof(outcome.status == "accepted", outcome.message, doc)


def rejected_reason(message: str) -> str:
    return f"proved, but the proof checker did not accept its certificate: {message}"
