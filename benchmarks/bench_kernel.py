"""Runtime kernel latency: `VirtualFixture.step` and the extracted controller alone, for
1, 10, 100 and 1000 boundaries; the monitor's added cost is their difference.

    python benchmarks/bench_kernel.py [--calls 2000]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from common import record

from certiloop.kernel import VirtualFixture, ctrl2


def planes(m: int, rng) -> list:
    normals = rng.normal(size=(m, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = -rng.uniform(0.5, 3.0, size=(m, 1)) * normals  # the origin is on every safe side
    return list(zip(points, normals))


def median_us(fn, calls: int) -> float:
    times = []
    for _ in range(calls):
        t0 = time.perf_counter_ns()
        fn()
        times.append(time.perf_counter_ns() - t0)
    return statistics.median(times) / 1000


def measure(m: int, rng, calls: int) -> dict:
    fixture = VirtualFixture(planes(m, rng), gain=1.0, buffer=0.5, period=0.0182,
                             position_tolerance=np.inf)  # the same p every call: no motion check
    p, f, fp = np.zeros(3), np.array([1.0, -2.0, 0.5]), np.array([0.1, 0.0, -0.3])
    n, r = fixture._normals, fixture._points
    args = (*p, *fp, *f, 0.5, 0.0182, 1.0, r[:, 0], n[:, 0], r[:, 1], n[:, 1], r[:, 2], n[:, 2])
    step = median_us(lambda: fixture.step(p, f, fp), calls)
    bare = median_us(lambda: ctrl2.controller(*args), calls)
    return {"boundaries": m, "step_median_us": round(step, 1), "controller_median_us": round(bare, 1),
            "monitor_and_checks_us": round(step - bare, 1)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=2000)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    rows = []
    for m in (1, 10, 100, 1000):
        rows.append(measure(m, rng, args.calls))
    record("kernel", rows)


if __name__ == "__main__":
    main()
