"""FMT* through OMPL (`og.FMT`, the optional extra certiloop[plan]) with certified paths.

What we take from the paper (§2.3) and what OMPL's FMT* does instead:

* Algorithm 1 as printed has defects (spec raven-hil.md §1.4): line 13 takes the candidate
  parents from Theta_near ∩ V_open, which is always empty (Theta_near ⊆ V_unvisited); FMT*
  (Janson et al., the paper's [40]) takes them from N_theta ∩ V_open, and so does OMPL's
  `FMT::expandTreeFromNode`. Lines 22-23 remove/close theta instead of z, and line 4
  (z <- theta_init) is missing; OMPL follows [40]. We use OMPL's implementation unchanged.
* eq 2, r_n = gamma (log n / n)^(1/d): `setNearestK(False)` (a radius, not k-nearest),
  OMPL's gamma from the free-space volume, which we estimate by Monte Carlo as the paper
  does (`free_fraction`, a fixed numpy seed) and pass with `setFreeSpaceVolume`; the
  radius multiplier is OMPL's default 1.1 unless given.
* eq 1, J = eta1 c(sigma) + eta2 ∫|alpha|² dt: the acceleration term depends on the speed
  at each waypoint, so as printed it is not additive over edges and breaks FMT*'s dynamic
  programming. Here every edge is a rest-to-rest quintic of EDGE_SECONDS (the paper's
  Table 2: about 4 s of tracking for 11-14 waypoints), so the term is a sum over edges
  and FMT* stays optimal for it. FMT* evaluates it for every pair of neighbours (about
  10^5 calls at n = 500, each a Python call from OMPL), so the objective takes its first-
  order part, the tip moving along its chord dp = tip(qb) - tip(qa) with the quintic
  profile: ∫|alpha|² dt = (120/7) |dp|² / T³ (`chord_accel_cost`; tip positions cached
  per sample). The reported `accel_quadrature` integrates the real joint-linear edge by
  second differences, for comparison. c(sigma) is the joint arc length in the normalised
  [0, 1]^6 space (the paper normalises the joints to [0, 1]).
* The paper integrates the robot dynamics with ODE to test each edge; we test straight
  joint segments (kinematic edges), densely in floats while planning (`DENSE_STEP`), and
  then *prove* the returned path's segments by interval bisection (`certify.py`). A segment
  that cannot be proved is blacklisted and FMT* runs again on the same samples (at most
  MAX_REPLANS times: only optimality is lost). Before a run is reported a success its
  certificate is re-checked by `check.py` (mpmath, the DH chain), as `certiloop check-path`
  does.
* Budgets: the verdict depends on the sample count and the seed only. FMT* stops when it
  reaches the goal or its open set empties (`setExtendedFMT(False)`: OMPL's extension would
  keep sampling until the clock stops it); a wall cap (default 600 s) only guards against
  a stall, and reaching it is reported as a failure that says so.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from certiloop.studies.raven.plan import kinematics
from certiloop.studies.raven.plan.certify import prove_segment
from certiloop.studies.raven.plan.scenes import Scene

INSTALL_HINT = ("FMT* planning needs OMPL: pip install 'certiloop[plan]' "
                "(ompl >= 2; wheels for Linux x86_64/aarch64)")
DENSE_STEP = 0.005  # normalised joint units between float checks along an edge (infinity norm)
EDGE_SECONDS = 0.35  # s per edge for the rest-to-rest quintic of eq 1's acceleration term
QUINTIC_NODES = 16
MAX_REPLANS = 5
WALL_CAP_S = 600.0
FREE_SAMPLES = 20_000


def load_ompl():
    """(ob, og, ou) or ImportError with the install hint."""
    try:
        from ompl import base as ob
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError:
        raise ImportError(INSTALL_HINT) from None
    return ob, og, ou


@dataclass
class Run:
    seed: int
    samples: int
    success: bool = False
    reason: str = ""
    planning_s: float = 0.0  # FMT* and the certification of its path (including re-plans)
    check_s: float = 0.0  # the independent re-check
    cost: float | None = None
    length: float | None = None  # normalised joint arc length
    accel: float | None = None  # sum over edges of the chord model of ∫|alpha|² dt (m²/s³)
    accel_quadrature: float | None = None  # the same for the joint-linear edges, by quadrature
    waypoints: list = field(default_factory=list)
    certificate: dict | None = None
    replans: int = 0
    validity_checks: int = 0
    motion_checks: int = 0
    pieces: int = 0

    def to_json(self) -> dict:
        return {"seed": self.seed, "samples": self.samples, "success": self.success, "reason": self.reason,
                "planning_s": self.planning_s, "check_s": self.check_s, "cost": self.cost,
                "length": self.length, "accel": self.accel,
                "accel_quadrature": self.accel_quadrature, "waypoints": self.waypoints,
                "certificate": self.certificate, "replans": self.replans,
                "validity_checks": self.validity_checks, "motion_checks": self.motion_checks,
                "pieces": self.pieces}


def free_fraction(scene: Scene, samples: int = FREE_SAMPLES) -> float:
    """Monte Carlo estimate of the free share of the joint box (fixed seed: deterministic)."""
    rng = np.random.default_rng(20170)
    q = scene.lo + rng.random((samples, 6)) * (scene.hi - scene.lo)
    return max(float(np.mean(scene.valid(q))), 1.0 / samples)


QUINTIC_SNAP = 120.0 / 7.0  # ∫_0^1 phi''(s)² ds for phi = 10 s³ - 15 s⁴ + 6 s⁵


_CHORD_FACTOR = QUINTIC_SNAP / EDGE_SECONDS ** 3


def chord_accel_cost(tip_a, tip_b) -> float:
    """eq 1's acceleration term for one edge, first order: the tip along its chord with the
    rest-to-rest quintic profile over EDGE_SECONDS (plain floats: called ~10^5 times)."""
    dx, dy, dz = tip_b[0] - tip_a[0], tip_b[1] - tip_a[1], tip_b[2] - tip_a[2]
    return _CHORD_FACTOR * (dx * dx + dy * dy + dz * dz)


def quintic_accel_cost(scene: Scene, qa: np.ndarray, qb: np.ndarray) -> float:
    """∫|alpha|² dt of the tip along a rest-to-rest quintic from qa to qb in EDGE_SECONDS,
    by second differences of the tip position at QUINTIC_NODES + 1 times (trapezoid rule)."""
    m, T = QUINTIC_NODES, EDGE_SECONDS
    s = np.linspace(0.0, 1.0, m + 1)
    phi = s ** 3 * (10 - 15 * s + 6 * s ** 2)
    _, tip = kinematics.points(qa + phi[:, None] * (qb - qa), scene.arm)
    h = T / m
    acc = (tip[2:] - 2 * tip[1:-1] + tip[:-2]) / h ** 2
    return float(np.sum(acc * acc) * h)


class _Geometry:
    """Normalised [0, 1]^6 <-> joints, and the float checks OMPL calls."""

    def __init__(self, scene: Scene) -> None:
        self.scene, self.lo, self.span = scene, scene.lo, scene.hi - scene.lo
        self.blacklist: set = set()
        self.validity_checks = self.motion_checks = 0
        self._tips: dict = {}

    def tip(self, state) -> tuple:
        """The tip of a sample as a tuple of floats, cached: FMT* asks for the cost of ~10^5
        neighbour pairs among n samples. The key is the first three coordinates (uniform
        floats: distinct samples share them with probability ~0; a clash could only change
        a cost, never what is checked for collisions)."""
        key = (state[0], state[1], state[2])
        p = self._tips.get(key)
        if p is None:
            q = self.lo + np.array([state[i] for i in range(6)]) * self.span
            p = tuple(float(v) for v in kinematics.points(q, self.scene.arm)[1][0])
            self._tips[key] = p
        return p

    def joints(self, state) -> np.ndarray:
        return self.lo + np.array([state[i] for i in range(6)]) * self.span

    def state_valid(self, state) -> bool:
        self.validity_checks += 1
        return bool(self.scene.clearance(self.joints(state))[0] >= 0.0)

    def motion_valid(self, s1, s2) -> bool:
        self.motion_checks += 1
        u1, u2 = np.array([s1[i] for i in range(6)]), np.array([s2[i] for i in range(6)])
        if (tuple(u1), tuple(u2)) in self.blacklist or (tuple(u2), tuple(u1)) in self.blacklist:
            return False
        steps = max(1, math.ceil(float(np.max(np.abs(u2 - u1))) / DENSE_STEP))
        t = np.linspace(0.0, 1.0, steps + 1)[:, None]
        return bool(np.all(self.scene.clearance(self.lo + (u1 + t * (u2 - u1)) * self.span) >= 0.0))


def _build(scene: Scene, samples: int, eta: tuple[float, float], geometry: _Geometry,
           radius_multiplier: float | None, free_volume: float):
    ob, og, _ = load_ompl()

    class Valid(ob.StateValidityChecker):
        def isValid(self, state):
            return geometry.state_valid(state)

    class Motion(ob.MotionValidator):
        def checkMotion(self, s1, s2, *rest):
            return geometry.motion_valid(s1, s2)

    class Accel(ob.OptimizationObjective):
        def motionCost(self, s1, s2):
            return ob.Cost(chord_accel_cost(geometry.tip(s1), geometry.tip(s2)))

        def stateCost(self, s):
            return ob.Cost(0.0)

    space = ob.RealVectorStateSpace(6)
    bounds = ob.RealVectorBounds(6)
    bounds.setLow(0.0)
    bounds.setHigh(1.0)
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    checker, motion = Valid(si), Motion(si)
    si.setStateValidityChecker(checker)
    si.setMotionValidator(motion)
    si.setup()
    start, goal = space.allocState(), space.allocState()
    for i in range(6):
        start[i] = (scene.start[i] - geometry.lo[i]) / geometry.span[i]
        goal[i] = (scene.goal[i] - geometry.lo[i]) / geometry.span[i]
    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(start, goal)
    length_obj = ob.PathLengthOptimizationObjective(si)
    keep = [checker, motion, space, start, goal, length_obj]  # Python owners must outlive the planner
    if eta[1] > 0:
        accel_obj = Accel(si)
        objective = ob.MultiOptimizationObjective(si)
        if eta[0] > 0:
            objective.addObjective(length_obj, eta[0])
        objective.addObjective(accel_obj, eta[1])
        keep += [accel_obj, objective]
    else:
        objective = length_obj
    pdef.setOptimizationObjective(objective)
    planner = og.FMT(si)
    planner.setNumSamples(samples)
    planner.setNearestK(False)
    planner.setExtendedFMT(False)
    planner.setFreeSpaceVolume(free_volume)
    if radius_multiplier is not None:
        planner.setRadiusMultiplier(radius_multiplier)
    planner.setProblemDefinition(pdef)
    planner.setup()
    return planner, pdef, keep


def certify_path(scene: Scene, waypoints: np.ndarray):
    """(index of the first segment not proved or None, certificate segments, pieces evaluated)."""
    segments, evaluated = [], 0
    for i in range(len(waypoints) - 1):
        proof = prove_segment(scene, waypoints[i], waypoints[i + 1])
        evaluated += proof.evaluated
        if not proof.proved:
            return i, segments, evaluated
        segments.append({"index": i, "pieces": proof.breakpoints(), "least_slack": proof.least_margin})
    return None, segments, evaluated


def path_costs(scene: Scene, waypoints: np.ndarray, eta) -> tuple[float, float, float, float]:
    """eq 1 as the planner optimises it: (cost, length, chord accel, quadrature accel)."""
    span = scene.hi - scene.lo
    u = (waypoints - scene.lo) / span
    length = float(np.sum(np.linalg.norm(np.diff(u, axis=0), axis=1)))
    _, tips = kinematics.points(waypoints, scene.arm)
    accel = sum(chord_accel_cost(a, b) for a, b in zip(tips, tips[1:]))
    quad = sum(quintic_accel_cost(scene, a, b) for a, b in zip(waypoints, waypoints[1:]))
    return eta[0] * length + eta[1] * accel, length, accel, quad


def plan_once(scene: Scene, samples: int, seed: int, eta=(0.1, 0.5), radius_multiplier=None,
              wall_cap_s: float = WALL_CAP_S, free_volume: float | None = None) -> Run:
    """One FMT* run with OMPL's RNG seeded: same seed and samples, same result."""
    from certiloop.studies.raven.plan.check import check_run
    from certiloop.studies.raven.plan.scenes import SCENES

    ob, og, ou = load_ompl()
    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)  # OMPL logs a harmless error when the seed is set twice
    run = Run(seed=seed, samples=samples)
    geometry = _Geometry(scene)
    free_volume = free_fraction(scene) if free_volume is None else free_volume
    start = time.perf_counter()
    try:
        for attempt in range(MAX_REPLANS + 1):
            ou.RNG.setSeed(seed + 1)  # OMPL refuses seed 0
            planner, pdef, keep = _build(scene, samples, eta, geometry, radius_multiplier, free_volume)
            remaining = wall_cap_s - (time.perf_counter() - start)
            planner.solve(ob.timedPlannerTerminationCondition(max(remaining, 0.0)))
            if not pdef.hasExactSolution():
                over = time.perf_counter() - start >= wall_cap_s
                run.reason = (f"wall cap of {wall_cap_s:g} s reached (a guard, not a budget)" if over
                              else "FMT* found no path with these samples")
                break
            path = pdef.getSolutionPath()
            u = np.array([[path.getState(k)[i] for i in range(6)] for k in range(path.getStateCount())])
            q = np.clip(scene.lo + u * (scene.hi - scene.lo), scene.lo, scene.hi)  # rounding at u = 1
            q[0], q[-1] = scene.start, scene.goal  # exactly the scene's (the states are normalised)
            bad, segments, pieces = certify_path(scene, q)
            run.pieces += pieces
            if bad is None:
                run.waypoints = q.tolist()
                run.certificate = {"scene": scene.to_json(), "segments": segments}
                break
            geometry.blacklist.add((tuple(u[bad]), tuple(u[bad + 1])))
            run.replans = attempt + 1
            del planner, pdef, keep
        else:
            run.reason = f"no certified path after {MAX_REPLANS} re-plans"
    finally:
        ou.setLogLevel(level)
    run.planning_s = time.perf_counter() - start
    run.validity_checks, run.motion_checks = geometry.validity_checks, geometry.motion_checks
    if run.certificate is None:
        return run
    run.cost, run.length, run.accel, run.accel_quadrature = path_costs(scene, np.array(run.waypoints), eta)
    t = time.perf_counter()
    verdict = check_run(run.to_json(), SCENES)
    run.check_s = time.perf_counter() - t
    if verdict.ok:
        run.success = True
    else:
        run.reason = f"the independent check rejected the certificate: {verdict.reason}"
    return run
