"""The paper's scene: the LWR4+ at q_d(0) = [20 50 0 -70 0 60 0] deg with the 0.43 m tool through
p_c = (-0.6053, -0.2203, 0), above a synthetic vessel sheet sampled at the paper's 4.04 mm
spacing (d_c = 3.5 mm after downsampling; the real clouds are not public).

`demo_controller(points=N)` returns an `RcmAdmittance` whose `step()` advances one 4 ms period.
"""

from __future__ import annotations

import numpy as np

from certiloop.studies.rcm.arm import Q_ANCHOR, tool_tip
from certiloop.studies.rcm.cloud import CloudBarrier
from certiloop.studies.rcm.dynamics import TABLE1, RcmAdmittance

TOOL_LENGTH = 0.43


def _port_on_axis() -> np.ndarray:
    """The paper's p_c = (-0.6053, -0.2203, 0) is rounded to 0.1 mm; the exact point of the tool
    axis at z = 0 (within 5e-5 m of it) starts the demo on S, with x_c = 0."""
    p_t, n, _, _ = tool_tip(Q_ANCHOR, TOOL_LENGTH)
    return p_t - (p_t[2] / n[2]) * n


P_C_PAPER = np.array([-0.6053, -0.2203, 0.0])
P_C = _port_on_axis()
D_C = 0.0035          # ball radius after downsampling
SPACING = 0.00404     # grid spacing whose cell diagonal is 2 d_c (the cover claim)
RADIUS = 0.0035       # capsule radius of the 7 mm tool


def vessel_sheet(points: int, below: float, centre: np.ndarray) -> np.ndarray:
    """`points` grid points nearest `centre`'s vertical, on a gently curved sheet `below` m under it."""
    side = int(np.ceil(np.sqrt(points))) + 2
    ij = (np.arange(side) - (side - 1) / 2) * SPACING
    X, Y = np.meshgrid(ij, ij)
    xy = np.column_stack([X.ravel(), Y.ravel()])
    xy = xy[np.argsort(np.einsum("ij,ij->i", xy, xy), kind="stable")[:points]]
    z = centre[2] - below + 0.5 * (xy[:, 0] ** 2 + xy[:, 1] ** 2)   # bowl of curvature radius 1 m
    return np.column_stack([centre[0] + xy[:, 0], centre[1] + xy[:, 1], z])


def demo_controller(points: int = 1000, mode: str = "tip", integrator: str = "euler", guard: bool = True,
                    gap: float = 0.02, dt: float = 0.004) -> RcmAdmittance:
    """The scene with an N-point cloud whose nearest ball is `gap` m below the tip (or the tool)."""
    if not isinstance(points, (int, np.integer)) or points < 0:
        raise ValueError(f"points must be a non-negative integer, not {points!r}")
    p_t = tool_tip(Q_ANCHOR, TOOL_LENGTH)[0]
    radius = RADIUS if mode == "tool" else 0.0
    cloud = vessel_sheet(int(points), gap + D_C + radius, p_t)
    barrier = CloudBarrier(cloud, D_C, TABLE1.d0, TABLE1.k, radius)
    return RcmAdmittance(Q_ANCHOR.copy(), P_C, barrier, TOOL_LENGTH, mode, integrator, guard, dt=dt)
