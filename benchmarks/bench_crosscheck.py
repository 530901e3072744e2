"""Cross-check every library obligation z3 proves with cvc5, on the exact formula z3 proved.

    python benchmarks/bench_crosscheck.py [--rlimit N] [--wall S] [--jobs J] [model ...]

discharge_one may prove a weakening of an obligation (instantiated, lowered, abstracted);
its result names the weakening (`backend`) but does not carry the formula, so this script
recovers it: `weakenings(...)` is deterministic and its labels are unique, so the form whose
label equals `backend` is the one z3 answered unsat on (`z3` alone: the obligation as
stated). Phase 1 runs z3 (discharge_one), phase 2 cvc5 (cross_check); both in a pool.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import pickle
import sys
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from certiloop.models import library
from certiloop.proofs.arith.crosscheck import DEFAULT_RLIMIT, SAFETY_NET_S, cross_check
from certiloop.proofs.arith.projection import abbreviation_instances
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.core.weaken import weakenings
from certiloop.proofs.engine.discharge import discharge_one

_OBLIGATIONS: dict[str, list] = {}


def _obligation(model: str, k: int):
    if model not in _OBLIGATIONS:
        _OBLIGATIONS[model] = generate(library.get(model))
    return _OBLIGATIONS[model][k]


def proved_formula(ob, backend: str):
    """The formula z3 answered unsat on, from discharge_one's `backend` label."""
    if backend == "z3":
        return ob.formula
    forms = [f for label, f in weakenings(ob.formula, ob.abbreviations, abbreviation_instances, ob.stronger)
             if label == backend]
    if len(forms) != 1:
        raise RuntimeError(f"{ob.id}: {len(forms)} weakenings labelled {backend!r}")
    return forms[0]


def z3_phase(task):
    model, k = task
    ob = _obligation(model, k)
    res = discharge_one(ob)
    formula = proved_formula(ob, res.backend) if res.verdict == "proved" else None
    return dict(model=model, id=ob.id, path=ob.path, kind=getattr(ob, "kind", "safety"),
                z3=res.verdict, backend=res.backend, z3_s=res.seconds), formula


def cvc5_phase(task):
    formula, rlimit, wall = task
    c = cross_check(formula, rlimit, wall_s=wall)
    return dict(status=c.status, detail=c.detail, cvc5_s=c.seconds, resources=c.resources)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("models", nargs="*")
    ap.add_argument("--rlimit", type=int, default=DEFAULT_RLIMIT)
    ap.add_argument("--wall", type=float, default=SAFETY_NET_S)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--z3-cache", type=Path, default=None, help="keep/reuse the z3 phase's results")
    args = ap.parse_args()
    models = args.models or library.names()
    tasks = [(m, k) for m in models for k in range(len(generate(library.get(m))))]
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(args.jobs, mp_context=ctx) as pool:
        t0 = time.perf_counter()
        if args.z3_cache and args.z3_cache.exists():
            done = [d for d in pickle.loads(args.z3_cache.read_bytes()) if d[0]["model"] in models]
        else:
            done = []
            for n, d in enumerate(pool.map(z3_phase, tasks, chunksize=1)):
                done.append(d)
                print(f"\rz3: {n + 1}/{len(tasks)} {d[0]['model']} {d[0]['id']} {d[0]['z3']} "
                      f"{d[0]['z3_s']:.1f} s   ", end="", file=sys.stderr, flush=True)
            print(file=sys.stderr)
            if args.z3_cache:
                args.z3_cache.write_bytes(pickle.dumps(done))
        z3_wall = time.perf_counter() - t0
        proved = [(row, f) for row, f in done if f is not None]
        t0 = time.perf_counter()
        checks = list(pool.map(cvc5_phase, [(f, args.rlimit, args.wall) for _, f in proved]))
        cvc5_wall = time.perf_counter() - t0
    rows = [row for row, _ in done]
    for (row, formula), c in zip(proved, checks):
        row.update(c)
        if c["status"] == "disagrees":
            row["formula"] = str(formula)
    per: dict[str, dict] = defaultdict(lambda: defaultdict(float))
    for r in rows:
        p = per[r["model"]]
        p["obligations"] += 1
        p["proved"] += r["z3"] == "proved"
        if "status" in r:
            p[r["status"]] += 1
            p["cvc5_s"] += r["cvc5_s"]
            if r["cvc5_s"] >= p["slowest_s"]:
                p["slowest_s"], p["slowest"] = r["cvc5_s"], r["id"]
            p["max_units"] = max(p["max_units"], r["resources"])
    head = ["model", "obligations", "proved", "confirmed", "disagrees", "unknown", "cvc5_s", "slowest",
            "slowest_s", "max_units"]
    print(" | ".join(head))
    for m in models:
        p = per[m]
        print(" | ".join([m] + [_fmt(p.get(k, 0)) for k in head[1:]]))
    total = {k: sum(per[m].get(k, 0) for m in models) for k in ("obligations", "proved", "confirmed",
                                                                   "disagrees", "unknown", "cvc5_s")}
    print(f"total: {json.dumps({k: round(v, 1) for k, v in total.items()})}; z3 phase {z3_wall:.1f} s, "
          f"cvc5 phase {cvc5_wall:.1f} s wall on {args.jobs} workers (rlimit {args.rlimit:,}, "
          f"safety net {args.wall:g} s)")
    for r in rows:
        if r.get("status") == "unknown":
            print(f"  unknown {r['model']} {r['id']} ({r['backend']}): {r['detail']}")
    for r in rows:
        if r.get("status") == "disagrees":
            print(f"!! DISAGREES {r['model']} {r['id']} {r['path']}\n   {r['formula']}\n"
                  f"   cvc5: {r['detail']}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    sys.exit(1 if total["disagrees"] else 0)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.2f}" if not v.is_integer() else str(int(v))
    return str(v)


if __name__ == "__main__":
    main()
