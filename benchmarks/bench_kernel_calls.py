"""What a Python call of `VirtualFixture.step` costs over the C step it runs: the fixture of
another commit (default ae9f168, loaded from git beside this one) against this one,
interleaved in one process, for 1, 10, 100 and 1,000 planes.

    python benchmarks/bench_kernel_calls.py [--old ae9f168] [--rounds 5] [--calls 2000]

Per size and side: every call timed alone (perf_counter_ns), median, p99 and max over all
rounds; `step+velocity` also reads the command's velocity (this commit builds it when first
read). `c_step_us` is the C step alone, as `step_many` runs it (one C loop over BATCH rows of the
same inputs, median time per row); `overhead_us` what a Python call adds to it. Writes
results/kernel_calls.json.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_kernel import planes
from common import latency, record

from certiloop.studies.sbs.fixture import VirtualFixture

ROOT = Path(__file__).resolve().parent.parent
SIZES = (1, 10, 100, 1000)
BATCH = 50  # rows per timed step_many call


def old_fixture_class(commit: str, folder: Path):
    """VirtualFixture of `commit` (its fixture.py and native.py), as a module of its own."""
    import old_code

    native = old_code.source(commit, "kernel/native.py").replace('Path(__file__).resolve().parent / "c"',
                                                                 f"Path({str(folder / 'c')!r})")
    (folder / "c").mkdir()
    for name in ("sbs_ctrl2.c", "sbs_ctrl2.h", "sbs_ctrl2_fixture.c", "sbs_ctrl2_fixture.h"):
        (folder / "c" / name).write_text(old_code.source(commit, f"kernel/c/{name}"))
    old_code.load("old_native", native, folder)
    fixture = old_code.source(commit, "kernel/fixture.py").replace(
        "from certiloop.studies.sbs import native as native", "import old_native as native")
    return old_code.load("old_fixture", fixture, folder).VirtualFixture


def timed(call, calls: int) -> list[int]:
    out = []
    for _ in range(calls):
        t0 = time.perf_counter_ns()
        call()
        out.append(time.perf_counter_ns() - t0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", default="ae9f168", help="the commit to compare with")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--calls", type=int, default=2000)
    args = ap.parse_args()
    p, f, fp = np.zeros(3), np.array([1.0, -2.0, 0.5]), np.array([0.1, 0.0, -0.3])
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        Old = old_fixture_class(args.old, Path(tmp))
        rng = np.random.default_rng(0)
        for m in SIZES:
            scene = planes(m, rng)
            fixtures = {side: cls(scene, gain=1.0, buffer=0.5, period=0.0182, position_tolerance=np.inf,
                                  backend="c") for side, cls in (("old", Old), ("new", VirtualFixture))}
            samples = {(side, what): [] for side in fixtures for what in ("step", "step+velocity")}
            c_rows = []
            batch = np.tile(np.concatenate([p, f, fp]), (args.calls, 1))
            for _ in range(args.rounds):  # interleaved: a busy moment hits both
                for side, fx in fixtures.items():
                    assert fx.step(p, f, fp).ok
                    samples[side, "step"] += timed(lambda fx=fx: fx.step(p, f, fp), args.calls)
                    samples[side, "step+velocity"] += timed(lambda fx=fx: fx.step(p, f, fp).velocity,
                                                            args.calls)
                for start in range(0, args.calls, BATCH):  # short batches: a preemption spoils few
                    t0 = time.perf_counter_ns()
                    done = fixtures["new"].step_many(batch[start:start + BATCH])
                    c_rows.append((time.perf_counter_ns() - t0) / BATCH)
                    assert done.ok.all()
            c_step = float(np.median(c_rows)) / 1000
            row = {"boundaries": m}
            for side in fixtures:
                for what in ("step", "step+velocity"):
                    stats = latency(samples[side, what], unit=1e-3, suffix="us")
                    row.update({f"{side}_{what}_{k}": round(v, 2) for k, v in stats.items()})
            row["speedup_step_median"] = round(row["old_step_median_us"] / row["new_step_median_us"], 2)
            row["speedup_step+velocity_median"] = round(
                row["old_step+velocity_median_us"] / row["new_step+velocity_median_us"], 2)
            row["c_step_us"] = round(c_step, 2)
            row["new_overhead_us"] = round(row["new_step_median_us"] - c_step, 2)
            row["old_overhead_us"] = round(row["old_step_median_us"] - c_step, 2)
            row.update({"rounds": args.rounds, "calls": args.calls, "old": args.old})
            rows.append(row)
    record("kernel_calls", rows)


if __name__ == "__main__":
    main()
