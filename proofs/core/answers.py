"""The answer of one validity check (solver.py, in this process or in a child: isolated.py)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass
class SolverAnswer:
    status: str  # "unsat" | "sat" | "unknown"
    reason: str = ""
    model: dict[str, Any] | None = None
    model_falsifies: bool | None = None  # z3's own evaluation of the formula in its model
    spent: int = 0  # z3 resource units (rlimit count) the check used
    allocations: int = 0  # z3 allocations the check used, when it ran in a child (isolated.py)
    backend: str = "z3"  # who decided: z3, or exact interval arithmetic (boxes.py)
