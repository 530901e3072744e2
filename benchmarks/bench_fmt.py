"""Table 2 of the Raven-II paper beside ours: certified FMT* (OMPL) on raven.frs_box.

    python benchmarks/bench_fmt.py [--runs 20] [--samples 200,500,1000,2000] [--eta 0.1,0.5]
    python benchmarks/bench_fmt.py --fig7 [--runs 20]     # Fig 7: eta = (1, 0) vs (0, 1) at n = 500

For each n: success rate (a certified path, re-checked independently), median planning time
(FMT* plus the certification of its path), median re-check time, median cost (eq 1 as the
planner optimises it), waypoints; the paper's execution, per-joint PD on `RavenArm` with a
quintic per edge (simulated tracking time, runs whose true wrist or tip crosses, median least
clearance); and tracking of the tip (studies/raven/plan/track.py): runs that
cross a boundary with the virtual fixture, and without it for an operator lagging far behind
the reference (the paper's success falls with n because shorter paths pass nearer the dome
wall; here the bare operator's corner cutting stands for that), beside the paper's Table 2
(20 runs per row, eta = (0.1, 0.5), Windows 7, i7 @ 3.5 GHz; its planning includes ODE
integration of the arm per edge, ours tests kinematic straight joint segments). Writes
benchmarks/results/fmt.json. Seeds 0 .. runs-1 for every n: the same command gives the
same paths (planning times vary with the machine and its load).
"""

from __future__ import annotations

import argparse
import statistics
import time

from common import record

from certiloop.studies.raven.plan.planner import free_fraction, plan_once
from certiloop.studies.raven.plan.scenes import FRS_BOX
from certiloop.studies.raven.plan.track import track, track_joints

PAPER = {200: {"planning_s": 3.676, "tracking_s": 4.705, "waypoints": 13.5, "cost": 21.9, "success": 0.90},
         500: {"planning_s": 15.935, "tracking_s": 4.277, "waypoints": 14.3, "cost": 11.1, "success": 0.85},
         1000: {"planning_s": 47.708, "tracking_s": 3.909, "waypoints": 11.1, "cost": 6.5, "success": 0.85},
         2000: {"planning_s": 216.373, "tracking_s": 3.688, "waypoints": 11.1, "cost": 5.7, "success": 0.75}}


SLOPPY_PULL = 3.0  # 1/s: an operator lagging far behind the reference (the fixture's nominal is 40)


def _median(xs):
    return statistics.median(xs) if xs else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--samples", default="200,500,1000,2000")
    parser.add_argument("--eta", default="0.1,0.5")
    parser.add_argument("--no-tracking", action="store_true", help="skip the fixture tracking")
    parser.add_argument("--fig7", action="store_true", help="Fig 7's two objectives at n = 500 instead")
    args = parser.parse_args()
    if args.fig7:
        return fig7(args.runs)
    eta = tuple(float(x) for x in args.eta.split(","))
    free = free_fraction(FRS_BOX)
    rows = []
    for n in (int(x) for x in args.samples.split(",")):
        runs = []
        for seed in range(args.runs):
            runs.append(plan_once(FRS_BOX, n, seed, eta, free_volume=free))
        ok = [r for r in runs if r.success]
        crossings, bare_crossings, track_s, pd = 0, 0, [], []
        if not args.no_tracking:
            for r in ok:
                pd.append(track_joints(FRS_BOX, r.waypoints))
                t0 = time.perf_counter()
                result = track(FRS_BOX, r.waypoints, per_segment=200, settle=300)
                track_s.append(time.perf_counter() - t0)
                crossings += min(result.min_wall, result.min_block) < -1e-12
                bare = track(FRS_BOX, r.waypoints, per_segment=200, settle=300, pull=SLOPPY_PULL,
                             fixture_on=False)
                bare_crossings += min(bare.min_wall, bare.min_block) < -1e-12
        paper = PAPER.get(n, {})
        rows.append({"n": n, "runs": len(runs), "success": len(ok) / len(runs),
                     "paper_success": paper.get("success", float("nan")),
                     "median_planning_s": _median([r.planning_s for r in runs]),
                     "max_planning_s": max(r.planning_s for r in runs),
                     "paper_planning_s": paper.get("planning_s", float("nan")),
                     "median_check_s": _median([r.check_s for r in ok]),
                     "median_cost": _median([r.cost for r in ok]),
                     "median_length": _median([r.length for r in ok]),
                     "paper_cost": paper.get("cost", float("nan")),
                     "median_waypoints": _median([len(r.waypoints) for r in ok]),
                     "paper_waypoints": paper.get("waypoints", float("nan")),
                     "replans": sum(r.replans for r in runs),
                     "median_motion_checks": _median([r.motion_checks for r in runs]),
                     "tracked": len(track_s), "pd_tracking_s": _median([t.seconds for t in pd]),
                     "paper_tracking_s": paper.get("tracking_s", float("nan")),
                     "pd_crossings": sum(t.min_clearance < 0 for t in pd),
                     "pd_median_min_clearance_mm": 1000 * _median([t.min_clearance for t in pd]),
                     "fixture_crossings": crossings,
                     "bare_sloppy_crossings": bare_crossings})
    record("fmt", rows)


def fig7(runs: int) -> None:
    """The paper (n = 500): eta = (1, 0) returns 36 waypoints, eta = (0, 1) returns 54."""
    free = free_fraction(FRS_BOX)
    rows = []
    for eta, paper in (((1.0, 0.0), 36), ((0.0, 1.0), 54)):
        done = [plan_once(FRS_BOX, 500, seed, eta, free_volume=free) for seed in range(runs)]
        ok = [r for r in done if r.success]
        rows.append({"eta": f"{eta[0]:g},{eta[1]:g}", "runs": runs, "success": len(ok) / runs,
                     "median_waypoints": _median([len(r.waypoints) for r in ok]), "paper_waypoints": paper,
                     "median_length": _median([r.length for r in ok]),
                     "median_accel_quadrature": _median([r.accel_quadrature for r in ok]),
                     "median_planning_s": _median([r.planning_s for r in done])})
    record("fmt_fig7", rows)


if __name__ == "__main__":
    main()
