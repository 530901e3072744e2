"""The human-force search of `certiloop falsify rcm.push_*`: the RCM paper's 7-DOF controller at its
4 ms period (`kernel.rcm.demo_controller`), driven by a surgeon's hand that hypothesis moves.

A *profile* is the wrench at the flange over time: a few segments, each a constant force held
for a number of periods (no torque). Hypothesis proposes profiles (force up to `fmax` N per
segment), steered by `target` towards the least clearance the controller reports; a run in
which the tool enters the cloud's forbidden region is then SHRUNK to the smallest scale of the
profile that still enters it (bisection over replays), and its horizon cut at the entry.

A penetration is reported only after an independent REPLAY: a fresh controller runs the
profile, and the clearance is recomputed by brute force -- the distance from the tip (or the
whole tool, a capsule) to every cloud point, along the joint path interpolated within each
period -- not by the controller's KD-tree, which the search trusted. `guarded` scenarios run
the same search on the controller with the proved sampled-data guard (`rcm.axial_guard`).

Deterministic for a seed: hypothesis draws from `random.Random(seed)`, no example database,
the budget a number of examples; the pool of constants it may draw is pinned.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import numpy as np

from certiloop.falsify.constant_pool import pinned_constants
from certiloop.studies.rcm.arm import lwr4_forward
from certiloop.studies.rcm.demo import D_C, RADIUS, demo_controller

SCENARIOS = {
    # name: (controller options, what it shows)
    "rcm.push_euler": ({"integrator": "euler", "guard": False, "mode": "tip"},
                       "the paper's controller: explicit Euler at 4 ms, no guard (tip)"),
    "rcm.push_guarded": ({"integrator": "euler", "guard": True, "mode": "tip"},
                         "the same with the proved guard rcm.axial_guard (tip)"),
    "rcm.push_semi_implicit": ({"integrator": "semi-implicit", "guard": False, "mode": "tip"},
                               "semi-implicit Euler at 4 ms, no guard (tip)"),
    "rcm.push_capsule": ({"integrator": "euler", "guard": False, "mode": "tool"},
                         "explicit Euler, no guard, the whole tool as a capsule"),
    "rcm.push_capsule_guarded": ({"integrator": "euler", "guard": True, "mode": "tool"},
                                 "explicit Euler with the proved guard, the whole tool as a capsule"),
}
SUBSTEPS = 8  # joint-path samples per period in the replay's brute-force distance


@dataclass(frozen=True)
class Profile:
    """Constant forces (N, base frame) held for a number of 4 ms periods each."""

    segments: tuple  # ((periods, (fx, fy, fz)), ...)

    @property
    def periods(self) -> int:
        return sum(n for n, _ in self.segments)

    def forces(self) -> np.ndarray:
        """The force of each period, (periods, 3)."""
        return np.concatenate([np.tile(np.asarray(f, float), (n, 1)) for n, f in self.segments])

    def scaled(self, s: float) -> Profile:
        return Profile(tuple((n, tuple(float(s * c) for c in f)) for n, f in self.segments))

    def cut(self, periods: int) -> Profile:
        """The first `periods` periods."""
        out, left = [], periods
        for n, f in self.segments:
            if left <= 0:
                break
            out.append((min(n, left), f))
            left -= n
        return Profile(tuple(out))

    def peak(self) -> float:
        return max(float(np.linalg.norm(f)) for _, f in self.segments)

    def describe(self) -> str:
        return "; ".join(f"{n} x 4 ms of ({f[0]:+.2f}, {f[1]:+.2f}, {f[2]:+.2f}) N" for n, f in self.segments)


@dataclass
class PushRun:
    """A replayed run: the controller's reported gaps and the brute-force clearances per period."""

    profile: Profile
    gaps: np.ndarray  # the controller's clearance bound at the start of each period run (m)
    clearance: np.ndarray  # brute-force least clearance within each period (m)
    reasons: list = field(default_factory=list)

    @property
    def entered(self) -> bool:
        return bool(len(self.clearance)) and float(self.clearance.min()) < 0.0

    @property
    def first_entry(self) -> int:
        """The first period whose path enters the region (-1: none)."""
        below = np.flatnonzero(self.clearance < 0.0)
        return int(below[0]) if len(below) else -1


def _controller(scenario: str, points: int, gap: float):
    options, _ = SCENARIOS[scenario]
    return demo_controller(points=points, gap=gap, **options)


