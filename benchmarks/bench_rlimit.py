"""Calibrate the deterministic budget: z3 resource units (rlimit) each library obligation
and each refutation attempt needs, measured with a budget far above any of them.

    python benchmarks/bench_rlimit.py [MODEL ...] [--json benchmarks/results/rlimit.json]

For every obligation it records the units spent by the form that proved it (or, when none
did, by all forms); for refuted models also the units of the refutation search. The
default budget (certiloop.proofs.engine.budget.DEFAULT_RLIMIT) must sit well above the
largest number a proved obligation needs."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from certiloop.models import library
from certiloop.proofs.arith.projection import abbreviation_instances
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.core.weaken import weakenings

HUGE = 10**9


def obligation_cost(ob, wall: float) -> dict:
    spent, start = 0, time.perf_counter()
    forms = list(weakenings(ob.formula, ob.abbreviations, abbreviation_instances, ob.stronger))
    forms.append(("z3", ob.formula))
    for how, f in forms:
        answer = check_valid(f, HUGE, wall)
        spent += answer.spent
        if answer.status == "unsat":
            return {"id": ob.id, "status": "proved", "form": how, "units": answer.spent, "all_units": spent,
                    "seconds": round(time.perf_counter() - start, 3)}
    return {"id": ob.id, "status": answer.status, "form": "", "units": answer.spent, "all_units": spent,
            "seconds": round(time.perf_counter() - start, 3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("models", nargs="*")
    parser.add_argument("--json", default=None)
    parser.add_argument("--wall", type=float, default=60.0)
    args = parser.parse_args()
    rows = []
    for name in args.models or library.names():
        theorem = library.get(name)
        costs = [obligation_cost(ob, args.wall) for ob in generate(theorem)]
        proved = [c for c in costs if c["status"] == "proved"]
        worst = max(proved, key=lambda c: c["units"], default=None)
        row = {"model": name, "obligations": len(costs), "proved": len(proved),
               "max_units": worst["units"] if worst else 0, "max_units_id": worst["id"] if worst else "",
               "total_units": sum(c["all_units"] for c in costs),
               "seconds": round(sum(c["seconds"] for c in costs), 2)}
        rows.append(row)
        print(f"{name:38} {row['proved']:>4}/{row['obligations']:<4} max {row['max_units']:>12,} "
              f"total {row['total_units']:>14,}  {row['seconds']:>7.2f} s", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
