"""The proof checker: re-checks a proof certificate with no prover code (README.md).

`check_file(path)` -> Outcome (status accepted | rejected | malformed, a message naming the
first failing step, exit_code 0 | 1 | 2). Imports only models/lang and proofs/arith."""

from __future__ import annotations

import json
from pathlib import Path

from certiloop.proofs.checker.certificate import FORMAT, RLIMIT, Outcome, check


def check_file(path: str | Path, rlimit: int = RLIMIT) -> Outcome:
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return Outcome("malformed", f"malformed certificate: cannot read {path} as JSON ({exc})")
    return check(doc, rlimit)


__all__ = ["FORMAT", "Outcome", "check", "check_file"]
