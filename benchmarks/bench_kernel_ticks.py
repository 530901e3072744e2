"""Per-tick Python cost of the Raven-II and RCM kernels: this commit against another (default
3b34d1f, its kernel modules loaded from git beside these: studies/, or kernel/ before the
studies moved), interleaved rounds in one process.

    python benchmarks/bench_kernel_ticks.py [--old 3b34d1f] [--rounds 5] [--calls 1000]

* raven arm.step, monitor.step, ik_step with 1 run (all of it is per-call overhead: numpy
  calls on arrays of 3-6 numbers) and with 1,000 runs (the campaign's batch);
* rcm step with no cloud (the 7-DOF dynamics and guard: the per-tick cost without the
  KD-tree), and with 10,000 points at the tip.
Median, p99 and max per call, over all rounds; writes results/kernel_ticks.json.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_rcm import guidance
from common import latency, record

from certiloop.studies.raven import arm as raven
from certiloop.studies.raven import deviation
from certiloop.studies.rcm import dynamics as rcm_dynamics
from certiloop.studies.rcm.cloud import CloudBarrier
from certiloop.studies.rcm.demo import demo_controller

ROOT = Path(__file__).resolve().parent.parent


def old_module(commit: str, paths: tuple[str, ...], name: str, folder: Path):
    """The first of `paths` that exists at `commit`, loaded as module old_NAME."""
    import subprocess

    import old_code

    for path in paths:
        try:
            text = old_code.source(commit, path)
        except subprocess.CalledProcessError:
            continue
        return old_code.load(f"old_{name}", text, folder)
    raise SystemExit(f"{commit} has none of {', '.join(paths)}")


def raven_cases(mods: dict, runs: int) -> dict:
    """name -> (side -> a call)."""
    cases: dict = {f"raven arm.step {runs} runs": {}, f"raven monitor.step {runs} runs": {},
                   f"raven ik_step {runs} runs": {}}
    for side, (arm_mod, dev_mod) in mods.items():
        arm = arm_mod.RavenArm()
        state = arm.rest(runs)
        target = state.q.copy()
        target[:, :3] += 0.01
        monitor = dev_mod.DeviationMonitor(runs=runs)
        pm = np.zeros((runs, 3))
        pr = pm + 1e-4
        pos = arm_mod.Positioning()
        goal = pm + np.array([0.01, 0.01, -0.2])
        qp = state.q[:, :3].copy()
        cases[f"raven arm.step {runs} runs"][side] = lambda arm=arm, s=state, t=target: arm.step(s, t)
        cases[f"raven monitor.step {runs} runs"][side] = lambda m=monitor, a=pm, b=pr: m.step(a, a, b, a)
        cases[f"raven ik_step {runs} runs"][side] = lambda p=pos, g=goal, q=qp: p.ik_step(g, q)
    return cases


def rcm_cases(mods: dict) -> dict:
    cases: dict = {"rcm step, no cloud": {}, "rcm step, 10000 pts at the tip": {}}
    base = demo_controller(points=10000, mode="tip", gap=0.005)
    empty = CloudBarrier(np.zeros((0, 3)), 0.0035)
    barriers = (("rcm step, no cloud", empty), ("rcm step, 10000 pts at the tip", base.barrier))
    for side, mod in mods.items():
        for case, barrier in barriers:
            c = mod.RcmAdmittance(base.q.copy(), base.p_c, barrier, base.tool_length, "tip", dt=base.dt)
            ticks = iter(range(10**9))
            cases[case][side] = lambda c=c, ticks=ticks: c.step(guidance(next(ticks) * 0.004))
    return cases


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", default="3b34d1f")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--calls", type=int, default=1000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        old_raven = old_module(args.old, ("studies/raven/arm.py", "kernel/raven.py"), "raven", folder)
        old_dev = old_module(args.old, ("studies/raven/deviation.py", "kernel/deviation.py"), "deviation",
                             folder)
        old_rcm = old_module(args.old, ("studies/rcm/dynamics.py", "kernel/rcm_dynamics.py"), "rcm_dynamics",
                             folder)
        cases = {**raven_cases({"old": (old_raven, old_dev), "new": (raven, deviation)}, 1),
                 **raven_cases({"old": (old_raven, old_dev), "new": (raven, deviation)}, 1000),
                 **rcm_cases({"old": old_rcm, "new": rcm_dynamics})}
        samples = {(case, side): [] for case in cases for side in ("old", "new")}
        for _ in range(args.rounds):  # interleaved: a busy moment hits both
            for case, sides in cases.items():
                for side, call in sides.items():
                    out = samples[case, side]
                    for _ in range(args.calls):
                        t0 = time.perf_counter_ns()
                        call()
                        out.append(time.perf_counter_ns() - t0)
    rows = []
    for case in cases:
        row = {"case": case}
        for side in ("old", "new"):
            row.update({f"{side}_{k}": round(v, 1) for k, v in
                        latency(samples[case, side], unit=1e-3, suffix="us").items()})
        row["speedup_median"] = round(row["old_median_us"] / row["new_median_us"], 2)
        row.update({"rounds": args.rounds, "calls": args.calls, "old": args.old})
        rows.append(row)
    record("kernel_ticks", rows)


if __name__ == "__main__":
    main()
