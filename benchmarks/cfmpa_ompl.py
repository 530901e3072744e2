"""The spec's B5 for the dual-arm paper (`bench_cfmpa.py --ompl`): what a general sampling planner does
with the dual-arm problem, beside the paper's space-time planner.

OMPL plans both arms together in the combined 4-D joint space (principal θ1, θ2, subordinate
θ1, θ2) from (principal start, subordinate start) to (principal goal, subordinate goal), with
RRTConnect and FMT* (n = 1,000), a static-pose checker (the four link rectangles pairwise
apart, by separating axes over their own edge normals: exact for rectangles) and OMPL's
default motion resolution. That is a looser problem: the principal need not follow its
synchronous PTP motion. The path is then time-parametrised (every joint at most its ω, the
joints of a segment in sync) and re-checked densely (one pose per 0.2 mrad of the largest
joint step): the collisions OMPL's discrete motion checks missed are counted.

Reported per scene and planner: success, planning time (OMPL's wall clock; a benchmark, never a
verdict), the subordinate's travel in grid cells (≈ J1 of the paper's planner), the largest
deviation of the principal from its PTP path (rad) and the motions with missed collisions.
"""

from __future__ import annotations

import math
import time

import numpy as np

from certiloop.studies.dualarm.arms import static_arm

DENSE = 2e-4  # rad between re-check poses
SOLVE_S = 5.0


def _normals(rect: np.ndarray) -> np.ndarray:
    edges = np.roll(rect, -1, axis=0) - rect
    return np.stack([-edges[:2, 1], edges[:2, 0]], axis=1)  # a rectangle has two edge directions


def rectangles_apart(a: np.ndarray, b: np.ndarray) -> bool:
    """Two convex quadrilaterals are disjoint iff some edge normal of either separates them."""
    for n in np.concatenate([_normals(a), _normals(b)]):
        pa, pb = a @ n, b @ n
        if pa.max() < pb.min() or pb.max() < pa.min():
            return True
    return False


def pose_free(scene, q) -> bool:
    a = static_arm(scene.principal, (q[0], q[1]))
    b = static_arm(scene.subordinate, (q[2], q[3]))
    return all(rectangles_apart(x, y) for x in a for y in b)


def _ompl():
    try:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError:
        return None
    return ob, og, ou


def plan_4d(scene, sub_start, sub_goal, planner_name: str, seed: int = 1):
    """(waypoints (k, 4) or None, seconds) from OMPL in the combined space."""
    ob, og, ou = _ompl()
    ou.setLogLevel(ou.LOG_NONE)
    ou.RNG.setSeed(seed)

    class Valid(ob.StateValidityChecker):
        def isValid(self, state):
            return pose_free(scene, [state[i] for i in range(4)])

    space = ob.RealVectorStateSpace(4)
    bounds = ob.RealVectorBounds(4)
    bounds.setLow(-2 * math.pi)
    bounds.setHigh(2 * math.pi)
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    checker = Valid(si)
    si.setStateValidityChecker(checker)
    si.setup()
    start, goal = space.allocState(), space.allocState()
    for i, v in enumerate((*scene.start, *sub_start)):
        start[i] = float(v)
    for i, v in enumerate((*scene.goal, *sub_goal)):
        goal[i] = float(v)
    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(start, goal)
    if planner_name == "FMT*":
        planner = og.FMT(si)
        planner.setNumSamples(1000)
        planner.setExtendedFMT(False)
    else:
        planner = og.RRTConnect(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    t0 = time.perf_counter()
    planner.solve(ob.timedPlannerTerminationCondition(SOLVE_S))
    seconds = time.perf_counter() - t0
    if not pdef.hasExactSolution():
        return None, seconds
    path = pdef.getSolutionPath()
    q = np.array([[path.getState(k)[i] for i in range(4)] for k in range(path.getStateCount())])
    del planner, pdef, checker
    return q, seconds


def missed_collisions(scene, q: np.ndarray) -> int:
    """Motions whose dense re-check meets a colliding pose (OMPL checked them at its resolution)."""
    missed = 0
    for a, b in zip(q, q[1:]):
        steps = max(1, math.ceil(float(np.max(np.abs(b - a))) / DENSE))
        if not all(pose_free(scene, a + t * (b - a)) for t in np.linspace(0.0, 1.0, steps + 1)):
            missed += 1
    return missed


def principal_deviation(scene, q: np.ndarray) -> float:
    """Largest distance (rad) of the principal's joint path from its PTP segment start -> goal."""
    s, g = np.asarray(scene.start, float), np.asarray(scene.goal, float)
    d = g - s
    p = q[:, :2] - s
    t = np.clip(p @ d / (d @ d), 0.0, 1.0)
    return float(np.max(np.linalg.norm(p - t[:, None] * d, axis=1)))


def rows(scenes: dict, queries_for, dt: float) -> list[dict]:
    """B5 rows, or one "skipped" row without OMPL."""
    if _ompl() is None:
        return [{"scene": "-", "planner": "OMPL not installed: skipped (pip install 'certiloop[plan]')"}]
    out = []
    for name, scene in scenes.items():
        h1, h2 = scene.steps
        pairs = queries_for(scene)
        if not pairs:
            continue
        (si, sj), (gi, gj) = pairs[0]
        sub_start, sub_goal = scene.cell_angles(si, sj), scene.cell_angles(gi, gj)
        for planner in ("RRTConnect", "FMT*"):
            q, seconds = plan_4d(scene, sub_start, sub_goal, planner)
            row = {"scene": name, "dt": dt, "planner": planner, "success": q is not None,
                   "planning_s": round(seconds, 3)}
            if q is not None:
                travel = np.abs(np.diff(q[:, 2:], axis=0)) / np.array([h1, h2])
                row.update({"waypoints": len(q), "sub_travel_cells": round(float(travel.sum()), 1),
                            "principal_dev_rad": round(principal_deviation(scene, q), 3),
                            "motions_missed": missed_collisions(scene, q)})
            out.append(row)
    return out
