"""Falsifier robustness and interpreter throughput.

For every refuted library model, over 20 seeds: how many seeds find a (re-checked)
counterexample within 2,000 examples, and the median examples and seconds to the first
one (shrinking off: time to *find*). Then control steps per second of the interpreter on
sbs.ctrl2 with 10 boundaries.

    python benchmarks/bench_falsify.py [--seeds 20] [--max-examples 2000] [--only cfmpa.]
"""

from __future__ import annotations

import argparse
import statistics
import time

from common import record

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


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--max-examples", type=int, default=2000)
    ap.add_argument("--only", default="", metavar="PREFIX",
                    help="only models whose name starts so (e.g. cfmpa.); the other rows are kept")
    args = ap.parse_args()
    record("falsify", robustness(args.seeds, args.max_examples, args.only))
    if not args.only:
        record("interpreter", [throughput()])


if __name__ == "__main__":
    main()
