"""`certiloop falsify rcm.push_*`: the human-force search on the RCM paper's controller
(`studies/rcm/push.py`), its report, JSON and figure."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

EXIT_OK, EXIT_FOUND = 0, 1


def run(args: argparse.Namespace, out, level: int) -> tuple[int, list[dict]]:
    """Search every named scenario; returns the exit code and the JSON documents."""
    from certiloop.cli import ui
    from certiloop.studies.rcm.push import SCENARIOS, search

    unknown = [n for n in args.models if n not in SCENARIOS]
    if unknown:
        raise ValueError(f"unknown kernel scenario {unknown[0]!r}; choose among {', '.join(SCENARIOS)}")
    docs, found = [], 0
    for name in args.models:
        start = time.perf_counter()
        result = search(name, max_examples=args.max_examples, seed=args.seed)
        doc = result.to_json()
        doc["seconds"] = round(time.perf_counter() - start, 2)
        docs.append(doc)
        if result.run is None:
            ui.say(out, f"{name}: no push entered the region in {result.examples} profiles searched "
                        f"(closest clearance {result.closest * 1000:.3f} mm; {doc['seconds']} s)")
            continue
        found += 1
        r = result.run
        ui.say(out, f"{name}: a push of at most {r.profile.peak():.2f} N enters the region at period "
                    f"{r.first_entry} ({r.first_entry * 4} ms), {-r.clearance.min() * 1000:.3f} mm deep "
                    f"(brute-force replay); found after {result.found_after} profiles, shrunk in "
                    f"{result.shrink_runs} replays ({doc['seconds']} s)")
        if level > ui.QUIET:
            ui.say(out, f"  push: {r.profile.describe()}")
        if args.plot:
            from certiloop.studies.rcm.push_plot import plot_push

            target = Path(args.plot)
            if len(args.models) > 1:
                target = target.with_name(f"{target.stem}-{name}{target.suffix}")
            plot_push(r, name, target)
            ui.say(out, f"  plot: {target}")
    return (EXIT_FOUND if found else EXIT_OK), docs
