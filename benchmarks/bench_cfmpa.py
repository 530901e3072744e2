"""The dual-arm paper's qualitative claims and builtDR / planner timing on the dual-arm scenes.

    python benchmarks/bench_cfmpa.py [--dt 0.2 0.1] [--queries 40] [--check] [--plot DIR]

For each scene and Δt: builtDR for the original and the modified swept region (median of
--repeats), the free fractions, seeded (start, goal) queries planned on both databases, and the
swept-part ratio: the area the principal's enclosure adds to its static arm, modified over
original (median over layers; shapely computes the areas here, never in the kernel).

--check exits 0 only when the paper's three claims hold: the modified database frees at least
as many cells everywhere and strictly more in R1; at least one query succeeds only with the
modified region (its plan accepted by the checker); none succeeds only with the original.
Writes benchmarks/results/cfmpa.json.

--soundness [--samples 20000] [--scenes 40] (the spec's B4) samples, for each scene and Δt,
instants inside free cells next to occupied ones -- the principal on its planned motion at
(k + λ)Δt, the subordinate anywhere on a king move out of the cell at the same instant -- and
counts the samples whose link polygons (shapely, exact) meet, for the original and the
modified database, and along the planned paths of the queries (the subordinate between
consecutive cells of its plan). Every such count must be 0; a control row samples occupied
cells and must find collisions (else the check is blind). Then on --scenes random scenes
(cfmpa_mutants.py) the same for both databases, and for each of the spec's seven mutants in
the cells it frees that a sound database occupies: each must collide somewhere (else the
sampling cannot tell it from a sound database). Exit 1 otherwise.
Writes benchmarks/results/cfmpa_soundness.json.

--ompl (the spec's B5, optional extra certiloop[plan]): OMPL's RRTConnect and FMT* on the same
scenes in the combined 4-D joint space, see cfmpa_ompl.py; without OMPL one "skipped" row.
Writes benchmarks/results/cfmpa_ompl.json.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from cfmpa_mutants import early_arrival_plans, mutant_databases, random_scene
from common import record

from certiloop.studies.dualarm.arms import arm_enclosures, builtdr, reference_scene, static_arm
from certiloop.studies.dualarm.planner import check_path, plan

DEFAULT_DT = (0.2, 0.1)
SCENES = {
    "R1": {},  # mixed directions: (0.25, 0.5) -> (0.7, -1.5)
    "same": {"goal": (1.2, 1.5)},  # both joints turn the same way
    "still": {"goal": (0.25, -1.5)},  # joint 1 stays put
}


def scene_for(name: str, dt: float):
    return replace(reference_scene(dt), **SCENES[name])


def swept_ratio(scene) -> float:
    """Median over layers of area(enclosure - static arm), modified over original."""
    from shapely.geometry import MultiPoint, Polygon
    from shapely.ops import unary_union

    ratios = []
    boxes = {mode: scene.principal_boxes(mode) for mode in ("original", "modified")}
    for k in range(scene.layers):
        pose = scene.planned_pose(k * scene.dt)
        static = unary_union([Polygon(x) for x in static_arm(scene.principal, pose)])
        area = {}
        for mode, b in boxes.items():
            links = arm_enclosures(scene.principal, b[k, 0], b[k, 1])
            region = unary_union([MultiPoint([tuple(p) for p in pts]).convex_hull for pts in links])
            area[mode] = region.difference(static).area
        ratios.append(area["modified"] / area["original"])
    return statistics.median(ratios)


def queries(P_mod, count: int, seed: int):
    """Seeded (start, goal) pairs: start free in layer 0, goal free in layer N-1 (modified)."""
    rng = np.random.default_rng(seed)
    free0, free_last = np.argwhere(P_mod[0] == 0), np.argwhere(P_mod[-1] == 0)
    if not len(free0) or not len(free_last):
        return []
    return [(tuple(int(v) for v in free0[rng.integers(len(free0))]),
             tuple(int(v) for v in free_last[rng.integers(len(free_last))])) for _ in range(count)]


def run(name: str, dt: float, repeats: int, count: int, seed: int) -> dict:
    scene = scene_for(name, dt)
    timings, db = {}, {}
    for mode in ("original", "modified"):
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            db[mode] = builtdr(scene, mode)
            times.append(time.perf_counter() - t0)
        timings[mode] = statistics.median(times)
    ok = {"original": 0, "modified": 0}
    only_mod = only_orig = 0
    plan_times = []
    for start, goal in queries(db["modified"], count, seed):
        got = {}
        for mode in ("original", "modified"):
            t0 = time.perf_counter()
            result = plan(db[mode], start, goal)
            plan_times.append(time.perf_counter() - t0)
            got[mode] = result.ok and check_path(db[mode], result.path, start, goal)[0]
            ok[mode] += got[mode]
        only_mod += got["modified"] and not got["original"]
        only_orig += got["original"] and not got["modified"]
    N, m, n = db["modified"].shape
    return {"scene": name, "dt": dt, "N": N, "m": m, "cells": N * m * n,
            "free_orig": float((db["original"] == 0).mean()), "free_mod": float((db["modified"] == 0).mean()),
            "mod_le_orig": bool((db["modified"] <= db["original"]).all()),
            "builtdr_orig_s": timings["original"], "builtdr_mod_s": timings["modified"],
            "queries": count, "ok_orig": ok["original"], "ok_mod": ok["modified"],
            "only_mod": int(only_mod), "only_orig": int(only_orig),
            "plan_median_s": statistics.median(plan_times) if plan_times else 0.0,
            "swept_ratio": swept_ratio(scene)}


def _collide(scene, principal, subordinate) -> bool:
    from shapely.geometry import Polygon

    a = [Polygon(x) for x in static_arm(scene.principal, principal)]
    b = [Polygon(x) for x in static_arm(scene.subordinate, subordinate)]
    return any(x.intersects(y) for x in a for y in b)


def _boundary(P: np.ndarray) -> np.ndarray:
    """Free cells with an occupied cell among their king neighbours in the same or an adjacent
    layer: where an unsound database's missing margin shows first."""
    occupied = np.pad(P.astype(bool), 1)
    near = np.zeros_like(occupied)
    for dk in (-1, 0, 1):
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                near |= np.roll(occupied, (dk, di, dj), axis=(0, 1, 2))
    return (P == 0) & near[1:-1, 1:-1, 1:-1]


