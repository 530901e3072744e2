"""Falsifier robustness, interpreter throughput, and the command's time beside an older checkout.

For every refuted library model, over 20 seeds: how many seeds find a (re-checked)
counterexample within 2,000 examples, and the median examples and seconds to the first
one (shrinking off: time to *find*). Then control steps per second of the interpreter on
sbs.ctrl2 with 10 boundaries.

    python benchmarks/bench_falsify.py [--seeds 20] [--max-examples 2000] [--only cfmpa.]

With --old PATH/TO/OLD/venv/bin/certiloop (another checkout's console script), only the
command `certiloop falsify sbs.ctrl2 --max-examples 300` (its default --jobs) is timed, old
and new interleaved run by run (each in a fresh folder, so with an empty example database)
so that a busy moment of the machine hits both: wall seconds and CPU seconds (user + system,
forked children included), median, min and max; the two JSON results must agree but for
their seconds. Then where each side's CPU goes, run in one process one after the other:
imports, the batch phase, the hypothesis search. The row goes into results/falsify.json.

    python benchmarks/bench_falsify.py --old /path/old/.venv/bin/certiloop [--runs 5]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import record, summary

from certiloop.falsify.choosers import RandomChooser
from certiloop.falsify.interpreter import Interpreter, Rejected
from certiloop.falsify.search import Options, falsify
from certiloop.models import library


def robustness(seeds: int, max_examples: int, only: str = "") -> list[dict]:
    rows = []
    for name in library.names():
        theorem = library.get(name)
        if theorem.expected != "refuted" or not name.startswith(only):
            continue
        found = [falsify(theorem, Options(max_examples=max_examples, seed=s, database=None, shrink=False))
                 for s in range(seeds)]
        hits = [r for r in found if r.found]
        rows.append({"model": name, "found": f"{len(hits)}/{seeds}",
                     "median_examples": statistics.median(r.examples for r in hits) if hits else None,
                     "median_s": round(statistics.median(r.seconds for r in hits), 3) if hits else None})
    return rows


def throughput(boundaries: int = 10, runs: int = 200) -> dict:
    interp = Interpreter(library.get("sbs.ctrl2"), max_steps=5, families=(boundaries, boundaries))
    steps, start = 0, time.perf_counter()
    for seed in range(runs):
        try:
            steps += interp.run(RandomChooser(seed)).checkpoints[-1].step
        except Rejected:
            continue
    seconds = time.perf_counter() - start
    return {"model": f"sbs.ctrl2, {boundaries} boundaries", "control_steps": steps,
            "steps_per_s": round(steps / seconds, 1)}


COMMAND = ["falsify", "sbs.ctrl2", "--max-examples", "300"]

# run by either side's python: CPU seconds of imports, the batch phase and the hypothesis
# search of `falsify sbs.ctrl2` (300 examples, one process; the module moved between versions)
PHASES = """
import json, pathlib, sys, tempfile, threading, time
t0 = time.process_time()
def main():
    try:
        import certiloop.falsify.batch.phase as phase
    except ImportError:
        import certiloop.falsify.batch_search as phase
    from certiloop.falsify import search
    from certiloop.models import library
    imported = time.process_time() - t0
    spent = {}
    inner = phase.batch_search
    def timed(*a, **k):
        t = time.process_time(); out = inner(*a, **k); spent["batch"] = time.process_time() - t
        return out
    phase.batch_search = timed
    t = time.process_time()
    r = search.falsify(library.get("sbs.ctrl2"), search.Options(max_examples=300, seed=0,
                       database=pathlib.Path(tempfile.mkdtemp())))
    rest = time.process_time() - t - spent["batch"]
    import cProfile, pstats
    profile = cProfile.Profile()
    profile.runcall(search.falsify, library.get("sbs.ctrl2"), search.Options(max_examples=300, seed=0,
                    database=pathlib.Path(tempfile.mkdtemp())))
    stats = pstats.Stats(profile).stats
    top = sorted(stats.items(), key=lambda kv: -kv[1][2])[:12]  # own time, under the profiler
    print(json.dumps({"imports_s": round(imported, 2), "batch_phase_s": round(spent["batch"], 2),
                      "hypothesis_search_s": round(rest, 2), "verdict": r.verdict, "examples": r.examples,
                      "top_own_time_profiled_s": [f"{'/'.join(f.split('/')[-2:])}:{fn} {v[2]:.2f}"
                                                  for (f, _line, fn), v in top]}))
