"""Shared helpers for benchmarks: timed repeats, a printed table, a JSON record."""

from __future__ import annotations

import json
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).parent / "results"


def wall(cmd: list[str], repeats: int) -> list[float]:
    """Wall-clock seconds of a command, start-up included, `repeats` times."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=False, capture_output=True)
        times.append(time.perf_counter() - t0)
    return times


def summary(times: list[float]) -> dict[str, float]:
    return {"median_s": statistics.median(times), "min_s": min(times), "max_s": max(times),
            "runs": len(times)}


def latency(samples, unit: float = 1.0, suffix: str = "ms") -> dict[str, float]:
    """Median, p99 and max of per-call times (each times `unit`): a control loop lives by its
    worst tick, so every kernel's record gives all three."""
    ordered = sorted(samples)
    n = len(ordered)
    return {f"median_{suffix}": statistics.median(ordered) * unit,
            f"p99_{suffix}": ordered[min(n - 1, int(0.99 * n))] * unit, f"max_{suffix}": ordered[-1] * unit}


def record(name: str, rows: list[dict]) -> None:
    """Print rows as a table and write them, with machine facts, to results/NAME.json."""
    keys = list(rows[0])
    widths = [max(len(k), *(len(_fmt(r[k])) for r in rows)) for k in keys]
    print("  ".join(k.ljust(w) for k, w in zip(keys, widths)))
    for r in rows:
        print("  ".join(_fmt(r[k]).ljust(w) for k, w in zip(keys, widths)))
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / f"{name}.json"
    if path.exists() and "model" in keys:  # a run over some models keeps the others' rows
        measured = {r["model"] for r in rows}
        rows = [r for r in json.loads(path.read_text())["rows"] if r.get("model") not in measured] + rows
    payload = {"benchmark": name, "python": sys.version.split()[0], "machine": platform.machine(),
               "cores": _cores(), "load_average_1_5_15min": _load(), "date": time.strftime("%Y-%m-%d"),
               "rows": rows}
    path.write_text(json.dumps(payload, indent=2) + "\n")


def _cores() -> int:
    import os

    return os.cpu_count() or 1


def _load() -> list[float] | None:
    """The machine's load when the record was written: a latency tail taken beside other work
    (load above the cores) shows the scheduler, not the code."""
    import os

    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def _fmt(x) -> str:
    return f"{x:.3f}" if isinstance(x, float) else str(x)
