"""Tail latency of the RCM step (`RcmAdmittance.step`, 10,000 cloud points at the tip, the
demo scene of bench_rcm.py): median, p99 and max over 10,000 ticks, this commit's step against
another commit's (default 3b34d1f, its studies/rcm/dynamics.py, or kernel/rcm_dynamics.py before
the studies moved, loaded from git beside this one), interleaved in blocks of ticks so that a
busy moment of the machine hits both.

    python benchmarks/bench_rcm_tail.py [--old 3b34d1f] [--ticks 10000] [--points 10000]

Three garbage-collector regimes, each a row per side:
* "on": Python's default, as any caller gets it;
* "frozen": what a control loop does before it starts: gc.collect() then gc.freeze(), so the
  set-up's objects (numpy, scipy, the cloud's tree) are never scanned again; the collector stays
  on and only ever scans the few objects of the last ticks;
* "frozen+off": as "frozen" and gc.disable() for the loop (the step's arrays are freed by
  reference counting the moment they die; the step makes no cycles: gc.collect() after the
  loop finds nothing, or the run says so).
`kib_per_tick` is the median over ticks of the peak traced memory during a step above what was
traced before it (tracemalloc, a separate pass; the step's result included). `gc_runs` and
`longest_gc_ms` count the cycle collector's runs that started during this side's ticks
(gc.callbacks); a tick above 1 ms without a collection is the scheduler (see the record's load
average). Writes results/rcm_tail.json.
"""

from __future__ import annotations

import argparse
import gc
import math
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

from bench_rcm import guidance
from common import latency, record

from certiloop.studies.rcm.demo import demo_controller

ROOT = Path(__file__).resolve().parent.parent
BLOCK = 500  # ticks per side before switching


def old_controller_class(commit: str, folder: Path):
    import subprocess

    import old_code

    for path in ("studies/rcm/dynamics.py", "kernel/rcm_dynamics.py"):
        try:
            text = old_code.source(commit, path)
        except subprocess.CalledProcessError:
            continue
        return old_code.load("old_rcm_dynamics", text, folder).RcmAdmittance
    raise SystemExit(f"{commit} has no RCM dynamics module")


def controllers(Old, points: int) -> dict:
    new = demo_controller(points=points, mode="tip", gap=0.005)
    old = Old(new.q.copy(), new.p_c, new.barrier, new.tool_length, new.mode, new.integrator, new.guard,
              dt=new.dt)
    return {"old": old, "new": new}


class Collections:
    """The cycle collector's runs while it is installed (gc.callbacks), by the side whose ticks
    were running: how many, the longest."""

    def __init__(self) -> None:
        self.side, self._start = "", 0
        self.runs: dict[str, int] = {}
        self.longest_ns: dict[str, int] = {}

    def __call__(self, phase: str, info: dict) -> None:
        if phase == "start":
            self._start = time.perf_counter_ns()
        else:
            self.runs[self.side] = self.runs.get(self.side, 0) + 1
            self.longest_ns[self.side] = max(self.longest_ns.get(self.side, 0),
                                             time.perf_counter_ns() - self._start)


def run(Old, points: int, ticks: int, regime: str, collections: Collections) -> dict[str, list[int]]:
    sides = controllers(Old, points)
    wrenches = [guidance(i * 0.004) for i in range(ticks)]
    times: dict[str, list[int]] = {side: [] for side in sides}
    frozen = regime != "on"
    if frozen:
        gc.collect()
        gc.freeze()
    if regime == "frozen+off":
        gc.disable()
    gc.callbacks.append(collections)
    try:
        for start in range(0, ticks, BLOCK):
            for side, c in sides.items():
                collections.side = side
                out = times[side]
                for w in wrenches[start:start + BLOCK]:
                    t0 = time.perf_counter_ns()
                    c.step(w)
                    out.append(time.perf_counter_ns() - t0)
    finally:
        gc.callbacks.remove(collections)
        if frozen:
            gc.enable()
            gc.unfreeze()
    if regime == "frozen+off" and gc.collect() != 0:
        print("note: the loop left cycles for the collector", file=sys.stderr)
    return times


def allocated_kib(c, ticks: int = 200) -> float:
    """Median over ticks of the peak traced memory during a step above what was traced before it."""
    peaks = []
    tracemalloc.start()
    try:
        for i in range(ticks):
            w = guidance(i * 0.004)
            tracemalloc.reset_peak()
            base = tracemalloc.get_traced_memory()[0]
            c.step(w)
            peaks.append(tracemalloc.get_traced_memory()[1] - base)
    finally:
        tracemalloc.stop()
    peaks.sort()
    return peaks[len(peaks) // 2] / 1024


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", default="3b34d1f")
    ap.add_argument("--ticks", type=int, default=10_000)
    ap.add_argument("--points", type=int, default=10_000)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        Old = old_controller_class(args.old, Path(tmp))
        kib = {side: allocated_kib(c) for side, c in controllers(Old, args.points).items()}
        for regime in ("on", "frozen", "frozen+off"):
            collections = Collections()
            times = run(Old, args.points, args.ticks, regime, collections)
            for side in ("old", "new"):
                stats = latency(times[side], unit=1e-6)
                rows.append({"case": f"step tip {args.points} pts", "side": side,
                             "commit": args.old if side == "old" else "this",
                             "gc": regime,
                             "ticks": args.ticks, **{k: round(v, 3) for k, v in stats.items()},
                             "over_1ms": sum(t > 1e6 for t in times[side]),
                             "over_2ms": sum(t > 2e6 for t in times[side]),
                             "kib_per_tick": round(kib[side], 1),
                             "gc_runs": collections.runs.get(side, 0),
                             "longest_gc_ms": round(collections.longest_ns.get(side, 0) / 1e6, 3)})
            old, new = rows[-2], rows[-1]
            new["speedup_median"] = round(old["median_ms"] / new["median_ms"], 2)
            new["speedup_p99"] = round(old["p99_ms"] / new["p99_ms"], 2)
    for r in rows:
        r.setdefault("speedup_median", "")
        r.setdefault("speedup_p99", "")
    record("rcm_tail", rows)
    assert all(math.isfinite(r["max_ms"]) for r in rows)


if __name__ == "__main__":
    main()
