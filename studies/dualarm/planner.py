"""The subordinate's planner over the state database (the dual-arm paper, searchoptpath), numpy only.

A path L_0 .. L_{len-1} of grid cells is a plan when (repaired Definition 4, `cfmpa.check_path`)
it starts at the start cell and ends at the goal cell, every element k is a cell free in layer
min(k, N-1), consecutive elements are king neighbours, and len >= N (the subordinate may not
park before the principal stops, D6). Among plans the planner returns one minimising
J1 = Σ |Δi| + |Δj| and then J2 = Σ |Δi_k - Δi_{k-1}| + |Δj_k - Δj_{k-1}|, both summed over the
whole path with Δ_0 = 0 (the arm starts at rest; D7: the paper sums k = 1..N only).

Search: a layered dynamic programme over states (cell, last move) for elements 0 .. N-1, each
layer one vectorised minimum over the 9 x 9 (previous move, move) pairs; then the static tail
in layer N-1 (the principal has stopped), relaxed to a fixpoint. The cost J1 W + J2 with
W > the largest possible J2 is lexicographic. A path is returned only if `check_path` accepts
it: a planner bug can cost optimality, never safety.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from certiloop.studies.dualarm.generated.check_path import controller as _extracted_check
from certiloop.studies.dualarm.pins import check_extracted

MOVES = np.array([(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1)])  # index 4 = stay
STAY = 4
INF = np.int64(1) << 60


@dataclass
class Plan:
    path: list[tuple[int, int]] | None
    j1: int | None
    j2: int | None
    ok: bool
    reason: str = ""
    costs: dict = field(default_factory=dict)


def check_path(P: np.ndarray, path, start, goal) -> tuple[bool, str]:
    """The runtime checker: (True, "") when `path` is a plan for database P (N, m, n), else
    (False, why). The verdict is the code extracted from the proved model `cfmpa.check_path`
    (studies/dualarm/generated/check_path.py); `_why_not` only words the reason."""
    check_extracted()
    P = np.asarray(P)
    N, m, n = P.shape
    cells = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    if N < 1 or m < 1 or n < 1 or len(start) != 2 or len(goal) != 2:  # the model's assumptions
        return False, f"database shape {P.shape} or start/goal is not a valid query"
    ok, enabled = _extracted_check(len(cells), int(start[0]), int(start[1]), int(goal[0]), int(goal[1]),
                                   N, m, n, cells[:, 0], cells[:, 1], P)
    if enabled and ok == 1:
        return True, ""
    why = _why_not(P, [tuple(c) for c in cells.tolist()], start, goal)
    return False, why or "the extracted checker rejects it"


def _why_not(P: np.ndarray, path, start, goal) -> str:
    """Why `path` is no plan (the first defect), or "" if none is found: for messages only."""
    N, m, n = P.shape
    if len(path) < max(1, N):
        return f"path has {len(path)} elements, fewer than N = {N} (early arrival)"
    if tuple(path[0]) != tuple(start) or tuple(path[-1]) != tuple(goal):
        return "path does not start at the start cell or end at the goal cell"
    for k, (i, j) in enumerate(path):
        if not (0 <= i < m and 0 <= j < n):
            return f"element {k} = {(i, j)} is off the grid"
        if P[min(k, N - 1), i, j] != 0:
            return f"element {k} = {(i, j)} is blocked in layer {min(k, N - 1)}"
        if k + 1 < len(path):
            ni, nj = path[k + 1]
            if abs(ni - i) > 1 or abs(nj - j) > 1:
                return f"elements {k} and {k + 1} are not neighbours"
    return ""


def costs(path) -> tuple[int, int]:
    """(J1, J2) of a path, summed over the whole path with Δ_0 = 0."""
    arr = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    d = np.diff(arr, axis=0)
    j1 = int(np.abs(d).sum())
    dd = np.diff(np.vstack([np.zeros((1, 2), np.int64), d]), axis=0)
    return j1, int(np.abs(dd).sum())


def _step_costs(weight: int) -> np.ndarray:
    """(9, 9) cost of move d after move d': W (|di| + |dj|) + |di - di'| + |dj - dj'|."""
    j1 = np.abs(MOVES).sum(1)
    j2 = np.abs(MOVES[None, :, :] - MOVES[:, None, :]).sum(2)
    return weight * j1[None, :] + j2


