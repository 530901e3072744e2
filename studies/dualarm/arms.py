"""Two planar SCARA arms (the dual-arm paper): link polygons, swept-region enclosures, builtDR.

numpy only. Each arm is two rectangular links; the swept region of a link while its joints
move through a box of joint angles is enclosed by the convex hull of finitely many points:
for a rotation by at most α < π about a joint, each vertex contributes its two end positions
and the apex where the end tangents meet, at radius ρ / cos(α/2) on the bisector
(`cfmpa.arc_in_triangle`; the end poses alone miss the arc bulge, `cfmpa.arc_in_chord_hull`).
Link 1 needs 4 x 3 = 12 points. Link 2 is enclosed in two stages: its sweep about the elbow
(12 points in link 1's frame), then each of those swept about the base (36 points): rotation
maps hulls to hulls, so every intermediate pose lies inside.

Two enclosures are disjoint when some axis separates their points (`cfmpa.sat_separates`);
the test tries K fixed axes, which is sound for any axis set and only costs free cells where
no tried axis separates two disjoint hulls. A cell is free only with a gap of 1e-9 * scale.

builtDR (Algorithm 1, step 3): P[k, i, j] = 1 if the principal's enclosure for layer k meets
the subordinate's enclosure for cell (i, j). The principal's joint box of layer k is
`original`: [θ - ωΔt, θ + ωΔt] per joint, or `modified` (§IV.A): [θ, θ + σωΔt], where θ is
its planned (synchronous PTP) pose at kΔt. The subordinate's box around cell (i, j) is
[θ - ωRΔt, θ + ωRΔt] per joint. N = ⌈T_f/Δt⌉ and m, n = ⌈2π/(ωRΔt)⌉ (D4: rounding down is
unsafe, `cfmpa.execution_layers_floor`, `cfmpa.execution_grid_floor`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from certiloop.studies.dualarm.generated.builtdr import controller as _extracted_builtdr
from certiloop.studies.dualarm.pins import check_extracted

MODES = ("original", "modified")
GAP = 1e-9  # relative separation a free cell needs


@dataclass(frozen=True)
class Arm:
    base: tuple[float, float]
    l1: float
    l2: float
    width: float


@dataclass(frozen=True)
class Scene:
    """Two arms, the principal's PTP motion, the speed limits and the latency Δt."""

    principal: Arm
    subordinate: Arm
    start: tuple[float, float]  # principal (θ1 absolute, θ2 relative to link 1)
    goal: tuple[float, float]
    w_principal: tuple[float, float]
    w_subordinate: tuple[float, float]
    dt: float
    r2_offset: float = -math.pi  # subordinate θ2 of column j is j h2 + r2_offset

    def __post_init__(self) -> None:
        for name, value in (("dt", self.dt), *((f"speed {w}", w) for w in (*self.w_principal,
                                                                           *self.w_subordinate))):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"scene: {name} must be a positive finite number, got {value!r}")
        if 2 * max(*self.w_principal, *self.w_subordinate) * self.dt >= math.pi:
            raise ValueError("scene: 2 ω Δt must be below π (a joint box must span less than half a turn)")
        for arm in (self.principal, self.subordinate):
            if min(arm.l1, arm.l2, arm.width) <= 0:
                raise ValueError("scene: link lengths and widths must be positive")

    @property
    def tf(self) -> float:
        return max(abs(g - s) / w for s, g, w in zip(self.start, self.goal, self.w_principal))

    @property
    def layers(self) -> int:
        """N = ⌈T_f/Δt⌉, at least 1 (a tolerance of 1e-9 absorbs float noise in T_f/Δt)."""
        return max(1, math.ceil(self.tf / self.dt - 1e-9))

    @property
    def grid(self) -> tuple[int, int]:
        """(m, n) = ⌈2π/(ωR Δt)⌉: one cell per Δt at full speed, grid step h <= ωR Δt."""
        return tuple(math.ceil(2 * math.pi / (w * self.dt) - 1e-9) for w in self.w_subordinate)

    @property
    def steps(self) -> tuple[float, float]:
        m, n = self.grid
        return 2 * math.pi / m, 2 * math.pi / n

    def cell_angles(self, i, j):
        h1, h2 = self.steps
        return np.asarray(i) * h1, np.asarray(j) * h2 + self.r2_offset

    def planned_pose(self, t: float) -> np.ndarray:
        """Synchronous PTP: both joints start and stop together, θ(t) = S + (G - S) min(t/T_f, 1)."""
        s, g = np.asarray(self.start, float), np.asarray(self.goal, float)
        frac = 1.0 if self.tf == 0 else min(max(t / self.tf, 0.0), 1.0)
        return s + (g - s) * frac

    @property
    def directions(self) -> np.ndarray:
        """σa = +1 if θGa > θSa else -1 (§IV.A)."""
        return np.where(np.asarray(self.goal) > np.asarray(self.start), 1.0, -1.0)

    def principal_boxes(self, mode: str) -> np.ndarray:
        """(N, 2, 2): per layer and joint, the [lo, hi] joint interval the database reserves."""
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; use one of {MODES}")
        w = np.asarray(self.w_principal) * self.dt
        poses = np.array([self.planned_pose(k * self.dt) for k in range(self.layers)])
        if mode == "original":
            return np.stack([poses - w, poses + w], axis=-1)
        far = poses + self.directions * w
        return np.stack([np.minimum(poses, far), np.maximum(poses, far)], axis=-1)


