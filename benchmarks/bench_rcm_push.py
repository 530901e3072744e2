"""The RCM paper's 4 ms penetration, found by search (`certiloop falsify rcm.push_*`): for each
kernel scenario, the least peak push the search finds that enters the cloud (brute-force
replay), or the closest clearance if none enters; the least steady axial push that enters;
and the figure of the found push replayed with and without the proved guard.

    python benchmarks/bench_rcm_push.py [--max-examples 60] [--points 1000]
    -> results/rcm_push.json, results/plots/rcm_push.png
"""

from __future__ import annotations

import argparse
import time

from common import RESULTS, record

from certiloop.studies.rcm.push import SCENARIOS, search, steady_threshold
from certiloop.studies.rcm.push_plot import plot_push


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-examples", type=int, default=60)
    ap.add_argument("--points", type=int, default=1000)
    args = ap.parse_args()
    rows, found = [], None
    for name in SCENARIOS:
        t0 = time.perf_counter()
        r = search(name, max_examples=args.max_examples, points=args.points)
        seconds = round(time.perf_counter() - t0, 1)
        if r.run is None:
            value = f"none entered; closest {r.closest * 1000:.3f} mm"
        else:
            value = (f"peak {r.run.profile.peak():.2f} N enters at {r.run.first_entry * 4} ms, "
                     f"{-r.run.clearance.min() * 1000:.3f} mm deep")
            found = found or (r, name)
        rows.append({"measure": name, "profiles": r.examples, "seconds": seconds, "value": value})
    for name in ("rcm.push_euler", "rcm.push_semi_implicit"):
        lo, hi = steady_threshold(name, points=args.points)
        rows.append({"measure": f"{name}: least steady axial push that enters within 2 s", "profiles": "",
                     "seconds": "", "value": f"between {lo:.2f} and {hi:.2f} N"})
    record("rcm_push", rows)
    if found:
        (RESULTS / "plots").mkdir(exist_ok=True)
        plot_push(found[0].run, found[1], RESULTS / "plots" / "rcm_push.png", points=args.points)


if __name__ == "__main__":
    main()
