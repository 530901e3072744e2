"""Runtime kernel latency: `VirtualFixture.step` and the extracted controller alone, for
1, 10, 100 and 1000 boundaries; the monitor's added cost is their difference.

    python benchmarks/bench_kernel.py [--calls 2000]
    python benchmarks/bench_kernel.py --compare /tmp/oldvenv/bin/python [--rounds 5] [--calls 1000]

--compare measures `step` of this install and of another one (its python, e.g. a virtualenv
with commit ae9f168 installed) side by side: interleaved rounds, each a fresh worker process
per install (`--worker`), the same planes and states; medians over rounds of per-round
medians and p99s, and the slowest call of all rounds, written to results/kernel_compare.json.
This install's step runs on its default back end (the compiled C when a compiler is there, see
certiloop.studies.sbs.native); with
CERTILOOP_KERNEL=python in the environment it runs the numpy path, written to
results/kernel_compare_numpy.json.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np
from common import latency, record

try:
    from certiloop.studies.sbs.fixture import VirtualFixture
    from certiloop.studies.sbs.generated import ctrl2
except ImportError:  # an older install (--compare's other side): the kernel before the studies moved
    from certiloop.kernel import ctrl2  # type: ignore[no-redef]
    from certiloop.kernel.fixture import VirtualFixture  # type: ignore[no-redef]


def planes(m: int, rng) -> list:
    normals = rng.normal(size=(m, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = -rng.uniform(0.5, 3.0, size=(m, 1)) * normals  # the origin is on every safe side
    return list(zip(points, normals))


def timed_us(fn, calls: int) -> dict[str, float]:
    """Median, p99 and max (µs) of `calls` calls, each timed alone."""
    times = []
    for _ in range(calls):
        t0 = time.perf_counter_ns()
        fn()
        times.append(time.perf_counter_ns() - t0)
    return latency(times, unit=1e-3, suffix="us")


def median_us(fn, calls: int) -> float:
    return timed_us(fn, calls)["median_us"]


def measure(m: int, rng, calls: int) -> dict:
    planes_ = planes(m, rng)
    fixture = VirtualFixture(planes_, gain=1.0, buffer=0.5, period=0.0182,
                             position_tolerance=np.inf)  # the same p every call: no motion check
    p, f, fp = np.zeros(3), np.array([1.0, -2.0, 0.5]), np.array([0.1, 0.0, -0.3])
    n, r = fixture._normals, fixture._points
    args = (*p, *fp, *f, 0.5, 0.0182, 1.0, r[:, 0], n[:, 0], r[:, 1], n[:, 1], r[:, 2], n[:, 2])
    step = timed_us(lambda: fixture.step(p, f, fp), calls)
    numpy_fixture = VirtualFixture(planes_, gain=1.0, buffer=0.5, period=0.0182, position_tolerance=np.inf,
                                   backend="python")
    numpy_step = timed_us(lambda: numpy_fixture.step(p, f, fp), calls)
    bare = median_us(lambda: ctrl2.controller(*args), calls)
    return {"boundaries": m, "backend": fixture.backend,
            **{f"step_{k}": round(v, 1) for k, v in step.items()},
            **{f"numpy_step_{k}": round(v, 1) for k, v in numpy_step.items()},
            "numpy_controller_median_us": round(bare, 1),
            "numpy_monitor_and_checks_us": round(numpy_step["median_us"] - bare, 1)}


SIZES = (1, 10, 100, 1000)


def worker(calls: int) -> dict:
    """`step` median, p99 and max (µs) for every size: only API both installs have."""
    rng = np.random.default_rng(0)
    out = {}
    for m in SIZES:
        fixture = VirtualFixture(planes(m, rng), gain=1.0, buffer=0.5, period=0.0182,
                                 position_tolerance=np.inf)
        p, f, fp = np.zeros(3), np.array([1.0, -2.0, 0.5]), np.array([0.1, 0.0, -0.3])
        fixture.step(p, f, fp)
        out[m] = timed_us(lambda fx=fixture, p=p, f=f, fp=fp: fx.step(p, f, fp), calls)
    return out


def compare(old_python: str, rounds: int, calls: int) -> None:
    here = [sys.executable, __file__, "--worker", "--calls", str(calls)]
    there = [old_python, __file__, "--worker", "--calls", str(calls)]
    runs: dict[str, list[dict]] = {"old": [], "new": []}
    for _ in range(rounds):  # interleaved: a busy moment hits both
        for side, cmd in (("old", there), ("new", here)):
            done = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd="/")
            runs[side].append({int(k): v for k, v in json.loads(done.stdout.splitlines()[-1]).items()})
    rows = []
    numpy_only = os.environ.get("CERTILOOP_KERNEL", "").lower() == "python"
    for m in SIZES:
        row = {"boundaries": m, "new_backend": "python" if numpy_only else "default"}
        for side in ("old", "new"):  # medians of the rounds' medians and p99s; the worst call of all
            row[f"{side}_step_median_us"] = round(statistics.median(r[m]["median_us"] for r in runs[side]), 1)
            row[f"{side}_step_p99_us"] = round(statistics.median(r[m]["p99_us"] for r in runs[side]), 1)
            row[f"{side}_step_max_us"] = round(max(r[m]["max_us"] for r in runs[side]), 1)
        row["speedup"] = round(row["old_step_median_us"] / row["new_step_median_us"], 2)
        rows.append({**row, "rounds": rounds, "calls": calls})
    record("kernel_compare_numpy" if numpy_only else "kernel_compare", rows)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--compare", metavar="PYTHON", help="another install's python, measured side by side")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.calls)))
        return
    if args.compare:
        compare(args.compare, args.rounds, args.calls)
        return
    rng = np.random.default_rng(0)
    rows = []
    for m in (1, 10, 100, 1000):
        rows.append(measure(m, rng, args.calls))
    record("kernel", rows)


if __name__ == "__main__":
    main()
