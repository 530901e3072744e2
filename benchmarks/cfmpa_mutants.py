"""The spec's B4 mutants of the dual-arm database (the dual-arm paper), for bench_cfmpa.py --soundness.

Each mutant is the kernel's builtDR with one piece swapped for a flawed reading the paper's
text allows or the library refutes (`cfmpa.*`):

    no apex        link enclosures from the end poses only (`cfmpa.arc_in_chord_hull`)
    pose only      every box shrunk to its sampled pose (`cfmpa.execution_pose_only`)
    floor N        N = ⌊T_f/Δt⌋ (`cfmpa.execution_layers_floor`)
    floor m        m, n = ⌊2π/(ωΔt)⌋, so a cell step exceeds ωΔt (`cfmpa.execution_grid_floor`)
    wrong σ        the modified box swept backwards (`cfmpa.execution_wrong_direction`)
    segment        the original region read as the joint-space segment θ ± ωΔt
                   (`cfmpa.execution_segment_original`)

The pieces are swapped with unittest.mock for the duration of one builtDR call, so the
kernel itself never carries an unsafe mode. The seventh mutant, early arrival
(`cfmpa.execution_early_arrival`), keeps the database and changes the plan: the paper's
search may stop when the goal is reached before layer N - 1, and `early_arrival_plans`
returns such plans (every element free in its layer, as the paper's check accepts them).

The reference scene R1 does not expose most of these flaws (its enclosures keep a margin the
flaws stay inside), so `random_scene` draws scenes from the spec's §3.4 ranges: links
0.2-2 m, widths 0.01-0.3 m, base gap 0.5-3.5 m, ω 0.2-3 rad/s, Δt 0.02-0.4 s.
"""

from __future__ import annotations

import math
from dataclasses import replace
from unittest import mock

import numpy as np

from certiloop.studies.dualarm import arms as dualarm
from certiloop.studies.dualarm.arms import Arm, Scene, builtdr
from certiloop.studies.dualarm.planner import MOVES

MAX_CELLS = 100_000  # random scenes stay small enough for a 2-core machine
SEGMENT_PIECES = 8  # the segment θ - ωΔt .. θ + ωΔt enclosed as a chain of this many small boxes


def _ends_only(points, lo, hi):
    """sweep_points without the tangent apexes: the chord hull misses the arc's bulge."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return np.concatenate([dualarm._rotate(points, lo), dualarm._rotate(points, hi)], axis=-2)


def _centre_only(points, lo, hi):
    """sweep_points at the box's centre only: the sampled pose, no motion."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return dualarm._rotate(points, (lo + hi) / 2)


def _floor_layers(scene: Scene) -> int:
    return max(1, math.floor(scene.tf / scene.dt + 1e-9))


def _floor_grid(scene: Scene) -> tuple[int, int]:
    return tuple(math.floor(2 * math.pi / (w * scene.dt) + 1e-9) for w in scene.w_subordinate)


def _segment_database(scene: Scene) -> np.ndarray:
    """Occupied where the subordinate's box meets any piece of the principal's segment."""
    w = np.asarray(scene.w_principal) * scene.dt
    poses = np.array([scene.planned_pose(k * scene.dt) for k in range(scene.layers)])
    cuts = np.linspace(-1.0, 1.0, SEGMENT_PIECES + 1)
    database = None
    for a, b in zip(cuts[:-1], cuts[1:]):
        piece = np.stack([poses + a * w, poses + b * w], axis=-1)
        with mock.patch.object(Scene, "principal_boxes", lambda self, mode, piece=piece: piece):
            part = builtdr(scene, "original")
        database = part if database is None else np.maximum(database, part)
    return database