sys.setrecursionlimit(100_000)
threading.stack_size(1 << 28)  # as the command: deeply nested models on a large stack
worker = threading.Thread(target=main)
worker.start()
worker.join()
"""


def _cli_once(cli: str, extra: tuple[str, ...] = ()) -> tuple[float, float, dict]:
    """Wall and CPU seconds (forked children included) of the command in a fresh folder, and its
    JSON result without its seconds."""
    with tempfile.TemporaryDirectory() as folder:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        proc = subprocess.run([cli, *COMMAND, *extra, "--json", "out.json"], cwd=folder, capture_output=True,
                              check=False)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if proc.returncode not in (0, 1):
            raise SystemExit(f"{cli} failed: {proc.stderr.decode()[-500:]}")
        result = json.loads((Path(folder) / "out.json").read_text())
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    result.pop("seconds", None)
    return wall, cpu, result


def versus(old: str, runs: int, jobs: int | None = None) -> dict:
    sides = {"old": old, "new": str(Path(sys.executable).with_name("certiloop"))}
    walls: dict[str, list[float]] = {k: [] for k in sides}
    cpus: dict[str, list[float]] = {k: [] for k in sides}
    results = {}
    for _ in range(runs):
        for side, cli in sides.items():
            extra = ("--jobs", str(jobs)) if jobs and side == "new" else ()
            wall, cpu, results[side] = _cli_once(cli, extra)
            walls[side].append(wall)
            cpus[side].append(cpu)
    if results["old"] != results["new"]:
        raise SystemExit(f"the results differ: old {results['old']}, new {results['new']}")
    phases = {side: json.loads(subprocess.run([str(Path(cli).with_name("python")), "-c", PHASES],
                                              capture_output=True, check=True, text=True).stdout)
              for side, cli in sides.items()}
    row = {"model": f"cli: falsify sbs.ctrl2 --max-examples 300{f' (new: --jobs {jobs})' if jobs else ''}",
           "jobs": f"{jobs or f'default ({min(2, os.cpu_count() or 1)})'}; the old one has no --jobs",
           "result": f"{results['new']['verdict']} in {results['new']['examples']} examples (both)"}
    for side in sides:
        row[f"{side}_wall"] = {k: round(v, 2) for k, v in summary(walls[side]).items()}
        row[f"{side}_cpu"] = {k: round(v, 2) for k, v in summary(cpus[side]).items()}
    row["wall_ratio_median"] = round(statistics.median(walls["old"]) / statistics.median(walls["new"]), 2)
    row["cpu_ratio_median"] = round(statistics.median(cpus["old"]) / statistics.median(cpus["new"]), 2)
    row["cpu_profile_old"] = phases["old"]
    row["cpu_profile_new"] = phases["new"]
    return row


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", help="another checkout's certiloop console script: time the command beside it")
    ap.add_argument("--runs", type=int, default=5, help="runs of each side with --old (default 5)")
    ap.add_argument("--jobs", type=int, help="with --old: the new side's --jobs (default: its default)")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--max-examples", type=int, default=2000)
    ap.add_argument("--only", default="", metavar="PREFIX",
                    help="only models whose name starts so (e.g. cfmpa.); the other rows are kept")
    args = ap.parse_args()
    if args.old:
        record("falsify", [versus(args.old, args.runs, args.jobs)])
        return
    record("falsify", robustness(args.seeds, args.max_examples, args.only))
    if not args.only:
        record("interpreter", [throughput()])


if __name__ == "__main__":
    main()