def _sample_cells(scene, P, samples: int, rng, where: np.ndarray | None = None) -> tuple[int, int]:
    """(collisions, samples) among instants (time layer k + λ) in the cells `where` marks over
    time layers 0 .. N (default: free cells of P next to occupied ones): the principal on its
    planned motion, the subordinate on a king move out of the cell at one cell per Δt (P's own
    grid step). Time layer N is the instant after the principal's arrival; P's layer
    min(k, len(P) - 1) is the one in use (the last layer is reused)."""
    N, m, n = P.shape
    h1, h2 = 2 * np.pi / m, 2 * np.pi / n
    if where is None:
        where = _over_time(_boundary(P), scene.layers)
    cells = np.argwhere(where)
    if not len(cells):
        return 0, 0
    hits = 0
    for k, i, j in cells[rng.integers(len(cells), size=samples)]:
        lam = rng.uniform()
        di, dj = rng.integers(-1, 2, size=2)
        sub = (i * h1 + di * h1 * lam, j * h2 + scene.r2_offset + dj * h2 * lam)
        hits += _collide(scene, scene.planned_pose((k + lam) * scene.dt), sub)
    return int(hits), samples


def _over_time(mask: np.ndarray, layers: int) -> np.ndarray:
    """mask (N, m, n) per time layer 0 .. layers (the last layer reused): (layers + 1, m, n)."""
    return mask[np.minimum(np.arange(layers + 1), len(mask) - 1)]


