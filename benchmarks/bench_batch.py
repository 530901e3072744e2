"""The falsifier, old install vs new, side by side on one machine: runs per second, time to
the first confirmed counterexample, and `certiloop falsify` on every refuted model.

    python benchmarks/bench_batch.py --old-python /tmp/oldvenv/bin/python [--seeds 5]

* runs/s: the old install's hypothesis search (examples per second, shrinking off, no
  example database, 200 examples; violations are not confirmed, so a refuted model's
  search runs them all: a rate of runs, not a time to a hit) against the new batch
  simulator (runs per second over two batches of 4,096, compiled once beforehand; the
  one-off compile time is listed apart; a model with families runs each 4,096 as one batch
  per family size 1..8, as the search does). A model the batch cannot compile falls back to
  hypothesis in the new install too; its new figure is then the hypothesis rate. With
  --hypothesis, the new install's own per-run search is measured too (`ratio_vs_hyp`).
* time to first counterexample: `falsify` (shrinking off) of each refuted model for
  seeds 0..N-1 in each install: seeds that found one, median seconds.
* CLI: `certiloop falsify MODEL --database none` (the CLI's budget, shrinking on) once per
  refuted model and install: exit code and seconds.
* ab: in the new install alone, the falsifier (300 examples) per model with the batch
  phase off and on, and the gate's own falsifier task: its cost on safe models, its gain on
  unsafe ones, the same verdicts (CPU seconds, one process).

Each measurement runs in a fresh process of the install's own Python, old and new
interleaved per model. Results: benchmarks/results/batch.json.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import record

WORKER = r'''
import json, statistics, sys, time
from certiloop.falsify.search import Options, falsify
from certiloop.models import library
mode, name, seeds = sys.argv[1], sys.argv[2], int(sys.argv[3])
try:
    th = library.get(name)
except Exception:  # a model this install does not have
    print(json.dumps({"missing": True}))
    raise SystemExit(0)
out = {}


def hypothesis_rate():
    """(runs, seconds) of this install's per-run hypothesis search."""
    import certiloop.falsify.search as search
    # count runs, not the time to a hit: no violation is confirmed, so the search
    # draws all its examples (the batch's rate, too, leaves replays out)
    search.confirm = lambda *a, **k: ""
    search._deep = lambda run: False
    opts = dict(max_examples=200, seed=0, database=None, shrink=False)
    if "batch_runs" in Options.__dataclass_fields__:
        opts["batch_runs"] = 0
    t = time.perf_counter(); r = falsify(th, Options(**opts))
    return r.examples, time.perf_counter() - t


if mode == "rate":
    try:
        import numpy as np
        from certiloop.falsify.batch.program import compiled
        t = time.perf_counter(); program = compiled(th, 3); out["compile_s"] = time.perf_counter() - t
        # a model with families: each 4,096 runs split over the search's sizes (1..8), a batch per size
        sizes = program.sizes((1, 8)) if hasattr(program, "sizes") else [0]
        rng = np.random.default_rng(0)
        t = time.perf_counter(); runs = 0; started = 0
        for _ in range(2):
            for m in sizes:
                count = 4096 // len(sizes)
                b = program.simulate(rng, count, m) if m else program.simulate(rng, count)
                runs += count; started += int(b.completed.sum())
        dt = time.perf_counter() - t
        out.update(batch=True, runs=runs, completed=started, seconds=dt)
        if "--with-hypothesis" in sys.argv:  # this install's per-run search on the same model
            out["hyp_runs"], out["hyp_seconds"] = hypothesis_rate()
    except Exception as exc:  # the old install, or a model outside the batch fragment
        runs, dt = hypothesis_rate()
        out.update(batch=False, runs=runs, seconds=dt, why=type(exc).__name__)
elif mode == "first":
    rows = []
    for seed in range(seeds):
        t = time.perf_counter()
        r = falsify(th, Options(seed=seed, database=None, shrink=False))
        rows.append((r.found, time.perf_counter() - t, getattr(r, "phase", "hypothesis")))
    out["found"] = sum(f for f, _, _ in rows)
    out["median_s"] = statistics.median(s for f, s, _ in rows if f) if out["found"] else None
    out["phases"] = sorted({p for f, _, p in rows if f})
