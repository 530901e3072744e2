"""Start-up of the commands a user waits on most often: `certiloop --help` and `certiloop list`
(table and --json), as subprocesses with output piped, wall time with interpreter start-up.

    python benchmarks/bench_cli_startup.py [--runs 15] [--old PATH/TO/OLD/venv/bin/certiloop]

`list` is timed with its stored listing in place ("stored": every call after the first while
nothing it depends on changes) and without ("built": a fresh $CERTILOOP_CACHE for each run,
so the library's theorems are built and checked and the table laid out). With --old, another
checkout's console script (e.g. a venv installed from an older commit) is timed in the same
run, the two interleaved run by run so that a busy moment of the machine hits both. Median,
min and max over the runs; writes results/cli_startup.json (the load average is in it).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import record

CASES = {"--help": ["--help"], "list": ["list"], "list --json": ["list", "--json"]}


def once(cli: str, args: list[str], cache: str) -> float:
    env = {**os.environ, "CERTILOOP_CACHE": cache}
    t0 = time.perf_counter()
    proc = subprocess.run([cli, *args], capture_output=True, env=env, check=False)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{cli} {' '.join(args)} failed: {proc.stderr.decode()[-500:]}")
    return elapsed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--old", help="another checkout's certiloop console script, timed beside this one")
    args = ap.parse_args()
    sides = {"new": str(Path(sys.executable).with_name("certiloop"))}
    if args.old:
        sides = {"old": args.old, **sides}
    times: dict[tuple[str, str, str], list[float]] = {}
    with tempfile.TemporaryDirectory() as stored:
        for cli in sides.values():   # the stored listings, made once
            for case in ("list", "list --json"):
                once(cli, CASES[case], stored)
        for _ in range(args.runs):
            for case, cli_args in CASES.items():
                modes = ("stored", "built") if case.startswith("list") else ("",)
                for mode in modes:
                    for side, cli in sides.items():
                        if mode == "built":
                            with tempfile.TemporaryDirectory() as fresh:
                                t = once(cli, cli_args, fresh)
                        else:
                            t = once(cli, cli_args, stored)
                        times.setdefault((case, mode, side), []).append(t)
    rows = []
    for (case, mode, side), ts in times.items():
        rows.append({"case": f"certiloop {case}" + (f" ({mode})" if mode else ""), "side": side,
                     "median_s": round(statistics.median(ts), 4), "min_s": round(min(ts), 4),
                     "max_s": round(max(ts), 4), "runs": len(ts), "target_s": 0.2})
    rows.sort(key=lambda r: (r["case"], r["side"]))
    with tempfile.TemporaryDirectory() as stored:
        for side, cli in sides.items():
            once(cli, ["list"], stored)
            rows.append({"case": "imports of certiloop list (stored), top 8, ms", "side": side,
                         "median_s": "", "min_s": "", "max_s": "", "runs": 1, "target_s": "",
                         "imports_ms": slowest_imports(cli, stored)})
    for r in rows:
        r.setdefault("imports_ms", "")
    record("cli_startup", rows)


def slowest_imports(cli: str, cache: str, top: int = 8) -> dict[str, float]:
    """The top-level imports of `certiloop list` with the largest cumulative time (-X importtime)."""
    python = str(Path(cli).with_name("python"))
    env = {**os.environ, "CERTILOOP_CACHE": cache}
    err = subprocess.run([python, "-X", "importtime", "-m", "certiloop.cli", "list"], capture_output=True,
                         text=True, env=env, check=False).stderr
    found = {}
    for line in err.splitlines():
        parts = line.split("|")
        if len(parts) == 3 and parts[1].strip().isdigit() and not parts[2].startswith("  "):
            found[parts[2].strip()] = int(parts[1]) / 1000
    return dict(sorted(found.items(), key=lambda kv: -kv[1])[:top])


if __name__ == "__main__":
    main()
