"""Deterministic budgets: what decides when the solver gives up.

Verdicts depend only on z3 resource units (its `rlimit` counter), never on the clock, so an
idle and a saturated machine reach the same verdicts. The wall-clock limit is a safety net
against a hung solver; reaching it yields `unknown` and says so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

# Calibrated on the library (benchmarks/bench_rlimit.py): the costliest obligation that
# proves needs ~RLIMIT_MEASURED units; the default leaves a wide margin above it.
DEFAULT_RLIMIT = 20_000_000
QUICK_SHARE = 40  # the per-branch report beside a refutation: 1/40 of the full budget
PROJECTED_CEX_SHARE = 4  # raw forms of an obligation whose projection has a counterexample


@dataclass(frozen=True)
class Budget:
    rlimit: int = DEFAULT_RLIMIT  # z3 resource units per obligation form: decides verdicts
    wall_s: float = 600.0  # per solver call: only a safety net

    def share(self, divisor: int) -> "Budget":
        return replace(self, rlimit=max(1, self.rlimit // divisor))