def _sample_paths(scene, P, paths, samples: int, rng) -> tuple[int, int]:
    """(collisions, samples) along plans: the subordinate between consecutive cells of a plan
    (parked at its last cell once the plan ends) while the principal moves."""
    m, n = P.shape[1:]
    h1, h2 = scene.steps
    hits = checked = 0
    for _ in range(samples if paths else 0):
        path = paths[int(rng.integers(len(paths)))]
        k = int(rng.integers(P.shape[0]))
        lam = rng.uniform()
        (i0, j0), (i1, j1) = path[min(k, len(path) - 1)], path[min(k + 1, len(path) - 1)]
        di, dj = (i1 - i0 + 1) % m - 1, (j1 - j0 + 1) % n - 1  # king moves wrap around the grid
        r1, r2 = scene.cell_angles(i0, j0)
        sub = (r1 + di * h1 * lam, r2 + dj * h2 * lam)
        hits += _collide(scene, scene.planned_pose((k + lam) * scene.dt), sub)
        checked += 1
    return int(hits), checked


def soundness(name: str, dt: float, samples: int, count: int, seed: int) -> list[dict]:
    """B4 on a named scene: collisions among `samples` instants in free cells next to occupied
    ones per database, in occupied cells (the control), and along plans."""
    scene = scene_for(name, dt)
    rng = np.random.default_rng(seed)
    rows = []

    def row(variant, hits, checked):
        rows.append({"scene": name, "dt": dt, "variant": variant, "samples": checked, "collisions": hits})

    databases = {mode: builtdr(scene, mode) for mode in ("original", "modified")}
    for mode, P in databases.items():
        row(mode, *_sample_cells(scene, P, samples, rng))
    occupied = _over_time(databases["modified"] == 1, scene.layers)
    row("modified, occupied cells (control)",
        *_sample_cells(scene, databases["modified"], samples, rng, occupied))
    P = databases["modified"]
    plans = [plan(P, start, goal) for start, goal in queries(P, count, seed)]
    paths = [r.path for r in plans if r.ok]
    row(f"planned ({len(paths)} plans)", *_sample_paths(scene, P, paths, samples, rng))
    return rows