def rectangle(length: float, width: float) -> np.ndarray:
    """A link along +x from its joint: (4, 2) vertices."""
    return np.array([[0.0, -width / 2], [length, -width / 2], [length, width / 2], [0.0, width / 2]])


def _rot(angle):
    """Rotation matrices for an array of angles: (..., 2, 2)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _rotate(points: np.ndarray, angle: np.ndarray, scale: np.ndarray | float = 1.0) -> np.ndarray:
    """points (..., P, 2) rotated by angle (...) and scaled, broadcasting the leading axes."""
    c, s = (np.cos(angle) * scale)[..., None], (np.sin(angle) * scale)[..., None]
    x, y = points[..., 0], points[..., 1]
    return np.stack([c * x - s * y, s * x + c * y], -1)


def sweep_points(points: np.ndarray, lo, hi) -> np.ndarray:
    """Enclosure of `points` (..., P, 2) rotated about the origin by any angle in [lo, hi]:
    (..., 3P, 2) = end positions and tangent apexes. lo, hi broadcast over the leading axes."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    half = (hi - lo) / 2
    apex = _rotate(points, lo + half, 1.0 / np.cos(half))
    return np.concatenate([_rotate(points, lo), _rotate(points, hi), apex], axis=-2)


def arm_enclosures(arm: Arm, box1, box2) -> tuple[np.ndarray, np.ndarray]:
    """Points enclosing link 1 and link 2 of `arm` over the joint box [box1] x [box2]
    (arrays of [lo, hi] pairs, broadcast): (..., 12, 2) and (..., 36, 2), world frame."""
    box1, box2 = np.asarray(box1, float), np.asarray(box2, float)
    base = np.asarray(arm.base, float)
    link1 = sweep_points(rectangle(arm.l1, arm.width), box1[..., 0], box1[..., 1])
    elbow = sweep_points(rectangle(arm.l2, arm.width), box2[..., 0], box2[..., 1]) + np.array([arm.l1, 0.0])
    link2 = sweep_points(elbow, box1[..., 0], box1[..., 1])
    return link1 + base, link2 + base


def static_arm(arm: Arm, pose) -> tuple[np.ndarray, np.ndarray]:
    """The two link rectangles of `arm` at joint pose (θ1, θ2): (4, 2) each, world frame."""
    t1, t2 = pose
    r1, r12 = _rot(np.float64(t1)), _rot(np.float64(t1 + t2))
    base = np.asarray(arm.base, float)
    link1 = rectangle(arm.l1, arm.width) @ r1.T + base
    link2 = rectangle(arm.l2, arm.width) @ r12.T + base + r1 @ np.array([arm.l1, 0.0])
    return link1, link2


def axes(count: int = 64) -> np.ndarray:
    """count unit directions over a half turn (a direction and its opposite test the same)."""
    a = np.arange(count) * math.pi / count
    return np.stack([np.cos(a), np.sin(a)], -1)