print(json.dumps(out))
'''


def _worker(python: str, mode: str, name: str, seeds: int = 1, *extra: str) -> dict:
    with tempfile.TemporaryDirectory() as cwd:
        script = Path(cwd) / "worker.py"
        script.write_text(WORKER)
        got = subprocess.run([python, str(script), mode, name, str(seeds), *extra], cwd=cwd,
                             capture_output=True, text=True)
    if got.returncode != 0:
        raise SystemExit(f"worker failed on {name}: {got.stderr.strip().splitlines()[-1:]}")
    return json.loads(got.stdout.strip().splitlines()[-1])


def _cli(exe: str, name: str) -> tuple[int, float]:
    with tempfile.TemporaryDirectory() as cwd:
        start = time.perf_counter()
        got = subprocess.run([exe, "falsify", name, "--database", "none"], cwd=cwd, capture_output=True)
        return got.returncode, time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--old-python", required=True, help="the old install's python")
    ap.add_argument("--new-python", default=sys.executable)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--only", choices=["rate", "first", "cli", "ab"], nargs="*")
    ap.add_argument("--models", nargs="*")
    ap.add_argument("--hypothesis", action="store_true",
                    help="rate: also this install's per-run hypothesis search, in the same worker")
    args = ap.parse_args()
    old_cli = str(Path(args.old_python).with_name("certiloop"))
    new_cli = str(Path(args.new_python).with_name("certiloop"))
    if not Path(new_cli).exists():
        new_cli = shutil.which("certiloop") or "certiloop"
    from certiloop.models import library

    refuted = [n for n in library.names() if library.get(n).expected == "refuted"]
    rate_models = args.models or (["sbs.ctrl2", "sbs.ctrl1"]
                                  + [n for n in library.names() if n.startswith("textbook.")]
                                  + [n for n in refuted if not n.startswith("textbook.")])
    todo = args.only or ["rate", "first", "cli", "ab"]
    if "ab" in todo:
        record("batch_ab", _ab(args.models or library.names()))
    if "rate" in todo:
        rows = []
        for name in rate_models:
            old = _worker(args.old_python, "rate", name)
            extra = ["--with-hypothesis"] if args.hypothesis else []
            new = _worker(args.new_python, "rate", name, 1, *extra)
            if old.get("missing") or new.get("missing"):
                continue
            o, n = old["runs"] / old["seconds"], new["runs"] / new["seconds"]
            row = {"model": name, "old_runs_s": round(o, 1), "new_runs_s": round(n, 1),
                   "ratio": round(n / o, 1), "new_path": "batch" if new["batch"] else "hypothesis",
                   "compile_s": round(new.get("compile_s", 0.0), 2),
                   "completed": f"{new.get('completed', new['runs'])}/{new['runs']}"}
            if args.hypothesis:  # the batch against this install's own per-run search
                h = new["hyp_runs"] / new["hyp_seconds"] if "hyp_runs" in new else n
                row.update(new_hyp_runs_s=round(h, 1), ratio_vs_hyp=round(n / h, 1))
            rows.append(row)
        record("batch_rate", rows)
    if "first" in todo:
        rows = []
        for name in (args.models or refuted):
            old = _worker(args.old_python, "first", name, args.seeds)
            new = _worker(args.new_python, "first", name, args.seeds)
            if old.get("missing") or new.get("missing"):
                continue
            both = old["median_s"] and new["median_s"]
            rows.append({"model": name, "old_found": f"{old['found']}/{args.seeds}",
                         "new_found": f"{new['found']}/{args.seeds}",
                         "old_median_s": _round(old["median_s"]), "new_median_s": _round(new["median_s"]),
                         "ratio": _round(old["median_s"] / new["median_s"]) if both else None,
                         "new_phase": ",".join(new["phases"])})
        record("batch_first", rows)
    if "cli" in todo:
        rows = []
        for name in (args.models or refuted):
            if _worker(args.old_python, "first", name, 0).get("missing"):
                continue
            (oc, os_), (nc, ns) = _cli(old_cli, name), _cli(new_cli, name)
            rows.append({"model": name, "old_exit": oc, "new_exit": nc, "old_s": round(os_, 2),
                         "new_s": round(ns, 2), "ratio": round(os_ / ns, 1)})
        record("batch_cli", rows)


def _ab(names: list[str]) -> list[dict]:
    """The falsifier (300 examples, shrinking off, seed 0) in this install, in one process:
    hypothesis alone, the batch phase then hypothesis, and the gate's own task (which gives a
    model expected proved 100 hypothesis examples once its batch runs found nothing): what
    the batch phase adds to or saves from the gate. Seconds are CPU seconds of this process."""
    from certiloop.api.gate_run import GateOptions, falsify_task
    from certiloop.falsify.search import Options, falsify
    from certiloop.models import library

    rows = []
    for name in names:
        theorem = library.get(name)
        got = {}
        for runs in (0, 4096):
            start = time.process_time()
            found = falsify(theorem, Options(max_examples=300, seed=0, database=None, shrink=False,
                                             batch_runs=runs))
            got[runs] = (time.process_time() - start, found)
        start = time.process_time()
        gate = falsify_task(theorem, GateOptions(falsify_examples=300, seed=0))
        gate_s = time.process_time() - start
        rows.append({"model": name, "expected": theorem.expected, "hypothesis_s": round(got[0][0], 2),
                     "batch_then_hyp_s": round(got[4096][0], 2), "gate_task_s": round(gate_s, 2),
                     "found": f"{got[0][1].found}/{got[4096][1].found}/{gate.found}",
                     "phase": got[4096][1].phase})
    return rows


def _round(x):
    return None if x is None else round(x, 3)


if __name__ == "__main__":
    main()
