"""Closed-form wrist and tip positions of the Raven-II arm, vectorised (numpy only).

From the DH table in `certiloop.studies.raven.arm` (Craig's convention, link transform
Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(d)): links 4-6 add no offsets but d4 = -0.47 m
along frame 3's z axis and a6 = Lw, so with R3 = Rx(a1) Rz(th1) Rx(a2) Rz(th2) Rx(a3) Rz(theta3)

    wrist = R3 (0, 0, d3 - 0.47)
    tip   = R3 (Lw cos th4 cos th5, Lw sin th4 cos th5, d3 - 0.47 + Lw sin th5)

(th6, the grasper's yaw, moves neither). The same formula is evaluated on floats here and on
intervals in `certify.py`; `raven.frames` (the 4x4 product) is the independent check in the
tests. The form is generic in its arithmetic: `chain` only adds and multiplies.
"""

from __future__ import annotations

import numpy as np

from certiloop.studies.raven.arm import ALPHA, D4, LW, THETA3


def rotate_x(v, c, s):
    x, y, z = v
    return (x, c * y - s * z, s * y + c * z)


def rotate_z(v, c, s):
    x, y, z = v
    return (c * x - s * y, s * x + c * y, z)


def local_points(d3, c4, s4, c5, s5):
    """Wrist and tip in frame 3, as coordinate triples (generic arithmetic)."""
    depth = d3 + D4
    wrist = (0.0 * depth, 0.0 * depth, depth)
    tip = (c5 * c4 * LW, c5 * s4 * LW, depth + s5 * LW)
    return wrist, tip


def chain(v, trig1, trig2, consts):
    """R3 v for v a coordinate triple; trig_i = (cos th_i, sin th_i); consts = the fixed
    (cos, sin) of alpha1, alpha2, alpha3 and theta3 (floats or intervals)."""
    (ca1, sa1), (ca2, sa2), (ca3, sa3), (ct3, st3) = consts
    v = rotate_z(v, ct3, st3)
    v = rotate_x(v, ca3, sa3)
    v = rotate_z(v, *trig2)
    v = rotate_x(v, ca2, sa2)
    v = rotate_z(v, *trig1)
    return rotate_x(v, ca1, sa1)


def float_consts(arm: str = "left"):
    a = ALPHA[arm]
    return ((np.cos(a[0]), np.sin(a[0])), (np.cos(a[1]), np.sin(a[1])), (np.cos(a[2]), np.sin(a[2])),
            (np.cos(THETA3[arm]), np.sin(THETA3[arm])))


def points(q, arm: str = "left") -> tuple[np.ndarray, np.ndarray]:
    """Wrist and tip positions, each (R, 3), for joint vectors q of shape (R, 6)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    consts = float_consts(arm)
    trig1, trig2 = (np.cos(q[:, 0]), np.sin(q[:, 0])), (np.cos(q[:, 1]), np.sin(q[:, 1]))
    wrist, tip = local_points(q[:, 2], np.cos(q[:, 3]), np.sin(q[:, 3]), np.cos(q[:, 4]), np.sin(q[:, 4]))
    return (np.stack(chain(wrist, trig1, trig2, consts), axis=-1),
            np.stack(chain(tip, trig1, trig2, consts), axis=-1))