def projections(points: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Min and max of the points' projections on each axis: (..., K) each, as float32 rounded
    outwards (the min down, the max up), so the intervals still contain the float64 ones and
    the comparisons run on half the memory."""
    proj = points @ dirs.T
    lo, hi = proj.min(axis=-2), proj.max(axis=-2)
    return (np.nextafter(lo.astype(np.float32), np.float32(-np.inf)),
            np.nextafter(hi.astype(np.float32), np.float32(np.inf)))


def _separated(a_min, a_max, b_min, b_max, gap) -> np.ndarray:
    """Some axis separates A and B by more than gap (reduces the last axis)."""
    return ((a_max + gap < b_min) | (b_max + gap < a_min)).any(axis=-1)


def subordinate_enclosures(scene: Scene, dirs: np.ndarray):
    """Projections of the subordinate's link enclosures per row i (link 1) and cell (i, j) (link 2)."""
    m, n = scene.grid
    r1, r2 = scene.cell_angles(np.arange(m), np.arange(n))
    wr = np.asarray(scene.w_subordinate) * scene.dt
    box1 = np.stack([r1 - wr[0], r1 + wr[0]], -1)  # (m, 2)
    box2 = np.stack([r2 - wr[1], r2 + wr[1]], -1)  # (n, 2)
    link1, _ = arm_enclosures(scene.subordinate, box1, box2[:1])
    # link 2 row by row: (n, 36, K) projections at a time instead of (m, n, 36, K)
    mins, maxs = np.empty((m, n, len(dirs)), np.float32), np.empty((m, n, len(dirs)), np.float32)
    for i in range(m):
        _, link2 = arm_enclosures(scene.subordinate, box1[i], box2)
        mins[i], maxs[i] = projections(link2, dirs)
    return projections(link1, dirs), (mins, maxs)


def builtdr(scene: Scene, mode: str = "modified", axis_count: int = 64) -> np.ndarray:
    """The state database D_R: (N, m, n) uint8, 1 where the swept regions may meet."""
    check_extracted()
    dirs = axes(axis_count)
    boxes = scene.principal_boxes(mode)
    p1, p2 = arm_enclosures(scene.principal, boxes[:, 0, :], boxes[:, 1, :])
    (s1_min, s1_max), (s2_min, s2_max) = subordinate_enclosures(scene, dirs)
    (q1_min, q1_max), (q2_min, q2_max) = projections(p1, dirs), projections(p2, dirs)
    sub = scene.subordinate
    scale = max(np.abs(p2).max(), np.abs(sub.base).max() + sub.l1 + sub.l2)
    gap = np.float32(max(GAP * scale, 4 * np.finfo(np.float32).eps * scale))  # above float32 rounding
    m, n = scene.grid
    meet = np.empty((scene.layers, m, n), dtype=bool)  # the overlap predicate of `cfmpa.builtdr`
    for k in range(scene.layers):
        # link 1 of the subordinate depends on the row only: (m, 1) broadcast over columns
        free = _separated(q1_min[k], q1_max[k], s1_min, s1_max, gap)[:, None]
        free = free & _separated(q2_min[k], q2_max[k], s1_min, s1_max, gap)[:, None]
        free = free & _separated(q1_min[k], q1_max[k], s2_min, s2_max, gap)
        free = free & _separated(q2_min[k], q2_max[k], s2_min, s2_max, gap)
        meet[k] = ~free
    # the database itself is filled by the code extracted from the proved model (Theorem 1)
    database, enabled = _extracted_builtdr(scene.layers, m, n, meet)
    if not enabled:  # cannot happen: the model's two branches cover every cell
        raise RuntimeError("extracted builtDR has no run on this overlap array")
    return database.astype(np.uint8)


def reference_scene(dt: float = 0.1) -> Scene:
    """Scene R1 of the spec: links 1.0 and 0.8 m (the public two_scara_collaboration URDF; the
    paper gives no dimensions), 0.1 m wide, bases 1.5 m apart, all ω = 1 rad/s, principal from
    (0.25, 0.5) to (0.7, -1.5), so T_f = 2 s."""
    arm = dict(l1=1.0, l2=0.8, width=0.1)
    return Scene(principal=Arm(base=(0.0, 0.0), **arm), subordinate=Arm(base=(1.5, 0.0), **arm),
                 start=(0.25, 0.5), goal=(0.7, -1.5), w_principal=(1.0, 1.0), w_subordinate=(1.0, 1.0),
                 dt=dt)