def mutant_soundness(samples: int, scenes: int, count: int, seed: int) -> list[dict]:
    """B4 on `scenes` random scenes (cfmpa_mutants.random_scene), `samples` instants per variant
    spread over them: the original and modified databases (free cells next to occupied ones,
    must never collide) and each mutant (the cells it frees that a sound database occupies,
    must collide somewhere), the early-arrival mutant along the plans it accepts."""
    rng = np.random.default_rng(seed)
    per_scene = -(-samples // scenes)
    totals: dict[str, list[int]] = {}

    def add(variant, hits, checked):
        total = totals.setdefault(variant, [0, 0, 0])
        total[0], total[1], total[2] = total[0] + hits, total[1] + checked, total[2] + (hits > 0)

    for _ in range(scenes):
        scene = random_scene(rng)
        for mode in ("original", "modified"):
            add(mode, *_sample_cells(scene, builtdr(scene, mode), per_scene, rng))
        for mutant, (Pm, sound) in mutant_databases(scene).items():
            # the cells the mutant frees and a sound database on its grid occupies
            freed = _over_time(Pm == 0, scene.layers) & _over_time(sound == 1, scene.layers)
            add(f"mutant: {mutant}", *_sample_cells(scene, Pm, per_scene, rng, freed))
        P = builtdr(scene, "modified")
        early = early_arrival_plans(P, count, rng)
        add("mutant: early arrival", *_sample_paths(scene, P, early, per_scene, rng))
    return [{"scene": f"random x{scenes}", "dt": None, "variant": variant, "samples": checked,
             "collisions": hits, "scenes_with_collisions": hit_scenes}
            for variant, (hits, checked, hit_scenes) in totals.items()]


def _soundness_verdict(rows: list[dict]) -> int:
    """0 when no free cell or plan collides, the control does, and every mutant does somewhere."""
    expected = ("modified, occupied", "mutant")  # the control and the mutants must collide
    bad = [r for r in rows if r["collisions"] and not r["variant"].startswith(expected)]
    mutants: dict[str, int] = {}
    for r in rows:
        if r["variant"].startswith("mutant"):
            name = r["variant"].split(" (")[0]
            mutants[name] = mutants.get(name, 0) + r["collisions"]
    for r in rows:
        where = f"{r['scene']:>10} dt={r['dt'] or '-':<5}"
        print(f"{where} {r['variant']:<36} {r['collisions']:>6} / {r['samples']}")
    blind = not any(r["collisions"] for r in rows if "control" in r["variant"])
    silent = sorted(name for name, hits in mutants.items() if not hits)
    print("no collision in free cells or along plans" if not bad else f"{len(bad)} variant(s) collide")
    if blind:
        print("the control found no collision in occupied cells either: the check sees nothing")
    for name in silent:
        print(f"{name} never collides: the sampling cannot tell it from a sound database")
    return 1 if bad or blind or silent else 0


def check(rows: list[dict]) -> list[str]:
    problems = []
    for r in rows:
        where = f"{r['scene']} at dt={r['dt']}"
        if not r["mod_le_orig"] or r["free_mod"] < r["free_orig"]:
            problems.append(f"{where}: the modified database is not cellwise below the original")
        if r["scene"] == "R1" and not r["free_mod"] > r["free_orig"]:
            problems.append(f"{where}: the modified database frees no more cells")
        if r["only_orig"]:
            problems.append(f"{where}: {r['only_orig']} queries succeed only with the original region")
    if not any(r["only_mod"] for r in rows):
        problems.append("no query succeeds only with the modified region")
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dt", type=float, nargs="+", help="latencies Δt (default 0.2 0.1)")
    ap.add_argument("--scene", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--queries", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--check", action="store_true", help="exit 1 unless the paper's claims hold")
    ap.add_argument("--plot", type=Path, metavar="DIR", help="also plot the occupancy layers (plot_cfmpa.py)")
    ap.add_argument("--soundness", action="store_true", help="B4: count collisions at sampled instants")
    ap.add_argument("--ompl", action="store_true", help="B5: OMPL in the combined 4-D space (cfmpa_ompl.py)")
    ap.add_argument("--samples", type=int, default=20_000, help="--soundness samples per variant")
    ap.add_argument("--scenes", type=int, default=40, help="--soundness random scenes for the mutants")
    args = ap.parse_args(argv)
    if any(not 0 < dt < 1.5 for dt in args.dt or ()):
        ap.error("--dt must lie in (0, 1.5)")
    if args.plot is not None:
        from plot_cfmpa import plot_layers

        for name in args.scene:
            for dt in args.dt or DEFAULT_DT:
                for path in plot_layers(scene_for(name, dt), name, args.plot):
                    print(f"wrote {path}")
    if args.ompl:
        from cfmpa_ompl import rows as ompl_rows

        rows = [r for dt in args.dt or DEFAULT_DT for r in ompl_rows(
            {s: scene_for(s, dt) for s in args.scene},
            lambda scene: queries(builtdr(scene, "modified"), 1, args.seed), dt)]
        record("cfmpa_ompl", rows)
        return 0
    if args.soundness:
        dts = args.dt or DEFAULT_DT
        rows = [r for s in args.scene for dt in dts
                for r in soundness(s, dt, args.samples, args.queries, args.seed)]
        rows += mutant_soundness(args.samples, args.scenes, args.queries, args.seed)
        record("cfmpa_soundness", rows)
        return _soundness_verdict(rows)
    rows = [run(s, dt, args.repeats, args.queries, args.seed)
            for s in args.scene for dt in args.dt or DEFAULT_DT]
    record("cfmpa", rows)
    if args.check:
        problems = check(rows)
        for p in problems:
            print(f"CLAIM FAILS: {p}")
        print("all three claims hold" if not problems else f"{len(problems)} claim(s) fail")
        return 1 if problems else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
