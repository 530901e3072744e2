"""End-to-end `certiloop prove MODEL` wall time, CLI start-up included.

    python benchmarks/bench_prove.py [--repeats 5] [MODEL ...]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile

from common import record, summary, wall

DEFAULT = ["sbs.ctrl1", "sbs.ctrl1_broken", "cfmpa.builtdr", "textbook.train"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("models", nargs="*", default=DEFAULT)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    rows = []
    for model in args.models:
        cmd = [sys.executable, "-m", "certiloop.cli", "prove", model, "--jobs", str(args.jobs)]
        times = wall(cmd, args.repeats)
        with tempfile.NamedTemporaryFile(suffix=".json") as f:
            subprocess.run(cmd + ["--json", f.name], capture_output=True)
            data = json.load(open(f.name))
        slowest = max(data["obligations"], key=lambda o: o["seconds"])
        rows.append({"model": model, "verdict": data["verdict"], "obligations": len(data["obligations"]),
                     **summary(times), "slowest_obligation": slowest["path"],
                     "slowest_s": slowest["seconds"]})
    record("prove", rows)


if __name__ == "__main__":
    main()