def _shift(a: np.ndarray, di: int, dj: int, fill) -> np.ndarray:
    """b[..., i, j] = a[..., i - di, j - dj] (fill outside): the value at the cell one came from."""
    out = np.full_like(a, fill)
    m, n = a.shape[-2:]
    out[..., max(di, 0):m + min(di, 0), max(dj, 0):n + min(dj, 0)] = \
        a[..., max(-di, 0):m + min(-di, 0), max(-dj, 0):n + min(-dj, 0)]
    return out


def _relax(cost: np.ndarray, free: np.ndarray, step: np.ndarray):
    """One DP step: new[d, i, j] = min_{d'} cost[d', (i, j) - move d] + step[d', d] on free cells.
    Returns (new cost, argmin d')."""
    new = np.full_like(cost, INF)
    arg = np.zeros(cost.shape, dtype=np.int8)
    for d, (di, dj) in enumerate(MOVES):
        came = _shift(cost, int(di), int(dj), INF)  # (9, m, n): cost at the previous cell per d'
        total = np.where(came >= INF, INF, came + step[:, d][:, None, None])
        best = total.argmin(axis=0)
        new[d] = np.take_along_axis(total, best[None], axis=0)[0]
        arg[d] = best
    new[:, ~free] = INF
    return new, arg


def plan(P: np.ndarray, start, goal, max_tail: int | None = None) -> Plan:
    """The lexicographically (J1, J2)-optimal plan for database P (N, m, n), or no plan."""
    P = np.asarray(P)
    if P.ndim != 3 or min(P.shape) < 1:
        raise ValueError(f"database must be a non-empty (N, m, n) array, got shape {P.shape}")
    N, m, n = P.shape
    for name, cell in (("start", start), ("goal", goal)):
        if len(cell) != 2 or not (0 <= cell[0] < m and 0 <= cell[1] < n):
            raise ValueError(f"{name} {tuple(cell)} is not a cell of the {m} x {n} grid")
    free = P == 0
    tail_limit = max_tail if max_tail is not None else 9 * m * n + 9
    horizon = N + tail_limit
    weight = 4 * horizon + 1  # J2 <= 4 per element: W J1 + J2 orders (J1, J2) lexicographically
    step = _step_costs(weight)
    cost = np.full((9, m, n), INF, dtype=np.int64)
    if free[0, start[0], start[1]]:
        cost[STAY, start[0], start[1]] = 0  # at rest: Δ_0 = 0
    pointers = []
    for k in range(1, N):
        cost, arg = _relax(cost, free[k], step)
        pointers.append(arg)
    # static tail in layer N-1: relax to a fixpoint, remembering where each improvement came from
    best = cost.copy()
    tail_from = np.full((9, m, n), -1, dtype=np.int8)  # -1: reached at element N-1
    for _ in range(tail_limit):
        new, arg = _relax(best, free[N - 1], step)
        better = new < best
        if not better.any():
            break
        best = np.where(better, new, best)
        tail_from = np.where(better, arg, tail_from)
    gi, gj = goal
    d_end = int(best[:, gi, gj].argmin())
    if best[d_end, gi, gj] >= INF:
        return Plan(None, None, None, False, "no plan: no path of free cells with len >= N")
    path = _trace(tail_from, pointers, (gi, gj), d_end)
    ok, why = check_path(P, path, start, goal)
    if not ok:  # never hand out a plan the checker rejects
        return Plan(None, None, None, False, f"planner produced a rejected path: {why}")
    j1, j2 = costs(path)
    total = int(best[d_end, gi, gj])
    if total != j1 * weight + j2:
        return Plan(None, None, None, False, "planner cost bookkeeping disagrees with the path")
    return Plan(path, j1, j2, True)


def _trace(tail_from, pointers, cell, d) -> list[tuple[int, int]]:
    """Walk the pointers back from (goal, last move) to the start."""
    rev = [cell]
    i, j = cell
    while tail_from[d, i, j] != -1:
        prev = int(tail_from[d, i, j])
        i, j = i - int(MOVES[d][0]), j - int(MOVES[d][1])
        d = prev
        rev.append((i, j))
    for arg in reversed(pointers):
        prev = int(arg[d, i, j])
        i, j = i - int(MOVES[d][0]), j - int(MOVES[d][1])
        d = prev
        rev.append((i, j))
    return rev[::-1]
