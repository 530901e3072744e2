"""Deterministic budgets: what decides when the solver gives up.

Verdicts depend only on z3 resource units (its `rlimit` counter), never on the clock, so an
idle and a saturated machine reach the same verdicts. The wall-clock limit is a safety net
against a hung solver; reaching it yields `unknown` and says so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

# Calibrated with benchmarks/bench_rlimit.py: the costliest obligation of any proved library
# model needs about 50,000 units (sbs.ctrl2_dynamic, 2-core machine, z3 4.x); 40 times that
# leaves room for harder user models while failing attempts stay short.
DEFAULT_RLIMIT = 2_000_000
QUICK_SHARE = 40  # the per-branch report beside a refutation: 1/40 of the full budget
PROJECTED_CEX_SHARE = 4  # raw forms of an obligation whose projection has a counterexample
PLAN_SHARE = 10  # each trial of an ODE cut chain's link (proofs/engine/odeplan.py)
# A search for a violating run explores a whole unrolled program at once: it gets 16 times
# an obligation's budget (the library's hardest run, sbs.predictive_multi, needs ~4.6M units
# under its scenario; sbs.ctrl2_last_wins ~2.7M over a two-boundary family).
REFUTE_FACTOR = 16
DEFAULT_WALL_S = 60.0
RUN_WALL_FACTOR = 5  # a run search's calls are larger: a wider safety net


@dataclass(frozen=True)
class Budget:
    rlimit: int = DEFAULT_RLIMIT  # z3 resource units per obligation form: decides verdicts
    # Per solver call, only a safety net: z3's nonlinear arithmetic can spend minutes on huge
    # rationals inside one step its resource count does not cover (seen on false quantified
    # obligations); such a call ends 'unknown' and says the net was reached. Library proofs
    # take under 5 s a call.
    wall_s: float = DEFAULT_WALL_S

    def share(self, divisor: int) -> "Budget":
        return replace(self, rlimit=max(1, self.rlimit // divisor))

    def for_runs(self) -> "Budget":
        """The budget of one attempt to find a violating (or a witness) run."""
        return replace(self, rlimit=self.rlimit * REFUTE_FACTOR, wall_s=self.wall_s * RUN_WALL_FACTOR)