def mutant_databases(scene: Scene) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """name -> (the database the mutant builds for `scene`, a sound database on the same grid).
    The cells the mutant frees and the sound one occupies are where its flaw can show."""
    out = {}
    modified, original = builtdr(scene, "modified"), builtdr(scene, "original")
    with mock.patch.object(dualarm, "sweep_points", _ends_only):
        out["no apex"] = builtdr(scene, "original"), original
    with mock.patch.object(dualarm, "sweep_points", _centre_only):
        out["pose only"] = builtdr(scene, "original"), original
    with mock.patch.object(Scene, "layers", property(_floor_layers)):
        out["floor N"] = builtdr(scene, "modified"), modified
    with mock.patch.object(Scene, "grid", property(_floor_grid)):
        floored = builtdr(scene, "modified")
    # sound on the floored grid: a subordinate box as wide as the step it really takes per Δt
    m, n = floored.shape[1:]
    wide = replace(scene, w_subordinate=(2 * math.pi / (m * scene.dt), 2 * math.pi / (n * scene.dt)))
    out["floor m"] = floored, builtdr(wide, "modified")
    backwards = property(lambda self: -np.where(np.asarray(self.goal) > np.asarray(self.start), 1.0, -1.0))
    with mock.patch.object(Scene, "directions", backwards):
        out["wrong σ"] = builtdr(scene, "modified"), modified
    out["segment"] = _segment_database(scene), original
    return out


def early_arrival_plans(P: np.ndarray, count: int, rng: np.random.Generator) -> list[list[tuple[int, int]]]:
    """Up to `count` plans the paper's search accepts and the repaired check rejects: a walk of
    king moves from a cell free in layer 0 that reaches its goal at element len - 1 < N - 1,
    every element k free in layer k, the goal occupied in some later layer (the subordinate
    parks there unchecked, D6). Breadth-first over the layers, one random start per plan."""
    N, m, n = P.shape
    free = P == 0
    starts = np.argwhere(free[0])
    plans = []
    for _ in range(count * 4):
        if len(plans) == count or not len(starts) or N < 3:
            break
        start = tuple(int(v) for v in starts[rng.integers(len(starts))])
        came = np.full((N, m, n), -1, dtype=np.int8)  # the move that first reached (k, i, j)
        reached = np.zeros((m, n), bool)
        reached[start] = True
        first = {start: 0}
        for k in range(1, N - 1):
            nxt = np.zeros_like(reached)
            for d, (di, dj) in enumerate(MOVES):
                shifted = np.zeros_like(reached)
                shifted[max(di, 0):m + min(di, 0), max(dj, 0):n + min(dj, 0)] = \
                    reached[max(-di, 0):m + min(-di, 0), max(-dj, 0):n + min(-dj, 0)]
                new = shifted & free[k] & ~nxt
                came[k][new] = d
                nxt |= new
            reached = nxt
            for i, j in np.argwhere(reached):
                first.setdefault((int(i), int(j)), k)
        late = [c for c, k in first.items() if k > 0 and P[k + 1:, c[0], c[1]].any()]
        if not late:
            continue
        goal = late[int(rng.integers(len(late)))]
        path, (i, j), k = [goal], goal, first[goal]
        while k > 0:
            di, dj = MOVES[came[k, i, j]]
            i, j, k = i - int(di), j - int(dj), k - 1
            path.append((i, j))
        plans.append(path[::-1])
    return plans


def random_scene(rng: np.random.Generator) -> Scene:
    """A scene from the spec's §3.4 ranges with at most MAX_CELLS cells (redrawn until it fits)."""
    while True:
        gap = rng.uniform(0.5, 3.5)
        arms = [Arm(base=base, l1=rng.uniform(0.2, 2), l2=rng.uniform(0.2, 2), width=rng.uniform(0.01, 0.3))
                for base in ((0.0, 0.0), (gap, 0.0))]
        w_principal, w_subordinate = tuple(rng.uniform(0.2, 3, 2)), tuple(rng.uniform(0.2, 3, 2))
        dt = rng.uniform(0.02, 0.4)
        if 2 * max(*w_principal, *w_subordinate) * dt >= math.pi:
            continue
        start, goal = tuple(rng.uniform(-math.pi, math.pi, 2)), tuple(rng.uniform(-math.pi, math.pi, 2))
        scene = Scene(arms[0], arms[1], start, goal, w_principal, w_subordinate, dt)
        m, n = scene.grid
        if scene.layers * m * n <= MAX_CELLS:
            return scene
