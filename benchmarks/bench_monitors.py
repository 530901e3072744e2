"""Latency of the generated ModelPlex-style monitors (`certiloop extract MODEL --monitors`):
controller_monitor on the extracted controller's own command, and plant_monitor on one step
(closed form for textbook.train, the interval enclosure for rcm.barrier_continuous), medians.

    python benchmarks/bench_monitors.py [--calls 300]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from common import record

from certiloop.kernel.extract import extract
from certiloop.kernel.extract.modelplex import monitors
from certiloop.models import library


def load(src: str) -> dict:
    ns: dict = {}
    exec(compile(src, "<generated>", "exec"), ns)
    return ns


def median_us(fn, calls: int) -> float:
    times = []
    for _ in range(calls):
        t0 = time.perf_counter_ns()
        fn()
        times.append(time.perf_counter_ns() - t0)
    return statistics.median(times) / 1000


def ctrl2_values(m: int, rng) -> dict:
    normals = rng.normal(size=(m, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = -rng.uniform(0.5, 3.0, size=(m, 1)) * normals  # the origin is on every safe side
    return {"px": 0.0, "py": 0.0, "pz": 0.0, "fx": 1.0, "fy": -2.0, "fz": 0.5, "fxp": 0.1, "fyp": 0.0,
            "fzp": -0.3, "G": 1.0, "D": 0.5, "e": 0.0182,
            **{f"n{x}": normals[:, a] for a, x in enumerate("xyz")},
            **{f"r{x}": points[:, a] for a, x in enumerate("xyz")}}


def controller_row(name: str, values: dict, calls: int, label: str) -> dict:
    t = library.get(name)
    c, m = load(extract(t)), load(monitors(t))
    *out, enabled = c["controller"](*[values[k] for k in c["INPUTS"] + c["FAMILIES"]])
    assert enabled
    state, command = {k: values[k] for k in m["STATE"]}, dict(zip(m["COMMAND"], out))
    assert m["controller_monitor"](state, command) is True
    return {"monitor": f"controller_monitor {name}{label}",
            "median_us": round(median_us(lambda: m["controller_monitor"](state, command), calls), 1)}


TRAIN = {"p": 50.0, "vt": 5.0, "A": 1.0, "b": 2.0, "m": 100.0, "eps": 0.5}
PREDICTIVE = {"px": 0.0, "py": 0.5, "rx": 0.0, "ry": 0.0, "nx": 0.0, "ny": 1.0, "fx": 0.0, "fy": -1.0,
              "fxp": 0.0, "fyp": -1.0, "G": 1.0, "e": 1.0}


def plant_row(name: str, prev: dict, nxt: dict, dt: float, tol: float, calls: int, how: str) -> dict:
    m = load(monitors(library.get(name)))
    m["plant_monitor"](prev, nxt, dt, tol)
    return {"monitor": f"plant_monitor {name} ({how})",
            "median_us": round(median_us(lambda: m["plant_monitor"](prev, nxt, dt, tol), calls), 1)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=300)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    rows = [controller_row("textbook.train", TRAIN, args.calls, ""),
            controller_row("sbs.predictive", PREDICTIVE, args.calls, "")]
    for m in (1, 10, 100):
        calls = max(10, args.calls // m)
        rows.append(controller_row("sbs.ctrl2", ctrl2_values(m, rng), calls, f" ({m} planes)"))
    rows.append(plant_row("textbook.train", {"p": 0.0, "vt": 2.0, "t": 0.0, "a": -2.0, "eps": 0.5},
                          {"p": 0.75, "vt": 1.0}, 0.5, 1e-9, args.calls, "closed form"))
    barrier = {"gap": 0.0066, "w": 0.0002, "L": 0.0, "e": 0.0, "F": -0.9, "dmp": 1.0, "Ebar": 10.0}
    rows.append(plant_row("rcm.barrier_continuous", barrier,
                          {"gap": 0.0066}, 0.005, 1e-6, max(10, args.calls // 10), "enclosure, 16 substeps"))
    record("monitors", rows)


if __name__ == "__main__":
    main()
