"""Old and new certiloop side by side: the same commands, interleaved, on one machine.

Machines differ 2-3x in speed, so a number from another machine says little; the ratio of
two installs measured in one sitting does. Install the old commit in its own virtualenv
(`git worktree add /tmp/old a42bfa6 && python3 -m venv /tmp/oldvenv && /tmp/oldvenv/bin/pip
install /tmp/old`), then

    python benchmarks/bench_compare.py --old /tmp/oldvenv/bin/certiloop [--repeats 3]

Each command runs in a fresh empty folder (no proof cache, no example database); `gate
--no-cache` over the models both installs know is the README's main command, cold. Results
go to benchmarks/results/compare.json with the machine's facts.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import tempfile
import time

from common import record

COMMANDS = [
    ["--help"],
    ["list"],
    ["prove", "sbs.ctrl1"],
    ["prove", "sbs.ctrl2"],
    ["prove", "sbs.ctrl2_last_wins"],
    ["falsify", "sbs.ctrl2", "--max-examples", "300", "--database", "none"],
    ["gate", "--no-cache"],
]


def _models(exe: str) -> set[str]:
    out = subprocess.run([exe, "list", "--json"], capture_output=True, text=True)
    if out.returncode == 0:
        return {m["model"] for m in json.loads(out.stdout)}
    # an install without `list --json`: the model names in the first column of its table
    wide = {**os.environ, "COLUMNS": "200"}
    table = subprocess.run([exe, "list"], capture_output=True, text=True, env=wide).stdout
    return set(re.findall(r"^\W*([a-z0-9_]+\.[a-z0-9_]+)\s", table, flags=re.M))


def _run(exe: str, args: list[str]) -> float:
    with tempfile.TemporaryDirectory() as cwd:
        start = time.perf_counter()
        subprocess.run([exe, *args], cwd=cwd, capture_output=True)
        return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--old", required=True, help="the old install's certiloop executable")
    ap.add_argument("--new", default=shutil.which("certiloop") or "certiloop")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--only", nargs="*", help="run only commands starting with these words")
    ap.add_argument("--gate", nargs="*", metavar="MODEL", help="gate these models (default: all both know)")
    ap.add_argument("--old-label", default="old", help="the old install's commit, written in each row")
    args = ap.parse_args()
    common = args.gate or sorted(_models(args.old) & _models(args.new)) or None
    rows = []
    for command in COMMANDS:
        if args.only and command[0] not in args.only:
            continue
        full = command + (common if command[:1] == ["gate"] and common else [])
        old, new = [], []
        for _ in range(args.repeats):  # interleaved: a busy moment hits both
            old.append(_run(args.old, full))
            new.append(_run(args.new, full))
        o, n = statistics.median(old), statistics.median(new)
        name = " ".join(command) + (f" ({len(common)} models)" if command[0] == "gate" and common else "")
        rows.append({"model": name, "old_s": round(o, 2), "new_s": round(n, 2),
                     "old_min_s": round(min(old), 2), "new_min_s": round(min(new), 2),
                     "speedup": round(o / n, 2), "runs": args.repeats, "old": args.old_label})
    record("compare", rows)


if __name__ == "__main__":
    main()