def _gaps(scenario: str, profile: Profile, points: int, gap: float) -> np.ndarray:
    """The controller's own clearance bound per period (the search's cheap objective)."""
    ctrl, out = _controller(scenario, points, gap), []
    for force in profile.forces():
        r = ctrl.step([*force, 0.0, 0.0, 0.0])
        out.append(r.gap)
        if not r.ok and ctrl.penetrated:
            break
    return np.asarray(out)


def _tool_points(q: np.ndarray, tool_length: float) -> tuple[np.ndarray, np.ndarray]:
    """Flange and tip positions for joint rows q (k, 7)."""
    frames = [lwr4_forward(qi) for qi in q]
    flange = np.array([T[:3, 3] for T in frames])
    tip = flange + tool_length * np.array([T[:3, 2] for T in frames])
    return flange, tip


def brute_clearance(cloud: np.ndarray, flange: np.ndarray, tip: np.ndarray, capsule: bool) -> np.ndarray:
    """Least distance from each pose's tip (or flange-to-tip segment, less the tool's radius) to
    every cloud point, less the points' ball radius d_c: negative inside the region."""
    if not capsule:
        d = np.linalg.norm(tip[:, None, :] - cloud[None, :, :], axis=2)
        return d.min(axis=1) - D_C
    seg = tip - flange
    rel = cloud[None, :, :] - flange[:, None, :]
    t = np.clip(np.einsum("kpi,ki->kp", rel, seg) / np.einsum("ki,ki->k", seg, seg)[:, None], 0.0, 1.0)
    nearest = flange[:, None, :] + t[..., None] * seg[:, None, :]
    return np.linalg.norm(cloud[None, :, :] - nearest, axis=2).min(axis=1) - D_C - RADIUS


def replay(scenario: str, profile: Profile, points: int = 1000, gap: float = 0.02) -> PushRun:
    """Run `profile` on a fresh controller and recompute every period's clearance by brute force
    along the joint path, linearly interpolated within the period (SUBSTEPS samples)."""
    ctrl = _controller(scenario, points, gap)
    cloud, capsule = ctrl.barrier.points, SCENARIOS[scenario][0]["mode"] == "tool"
    gaps, clear, reasons = [], [], []
    for force in profile.forces():
        q0 = ctrl.q.copy()
        r = ctrl.step([*force, 0.0, 0.0, 0.0])
        gaps.append(r.gap)
        reasons.append(r.reason)
        s = np.linspace(0.0, 1.0, SUBSTEPS + 1)[:, None]
        flange, tip = _tool_points(q0 + s * (ctrl.q - q0), ctrl.tool_length)
        clear.append(float(brute_clearance(cloud, flange, tip, capsule).min()))
        if not r.ok and ctrl.penetrated:
            break
    return PushRun(profile, np.asarray(gaps), np.asarray(clear), reasons)


@dataclass
class PushResult:
    scenario: str
    run: PushRun | None  # the shrunk, replayed entering run; None if the search found none
    examples: int  # profiles run by the search (shrinking not counted)
    closest: float  # the least clearance (controller's bound) any searched profile reached (m)
    found_after: int = 0
    shrink_runs: int = 0
    unshrunk: Profile | None = None  # the profile the search found, before shrinking
    scale: tuple = (0.0, 1.0)  # the shrink's bracket: `unshrunk` scaled by [0] did not enter, by [1] did

    def to_json(self) -> dict:
        run = self.run
        return {"scenario": self.scenario, "description": SCENARIOS[self.scenario][1],
                "entered": run is not None, "examples": self.examples, "found_after": self.found_after,
                "closest_clearance_m": self.closest, "shrink_replays": self.shrink_runs,
                "profile": None if run is None else [[n, list(f)] for n, f in run.profile.segments],
                "peak_force_N": None if run is None else run.profile.peak(),
                "first_entry_period": None if run is None else run.first_entry,
                "least_clearance_m": None if run is None else float(run.clearance.min()),
                "scale_bracket": list(self.scale),
                "unshrunk": (None if self.unshrunk is None
                             else [[n, list(f)] for n, f in self.unshrunk.segments])}


def _profiles(fmax: float, horizon: int):
    from hypothesis import strategies as st

    force = st.tuples(st.floats(-fmax / 2, fmax / 2), st.floats(-fmax / 2, fmax / 2), st.floats(-fmax, 0.0))
    segment = st.tuples(st.integers(5, horizon), force)

    def clip(segments) -> Profile:
        out, total = [], 0
        for n, f in segments:
            n = min(n, horizon - total)
            if n <= 0:
                break
            norm = float(np.linalg.norm(f))
            f = tuple(c * (fmax / norm) for c in f) if norm > fmax else tuple(f)
            out.append((n, f))
            total += n
        return Profile(tuple(out))

    return st.lists(segment, min_size=1, max_size=4).map(clip)


