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
# A proof's obligations go in waves of WAVE; once one is refuted the proof cannot succeed,
# and the later waves get this share (prover._screened): a failing proof stops spending early.
WAVE = 8
SCREEN_SHARE = 10
# A search for a violating run explores a whole unrolled program at once: it gets 6 times
# an obligation's budget (the library's hardest run, sbs.predictive_multi, needs ~4.7M units
# under its scenario; sbs.ctrl2_last_wins ~2.7M over a two-boundary family; no run of
# KeYmaera X's archives more than 3.3M). More is costly: a search that finds nothing spends all
# of it (16 times: 56 s on ModelPlex's Approximated Robix Static Safety).
REFUTE_FACTOR = 6
# Nonlinear size (proofs/engine/polysize.py: mixed monomials x their degree x coefficient bits,
# the largest over a formula's comparisons of degree 4 and more) above which a formula is not
# given to z3: there its rlimit stops counting most of the work (nlsat's projections; a
# degree-10 barrier in two variables: 42 s for 530,000 units). KeYmaera X's archives:
# the largest of any proved entry's obligations is 648 (nonlinear.kyx's Ferragut Giacomini
# Example 1, degree 7); the slow unknown ones are 1,782 to 8,600. The library: at most 480 on
# proved models (sbs.predictive); sbs.predictive_multi (refuted by a run) has 21 obligations
# above, none proved before either.
MAX_NONLINEAR_SIZE = 1500
# Obligations of one proof above which none is tried (the program's paths multiply): the
# library's largest proof has 144 (sbs.ctrl2), KeYmaera X's archives' proved entries fewer;
# advanced.kyx's CTCS-3 has 6,602, whose generation alone took longer than 30 s.
MAX_OBLIGATIONS = 1000
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
    # a formula whose nonlinear size passes this is left unknown without calling z3 (deterministic)
    max_nonlinear_size: int = MAX_NONLINEAR_SIZE
    max_obligations: int = MAX_OBLIGATIONS  # more in one proof: unknown, none tried (deterministic)

    def share(self, divisor: int) -> "Budget":
        return replace(self, rlimit=max(1, self.rlimit // divisor))

    def for_runs(self) -> "Budget":
        """The budget of one attempt to find a violating (or a witness) run."""
        return replace(self, rlimit=self.rlimit * REFUTE_FACTOR, wall_s=self.wall_s * RUN_WALL_FACTOR)
