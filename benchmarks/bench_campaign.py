"""Fault-campaign throughput and the per-tick cost of the runtime safety loop.

1. Injected runs per second: `run_setup` on raven.stop_margin (all fault kinds, 2,000-tick
   runs, batches of 500), in this process and over 2 worker processes (`--jobs 2`); the same
   with the Raven arm as the plant (raven.stop_margin_arm, batches of 1,000).
2. Monitor plus fixture per 1 kHz tick for one arm: `DeviationMonitor.step` and
   `VirtualFixture.step` (3 planes), the median of `--calls` ticks (Raven's budget: 1 ms).
3. Calibration (the paper's fault-free deviation, 2.43 +- 1.72 mm under 3 mm): 100 golden runs
   with the Raven arm as the plant per teleoperation scale 0.05, 0.1, 0.15, 0.2, taken as the
   robot's peak speed = scale x 0.5 m/s of the surgeon's hand (an assumption: the paper gives
   the scales, not the hand's speed), operators differing by up to 50 % in speed; the peak
   deviation's mean and standard deviation, and the alarms at tol = 3 mm.
4. Detection latency of the paper's fault (a shoulder DAC override >= 50 % of MAX_DAC, 200
   runs with the arm), and the worst-case search's reliability (`--search raven.no_margin`,
   seeds 0-19: faults tried before the first crossing).

    python benchmarks/bench_campaign.py [--runs 2000] [--calls 5000] [--arm-runs 2000]
"""

from __future__ import annotations

import argparse
import multiprocessing
import statistics
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from common import record

from certiloop.studies.raven.campaign.fault_search import worst_case
from certiloop.studies.raven.campaign.run import SETUPS, Fault, Scenario, run_campaign, run_setup
from certiloop.studies.raven.deviation import DeviationMonitor
from certiloop.studies.sbs.fixture import VirtualFixture

HAND_SPEED = 0.5  # m/s, the surgeon's hand (assumed)


def runs_per_second(runs: int, jobs: int, name: str = "raven.stop_margin", batch: int = 500) -> dict:
    setup = SETUPS[name]
    t0 = time.perf_counter()
    if jobs == 1:
        rows = run_setup(setup, runs=runs, seed=0, batch=batch)
    else:
        with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
            rows = run_setup(setup, runs=runs, seed=0, batch=batch, executor=pool)
    seconds = time.perf_counter() - t0
    return {"measure": f"{name}, {jobs} process(es), batches of {batch}", "runs": len(rows),
            "seconds": round(seconds, 2),
            "value": round(len(rows) / seconds, 1), "unit": "runs/s (2,000 ticks each)"}


def tick_cost(calls: int) -> dict:
    fixture = VirtualFixture([((0.0, 0.0, -0.01), (0.0, 0.0, 1.0)), ((0.02, 0.0, 0.0), (-1.0, 0.0, 0.0)),
                              ((0.0, 0.02, 0.0), (0.0, -1.0, 0.0))],
                             gain=1.0, buffer=0.002, period=1e-3, position_tolerance=np.inf)
    monitor = DeviationMonitor(1)
    p, f, fp = np.zeros(3), np.array([0.1, -0.2, -0.5]), np.zeros(3)
    model, v, robot = np.zeros((1, 3)), np.zeros((1, 3)), np.full((1, 3), 1e-4)
    times = []
    for _ in range(calls):
        t0 = time.perf_counter_ns()
        fixture.step(p, f, fp)
        monitor.step(model, v, robot, v)
        times.append(time.perf_counter_ns() - t0)
    return {"measure": "monitor + fixture, one tick", "runs": calls, "seconds": round(sum(times) / 1e9, 2),
            "value": round(statistics.median(times) / 1000, 1), "unit": "µs (median)"}


def dac_override_latency(runs: int = 200) -> dict:
    """The paper's fault: the shoulder's DAC overridden by a constant >= 50 % of MAX_DAC (either
    sign) for 300 ticks, the arm as the plant; ticks from the window's start to the alarm."""
    rng = np.random.default_rng(0)
    faults = [Fault("override", "motor", int(rng.integers(200, 1200)), 300,
                    float(rng.choice([-1, 1]) * rng.uniform(0.5, 1.0))) for _ in range(runs)]
    sc = Scenario(ticks=1600, plant="arm", fallback="haptic", reach_speed=0.05, speed_spread=0.5)
    rec = run_campaign(faults, sc, seed=0)
    latency = np.array([a - f.start for f, a in zip(faults, rec.first_alarm) if a >= f.start])
    return {"measure": "DAC override >= 50 % MAX_DAC, latency ticks (1 ms): median / p95 / max",
            "runs": runs, "seconds": "",
            "value": f"{np.median(latency):.0f} / {np.percentile(latency, 95):.0f} / {latency.max():.0f}",
            "unit": f"{len(latency)} of {runs} alarmed in their window"}


def search_seeds(seeds: int = 20, max_examples: int = 500) -> dict:
    """--search on raven.no_margin for seeds 0..seeds-1: faults tried until a crossing."""
    found = [worst_case(SETUPS["raven.no_margin"], max_examples=max_examples, seed=s) for s in range(seeds)]
    tried = [r.found_after for r in found if r.fault is not None]
    return {"measure": "--search raven.no_margin: faults tried to the first crossing, min / median / max",
            "runs": seeds, "seconds": "",
            "value": f"{min(tried)} / {statistics.median(tried):.0f} / {max(tried)}" if tried else "-",
            "unit": f"{len(tried)} of {seeds} seeds crossed (all shrunk and replayed)"}


def calibration(runs: int = 100) -> list[dict]:
    rows = []
    for scale in (0.05, 0.1, 0.15, 0.2):
        sc = Scenario(ticks=2000, plant="arm", reach_speed=scale * HAND_SPEED, speed_spread=0.5)
        rec = run_campaign([None] * runs, sc, seed=0)
        peak = rec.peak_deviation * 1000
        rows.append({"measure": f"golden runs, scale {scale}", "runs": runs, "seconds": "",
                     "value": f"{peak.mean():.2f} +- {peak.std():.2f}",
                     "unit": f"mm peak deviation; {int((rec.first_alarm >= 0).sum())} alarms"})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--calls", type=int, default=5000)
    ap.add_argument("--arm-runs", type=int, default=2000)
    args = ap.parse_args()
    record("campaign", [runs_per_second(args.runs, 1), runs_per_second(args.runs, 2),
                        runs_per_second(args.arm_runs, 1, "raven.stop_margin_arm", batch=1000),
                        runs_per_second(args.arm_runs, 2, "raven.stop_margin_arm", batch=1000),
                        tick_cost(args.calls), dac_override_latency(), search_seeds(), *calibration()])


if __name__ == "__main__":
    main()