def search(scenario: str, max_examples: int = 60, seed: int = 0, points: int = 1000, horizon: int = 250,
           fmax: float = 10.0, gap: float = 0.02, tighten: int = 3) -> PushResult:
    """Search up to `max_examples` profiles (force <= fmax N, `horizon` periods) for one that
    takes the tool into the region; shrink and replay what it finds. Then `tighten` times,
    search again below 90 % of the best entering profile's peak force (the same budget each):
    the result is the entering profile with the least peak force found."""
    if scenario not in SCENARIOS:
        raise ValueError(f"unknown scenario {scenario!r}; choose among {', '.join(SCENARIOS)}")
    result = _search_once(scenario, max_examples, seed, points, horizon, fmax, gap)
    for round_ in range(tighten):
        if result.run is None:
            break
        lower = _search_once(scenario, max_examples, seed + round_ + 1, points, horizon,
                             0.9 * result.run.profile.peak(), gap)
        spent = result.examples + lower.examples
        if lower.run is None:
            result.examples, result.closest = spent, min(result.closest, lower.closest)
            break
        lower.examples, lower.found_after = spent, result.examples + lower.found_after
        lower.shrink_runs += result.shrink_runs
        result = lower
    return result


def _search_once(scenario: str, max_examples: int, seed: int, points: int, horizon: int, fmax: float,
                 gap: float) -> PushResult:
    from hypothesis import HealthCheck, Phase, find, settings, target
    from hypothesis.errors import NoSuchExample

    tried, closest = 0, float("inf")

    def enters(profile: Profile) -> bool:
        nonlocal tried, closest
        tried += 1
        gaps = _gaps(scenario, profile, points, gap)
        least = float(gaps.min()) if len(gaps) else float("inf")
        closest = min(closest, least)
        target(-least, label="depth towards the cloud (m)")
        return least <= 0.0

    # every setting spelled out: a loaded profile must not replace the seed's random source
    config = settings(max_examples=max_examples, database=None, deadline=None, derandomize=False,
                      phases=(Phase.generate, Phase.target), suppress_health_check=list(HealthCheck))
    try:
        with pinned_constants([fmax, fmax / 2, horizon, 5]):
            found = find(_profiles(fmax, horizon), enters, settings=config, random=random.Random(seed))
    except NoSuchExample:
        return PushResult(scenario, None, tried, closest)
    shrunk, runs, bracket = shrink(scenario, found, points, gap)
    run = replay(scenario, shrunk, points, gap)
    # the brute-force witness must confirm what the controller's clearance bound said
    return PushResult(scenario, run if run.entered else None, tried, closest, tried, runs, found, bracket)


def shrink(scenario: str, profile: Profile, points: int = 1000, gap: float = 0.02,
           rounds: int = 12) -> tuple[Profile, int, tuple]:
    """The smallest scale s in (0, 1] of `profile` whose replay still enters (bisection,
    `rounds` halvings: s within 2^-rounds of the least), cut at its entry. Every kept profile
    entered in a brute-force replay, so the result does whatever the bracket. Returns it, the
    replays spent and the bracket (lo, hi): scaled by lo the profile did not enter."""
    lo, hi, runs = 0.0, 1.0, 0
    best = replay(scenario, profile, points, gap)
    runs += 1
    if not best.entered:
        return profile, runs, (lo, hi)
    for _ in range(rounds):
        mid = (lo + hi) / 2
        trial = replay(scenario, profile.scaled(mid), points, gap)
        runs += 1
        if trial.entered:
            hi, best = mid, trial
        else:
            lo = mid
    shrunk = profile.scaled(hi)
    return shrunk.cut(best.first_entry + 1), runs, (lo, hi)


def steady_threshold(scenario: str, direction=(0.0, 0.0, -1.0), fmax: float = 30.0, periods: int = 500,
                     points: int = 1000, gap: float = 0.02, rounds: int = 10) -> tuple[float, float]:
    """The least steady push along `direction` (within fmax / 2^rounds) that enters within
    `periods`: (the largest that did not, the least that did), by brute-force replays; (fmax,
    inf) if even fmax does not enter."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)

    def enters(f: float) -> bool:
        return replay(scenario, Profile(((periods, tuple(f * d)),)), points, gap).entered

    if not enters(fmax):
        return fmax, float("inf")
    lo, hi = 0.0, fmax
    for _ in range(rounds):
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if enters(mid) else (mid, hi)
    return lo, hi

