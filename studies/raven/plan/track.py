"""Track a planned path's tip with the virtual fixture (the verified ctrl2 kernel).

The reference is the tip along the planned joint-space segments, sampled densely and
advanced one sample per control period. An autonomous "operator" pulls the tip towards
the reference, f = K (ref - p), and the `VirtualFixture` turns that force into the velocity
G k f, with the scene's walls and one face of each block as its planes: the face that
separates the reference best at that moment (a face is swapped in only once the tip is on
its safe side, as the fixture requires). The tip integrates p' = G k f exactly over each
period (f held, fp = 0). Returned: the tip's least true distance to every boundary over
the run (walls, and the block's nearest separating face), and where it ended.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from certiloop.studies.raven.plan import kinematics
from certiloop.studies.raven.plan.scenes import Scene, box_faces
from certiloop.studies.sbs.fixture import VirtualFixture

PERIOD = 1e-3
GAIN = 1.0
BUFFER = 0.002
PULL = 40.0  # 1/s: operator force per metre of lag


@dataclass
class Tracking:
    min_wall: float  # least n·p - c over walls and steps (< 0: crossed)
    min_block: float  # least over steps of the best face's n·p - c (< 0: inside a block)
    final_error: float  # |p - goal tip| at the end
    steps: int
    stopped_steps: int  # steps where the fixture commanded k = 0 (fallback or held at a plane)


def _plane(n, c):
    n = np.asarray(n, dtype=float)
    return (n * c, n)  # a point on n·p = c, and its normal


def reference_tips(scene: Scene, waypoints, per_segment: int = 400) -> np.ndarray:
    q = np.asarray(waypoints, dtype=float)
    t = np.linspace(0.0, 1.0, per_segment, endpoint=False)[:, None]
    dense = np.concatenate([a + t * (b - a) for a, b in zip(q, q[1:])] + [q[-1:]])
    return kinematics.points(dense, scene.arm)[1]


def track(scene: Scene, waypoints, per_segment: int = 400, settle: int = 500, pull: float = PULL,
          fixture_on: bool = True) -> Tracking:
    """Track with the fixture (or, `fixture_on=False`, with k = 1 always: the bare operator)."""
    ref = reference_tips(scene, waypoints, per_segment)
    walls = [_plane(n, c) for n, c in scene.walls]
    blocks = [box_faces(lo, hi) for lo, hi in scene.blocks]

    def best_faces(point):
        return tuple(int(np.argmax([np.dot(n, point) - c for n, c in faces])) for faces in blocks)

    p = ref[0].copy()
    chosen = best_faces(p)
    fixture = VirtualFixture(walls + [_plane(*blocks[b][f]) for b, f in enumerate(chosen)],
                             gain=GAIN, buffer=BUFFER, period=PERIOD)
    min_wall = min_block = np.inf
    stopped = 0
    total = len(ref) + settle
    for step in range(total):
        target = ref[min(step, len(ref) - 1)]
        wanted = best_faces(target)
        if wanted != chosen:
            ok = all(np.dot(blocks[b][f][0], p) - blocks[b][f][1] >= 0 for b, f in enumerate(wanted))
            if ok:
                chosen = wanted
                fixture = VirtualFixture(walls + [_plane(*blocks[b][f]) for b, f in enumerate(chosen)],
                                         gain=GAIN, buffer=BUFFER, period=PERIOD)
        f = pull * (target - p)
        if fixture_on:
            cmd = fixture.step(p, f, np.zeros(3))
            stopped += cmd.k == 0.0
            p = p + cmd.velocity * PERIOD
        else:
            p = p + GAIN * f * PERIOD
        min_wall = min(min_wall, min(float(np.dot(n, p) - c) for n, c in scene.walls))
        for faces in blocks:
            min_block = min(min_block, max(float(np.dot(n, p) - c) for n, c in faces))
    return Tracking(min_wall, min_block, float(np.linalg.norm(p - ref[-1])), total, stopped)


@dataclass
class JointTracking:
    min_clearance: float  # least true slack (margin not counted) of wrist and tip over the run (< 0: crossed)
    final_error: float  # max |q - goal| over the positioning joints at the end (rad, m)
    seconds: float  # simulated tracking time


def track_joints(scene: Scene, waypoints, edge_seconds: float = 0.35, settle: int = 300) -> JointTracking:
    """The paper's execution (§2.3): per-joint PD (PID on the insertion) on `RavenArm` at 1 kHz,
    following each planned edge as a rest-to-rest quintic of `edge_seconds`, no fixture. The
    true wrist and tip are checked against the scene at every tick with the margin given back:
    a crossing is a real one."""
    from certiloop.studies.raven.arm import RavenArm

    q = np.asarray(waypoints, dtype=float)
    arm = RavenArm(scene.arm)
    state = arm.rest(1, q[0])
    ticks = max(1, round(edge_seconds / arm.p.dt))
    s = np.arange(1, ticks + 1) / ticks
    phi = s ** 3 * (10 - 15 * s + 6 * s ** 2)
    targets = np.concatenate([a + phi[:, None] * (b - a) for a, b in zip(q, q[1:])]
                             + [np.repeat(q[-1:], settle, axis=0)])
    least = np.inf
    for target in targets:
        state, _, _ = arm.step(state, target[None, :])
        least = min(least, float(scene.clearance(state.q)[0]) + scene.margin)
    return JointTracking(least, float(np.max(np.abs(state.q[0, :3] - q[-1, :3]))), len(targets) * arm.p.dt)
