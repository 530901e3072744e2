"""Planning scenes: the arm's joint box, start and goal, and the geometry to keep clear of.

Geometry is a list of *clauses*, each a list of planes (n, c): a clause holds at a joint
state when one of its planes has both the wrist and the tip on its safe side with the
margin, n·wrist >= c + m and n·tip >= c + m. Because a half-space is convex, both ends on
the safe side puts the whole wrist-tip link there too.

* a **wall** (the cavity's sides and floor) is a clause of one plane: the arm must stay
  inside. The RCM (the base origin) must satisfy every wall as well (checked here), so the
  whole tool, RCM - wrist - tip, stays inside the walls;
* a **block** (an obstacle inside the cavity) is a clause of its six face planes, outward:
  the wrist-tip link is clear of the box when one face separates it. That is sufficient,
  not necessary (a link passing a corner diagonally may be clear with no face separating
  it), so a block is a little larger for the planner than it is. The shaft is not checked
  against blocks (only against the walls).

`raven.frs_box` models the paper's FRS dome experiment (§4.2, Fig 7-8): "Initially, the
robot arm is placed deeply inside the FRS training module. The test scenario is to achieve
the motion sequences of retrieving the robot arm first from the surgical field and then
moving forward to reach the cube ring." The paper gives no dimensions; these are ours. In
the base frame of the left arm (the RCM at the origin, -y roughly along the shaft into the
body): the cavity is the box x in [-0.08, 0.08], z in [-0.05, 0.11], floor y = -0.20 m;
a partition (the peg board between the ring's start and goal) stands on the floor,
x in [-0.012, 0.012], y in [-0.20, -0.12], z in [-0.05, 0.07], leaving a 4 cm gap at the
z = 0.11 wall; the margin is 2 mm. The start has the tip at (-0.045, -0.160, 0.020) on one
side of the partition, the goal at (0.045, -0.160, 0.020) on the other: the straight joint
path runs through the partition, so the arm must retract over it or pass through the gap.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from certiloop.studies.raven.arm import DEG
from certiloop.studies.raven.plan import kinematics

Plane = tuple[tuple[float, float, float], float]  # (n, c): safe side n·p >= c (+ margin)


def box_faces(lo, hi) -> list[Plane]:
    """The six outward face planes of an axis-aligned box: outside face i is n·p >= c."""
    faces = []
    for axis in range(3):
        e = [0.0, 0.0, 0.0]
        e[axis] = -1.0
        faces.append((tuple(e), -float(lo[axis])))  # p[axis] <= lo
        e = [0.0, 0.0, 0.0]
        e[axis] = 1.0
        faces.append((tuple(e), float(hi[axis])))  # p[axis] >= hi
    return faces


@dataclass(frozen=True)
class Scene:
    name: str
    description: str
    joint_lo: tuple
    joint_hi: tuple
    start: tuple
    goal: tuple
    walls: tuple  # of Plane
    blocks: tuple  # of (lo, hi) boxes
    margin: float
    arm: str = "left"
    clauses: tuple = field(init=False)
    _plane_table: tuple = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        clauses = tuple((plane,) for plane in self.walls) + tuple(tuple(box_faces(lo, hi))
                                                                 for lo, hi in self.blocks)
        object.__setattr__(self, "clauses", clauses)
        normals = np.array([n for clause in clauses for n, _ in clause], dtype=float)
        offsets = np.array([c for clause in clauses for _, c in clause], dtype=float)
        starts = np.cumsum([0] + [len(clause) for clause in clauses[:-1]])
        object.__setattr__(self, "_plane_table", (normals, offsets, starts))
        for n, c in self.walls:
            if not 0.0 >= c + self.margin:
                raise ValueError(f"scene {self.name}: the RCM is outside the wall {n}·p >= {c}")
        for name, q in (("start", self.start), ("goal", self.goal)):
            if not self.valid(np.array([q]))[0]:
                raise ValueError(f"scene {self.name}: the {name} configuration is not clear")

    @property
    def lo(self) -> np.ndarray:
        return np.array(self.joint_lo, dtype=float)

    @property
    def hi(self) -> np.ndarray:
        return np.array(self.joint_hi, dtype=float)

    def clearance(self, q) -> np.ndarray:
        """Per state (R,): the least clause slack (>= 0 means clear), in metres (floats);
        -inf outside the joint box."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        wrist, tip = kinematics.points(q, self.arm)
        normals, offsets, starts = self._plane_table
        slack = np.minimum(wrist @ normals.T, tip @ normals.T) - offsets - self.margin  # (R, planes)
        worst = np.min(np.maximum.reduceat(slack, starts, axis=1), axis=1)
        inside = np.all((q >= self.lo) & (q <= self.hi), axis=1)
        return np.where(inside, worst, -np.inf)

    def valid(self, q) -> np.ndarray:
        return self.clearance(q) >= 0.0

    def to_json(self) -> dict:
        return {"name": self.name, "arm": self.arm, "margin": self.margin,
                "joint_lo": list(self.joint_lo), "joint_hi": list(self.joint_hi),
                "start": list(self.start), "goal": list(self.goal),
                "clauses": [[{"normal": list(n), "offset": c} for n, c in clause] for clause in self.clauses]}


FRS_BOX = Scene(
    name="raven.frs_box",
    description="the paper's FRS-dome experiment: retract from deep in the cavity over a partition, "
                "reach the ring",
    joint_lo=(0.0, 45 * DEG, 0.23, -90 * DEG, -90 * DEG, -90 * DEG),
    joint_hi=(90 * DEG, 135 * DEG, 0.56, 90 * DEG, 90 * DEG, 90 * DEG),
    start=(0.5603, 1.6484, 0.3031, 0.0, 0.0, 0.0),
    goal=(1.1086, 1.6484, 0.3031, 0.0, 0.0, 0.0),
    walls=(((1.0, 0.0, 0.0), -0.08), ((-1.0, 0.0, 0.0), -0.08), ((0.0, 0.0, 1.0), -0.05),
           ((0.0, 0.0, -1.0), -0.11), ((0.0, 1.0, 0.0), -0.20)),
    blocks=(((-0.012, -0.20, -0.05), (0.012, -0.12, 0.07)),),
    margin=0.002,
)

SCENES = {FRS_BOX.name: FRS_BOX}
