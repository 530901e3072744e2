"""The RCM paper's admittance kernel: step latency, the paper's reproductions, and proof times.

    python benchmarks/bench_rcm.py [--steps 2000] [--no-prove] [--plot]

* step: `RcmAdmittance.step` (7-DOF target dynamics, KD-tree barrier, variable damping, guard;
  explicit Euler) in the demo scene with the tip 5 mm above the cloud (so points are in the
  influence band) under a slow human wrench: tip with 1,000 and 10,000 points, whole-tool
  capsule with 10,000. Median, p99 and max in ms; targets 0.5 / 1 / 2 ms (the period is 4 ms);
  bench_rcm_tail.py: the tail over 10,000 ticks against an older commit, with the GC regimes.
* B1 kinematic anchor: distance of the paper's p_c from the tool axis at q_d(0).
* B2 fig. 8: max ||x_c|| over 10 s of guidance at 4 ms and 1 ms.
* B3 clearance: minimum tip (or capsule) clearance under steady downward pushes from 15 mm,
  for the paper's Euler, semi-implicit Euler and the guarded Euler ("entered" if it got inside).
* B4 decoupling: x_c(t) against x_c(0)(1 + alpha t)e^{-alpha t} at dt = 20 us over 80 ms.
* prove: cold `certiloop prove` wall time (fresh cache) for every rcm.* library model.

Writes results/rcm.json (and results/rcm.png with --plot, if matplotlib is installed); with
--no-prove it keeps the proof times already recorded there.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from common import RESULTS, latency, record

from certiloop.studies.rcm import kernel as rcm
from certiloop.studies.rcm.cloud import CloudBarrier
from certiloop.studies.rcm.demo import P_C, P_C_PAPER, TOOL_LENGTH, demo_controller
from certiloop.studies.rcm.dynamics import RcmAdmittance


def guidance(t: float) -> list[float]:
    """A slow human wrench, |f| <= 3 N."""
    return [2 * math.sin(0.5 * t), 1.5 * math.sin(0.7 * t + 1), -math.sin(0.3 * t), 0.1 * math.sin(0.9 * t),
            0.1 * math.cos(0.6 * t), 0.05 * math.sin(t)]


def step_latency(points: int, mode: str, steps: int) -> dict:
    c = demo_controller(points=points, mode=mode, gap=0.005)
    times = []
    for i in range(steps):
        w = guidance(i * c.dt)
        t0 = time.perf_counter_ns()
        c.step(w)
        times.append(time.perf_counter_ns() - t0)
    return {"case": f"step {mode} {points} pts", **latency(times, unit=1e-6),
            "target_ms": {("tip", 1000): 0.5, ("tip", 10000): 1.0}.get((mode, points), 2.0)}


def anchor() -> dict:
    p, n, _, _ = rcm.tool_tip(rcm.Q_ANCHOR, TOOL_LENGTH)
    r = P_C_PAPER - p
    flange = rcm.lwr4_forward(rcm.Q_ANCHOR)[:3, 3]
    return {"case": "B1 anchor", "flange_m": [round(float(x), 5) for x in flange],
            "p_c_off_axis_mm": float(np.linalg.norm(r - (r @ n) * n)) * 1e3}


def fig8(dt: float, seconds: float = 10.0) -> tuple[dict, np.ndarray]:
    c = demo_controller(points=625, gap=0.05, dt=dt)
    xs = []
    for i in range(int(round(seconds / dt))):
        c.step(guidance(i * dt))
        xs.append(np.linalg.norm(rcm.rcm_error(c.q, P_C, TOOL_LENGTH)))
    return {"case": f"B2 fig8 dt={dt * 1e3:g} ms", "max_xc_um": max(xs) * 1e6}, np.array(xs)


def clearance(integrator: str, guard: bool, mode: str, push: float, steps: int = 500) -> tuple[dict, list]:
    c = demo_controller(points=625, gap=0.015, mode=mode, integrator=integrator, guard=guard)
    gaps, entered = [], None
    for i in range(steps):
        r = c.step([0.0, 0.0, -push, 0.0, 0.0, 0.0])
        if not r.ok:
            entered = i
            break
        gaps.append(r.gap)
    name = f"{integrator}{' +guard' if guard else ''}"
    return ({"case": f"B3 {mode} {name} {push:g} N", "min_gap_mm": min(gaps) * 1e3,
             "entered_at_step": entered}, gaps)


def decoupling() -> dict:
    q0 = rcm.Q_ANCHOR + np.array([0.0, 0.004, 0.0, -0.003, 0.0, 0.0, 0.0])
    x0 = rcm.rcm_error(q0, P_C, TOOL_LENGTH)
    dt, alpha = 2e-5, 25.0
    empty = CloudBarrier(np.zeros((0, 3)), 0.0035)
    c = RcmAdmittance(q0, P_C, empty, TOOL_LENGTH, integrator="semi-implicit", dt=dt,
                      wrench=np.array([0.0, 0.0, -3.0, 0.1, 0.0, 0.0]))
    worst = 0.0
    for i in range(1, int(round(0.08 / dt)) + 1):
        c.step()
        x = rcm.rcm_error(c.q, P_C, TOOL_LENGTH)
        worst = max(worst, np.linalg.norm(x - x0 * (1 + alpha * i * dt) * math.exp(-alpha * i * dt)))
    return {"case": "B4 decoupling dt=20 us", "x0_mm": float(np.linalg.norm(x0)) * 1e3,
            "max_dev_pct_of_x0": 100 * worst / float(np.linalg.norm(x0))}


def prove_times() -> list[dict]:
    cli = Path(sys.executable).with_name("certiloop")
    listing = subprocess.run([str(cli), "list"], capture_output=True, text=True).stdout
    names = sorted({w for line in listing.splitlines() for w in line.split() if w.startswith("rcm.")})
    rows = []
    for name in names:
        with tempfile.TemporaryDirectory() as cache:
            t0 = time.perf_counter()
            out = subprocess.run([str(cli), "prove", "-q", name], capture_output=True, text=True,
                                 env={**os.environ, "CERTILOOP_CACHE": cache})
            rows.append({"case": f"prove {name}", "wall_s": time.perf_counter() - t0, "exit": out.returncode})
    return rows


def plot(xs4: np.ndarray, xs1: np.ndarray, traces: dict, path: Path) -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    a.semilogy(np.arange(len(xs4)) * 0.004, np.maximum(xs4, 1e-12), label="4 ms")
    a.semilogy(np.arange(len(xs1)) * 0.001, np.maximum(xs1, 1e-12), label="1 ms", alpha=0.7)
    a.set(xlabel="t (s)", ylabel="||x_c|| (m)", title="RCM error under guidance (paper fig. 8)")
    a.legend()
    for label, gaps in traces.items():
        b.plot(np.arange(len(gaps)) * 0.004, np.array(gaps) * 1e3, label=label)
    b.axhline(0.0, color="k", lw=0.8)
    b.set(xlabel="t (s)", ylabel="tip clearance rho - d_c (mm, capped at d_0)",
          title="8 N push from 15 mm (tip; euler ends inside)")
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--no-prove", action="store_true")
    ap.add_argument("--plot", action="store_true")
    args = ap.parse_args()
    rows = [step_latency(1000, "tip", args.steps), step_latency(10000, "tip", args.steps),
            step_latency(10000, "tool", args.steps), anchor()]
    b2_4, xs4 = fig8(0.004)
    b2_1, xs1 = fig8(0.001)
    rows += [b2_4, b2_1]
    traces = {}
    for mode in ("tip", "tool"):
        for integ, guard in (("euler", False), ("semi-implicit", False), ("euler", True)):
            for push in (5.0, 8.0, 30.0):
                row, gaps = clearance(integ, guard, mode, push)
                rows.append(row)
                if mode == "tip" and push == 8.0:
                    traces[row["case"].split(" ", 2)[2].rsplit(" ", 2)[0]] = gaps
    rows.append(decoupling())
    if not args.no_prove:
        rows += prove_times()
    elif (RESULTS / "rcm.json").exists():  # keep the proof times an earlier run recorded
        earlier = json.loads((RESULTS / "rcm.json").read_text())["rows"]
        rows += [{k: v for k, v in r.items() if v != ""} for r in earlier if r["case"].startswith("prove ")]
    keys = sorted({k for r in rows for k in r}, key=lambda k: (k != "case", k))
    record("rcm", [{k: r.get(k, "") for k in keys} for r in rows])
    if args.plot and plot(xs4, xs1, traces, Path(__file__).parent / "results" / "rcm.png"):
        print("wrote benchmarks/results/rcm.png")


if __name__ == "__main__":
    main()
