"""The arm and the guard of the RCM paper's admittance controller (KUKA LWR4+, 250 Hz), numpy only.

Import them from `certiloop.studies.rcm.kernel`, which also exports the full controller.

* `lwr4_forward(q)`: 4x4 flange pose; `lwr4_jacobian(q, tool_length)`: the 6x7 geometric
  Jacobian of the tool tip (linear rows first), both from the standard DH table below.
* `rcm_error`, `rcm_constraint_jacobian`: x_c = B_c^T (p_t - p_c) (1) and A = A_x J_t (4)-(7).
* `null_projector(A, W)`: N = I - A^dagger A with the weighted pseudo-inverse of (18).
* The axial reduction of (27) with the paper's barrier (11)-(13) and damping (43)-(45)
  (`barrier_force_axial`, `damping_axial`, `axial_euler_step`): the paper's 4 ms explicit
  Euler, used by the tests to show the crossing the model `rcm.axial_euler_4ms` refutes.
* The proved sampled-data guard (`rcm.axial_guard`): `guard_speed` runs the model's control
  step as extracted into `studies/rcm/generated/axial_guard.py` (hash-pinned: it refuses to run if the model
  changed since, and the gate re-extracts it byte for byte); `guarded_tip_velocity`
  applies it to a tip velocity against a point cloud (the gap is the smallest distance to
  a ball of radius d_c, the speed |v| bounds how fast any gap closes). Non-finite input,
  or a tip already inside the inflated region, gives a zero command; nothing here returns NaN.

The guard's guarantee is the model's: with the tip moving at the commanded (constant)
velocity for at most one period, every gap stays >= margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from certiloop.studies.rcm.generated import axial_guard as rcm_guard

# --------------------------------------------------------------------------- LWR4+ kinematics

# Standard DH (theta_i = q_i, a_i = 0) of the KUKA LWR4+: d = (0.31, 0, 0.40, 0, 0.39, 0, 0.078) m,
# alpha = (pi/2, -pi/2, -pi/2, pi/2, pi/2, -pi/2, 0): the arm's published link lengths
# (KUKA LWR4+ specification: shoulder 0.31 m, upper arm 0.40 m, forearm 0.39 m, flange
# 0.078 m). Checked against the paper's own anchor (tests/studies/rcm/test_rcm_kernel.py): at
# q = [20 50 0 -70 0 60 0] deg the flange is at (-0.6053, -0.2203, 0.2941) m, tool axis down.
DH_D = np.array([0.31, 0.0, 0.40, 0.0, 0.39, 0.0, 0.078])
DH_ALPHA = np.array([1, -1, -1, 1, 1, -1, 0]) * (np.pi / 2)
Q_ANCHOR = np.radians([20.0, 50.0, 0.0, -70.0, 0.0, 60.0, 0.0])


def link_frames(q: np.ndarray) -> list[np.ndarray]:
    """T_0 (identity), T_0^1, ..., T_0^7."""
    out = [np.eye(4)]
    T = np.eye(4)
    for th, d, al in zip(q, DH_D, DH_ALPHA):
        ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
        T = T @ np.array([[ct, -st * ca, st * sa, 0.0], [st, ct * ca, -ct * sa, 0.0],
                          [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]])
        out.append(T)
    return out


def lwr4_forward(q) -> np.ndarray:
    """The flange pose (4x4 homogeneous transform) for joint angles q (7, rad)."""
    q = np.asarray(q, dtype=float).reshape(7)
    return link_frames(q)[-1]


def lwr4_jacobian(q, tool_length: float = 0.0) -> np.ndarray:
    """Geometric Jacobian (6x7: linear velocity, then angular) of the point tool_length along
    the flange's z axis (the tool tip p_t; 0 gives the flange)."""
    q = np.asarray(q, dtype=float).reshape(7)
    frames = link_frames(q)
    end = frames[-1]
    p = end[:3, 3] + tool_length * end[:3, 2]
    J = np.zeros((6, 7))
    for i in range(7):
        z, o = frames[i][:3, 2], frames[i][:3, 3]
        J[:3, i] = np.cross(z, p - o)
        J[3:, i] = z
    return J


def tool_tip(q, tool_length: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(p_t, n_t, a_t, o_t): tip position and the tool frame's z, x, y axes."""
    T = lwr4_forward(q)
    n, a, o = T[:3, 2], T[:3, 0], T[:3, 1]
    return T[:3, 3] + tool_length * n, n, a, o


def _hat(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def rcm_error(q, p_c, tool_length: float) -> np.ndarray:
    """x_c = B_c^T (p_t - p_c) (1): the offset of p_c from the tool axis, in the tool's x, y."""
    p, _, a, o = tool_tip(q, tool_length)
    r = p - np.asarray(p_c, dtype=float)
    return np.array([a @ r, o @ r])


def rcm_constraint_jacobian(q, p_c, tool_length: float) -> np.ndarray:
    """A = A_x J_t (2x7), A_x = B_c^T [I  (p_t - p_c)^] (4): x_c' = A q'."""
    p, _, a, o = tool_tip(q, tool_length)
    r = p - np.asarray(p_c, dtype=float)
    Bt = np.vstack([a, o])
    Ax = np.hstack([Bt, Bt @ _hat(r)])
    return Ax @ lwr4_jacobian(q, tool_length)


def null_projector(A: np.ndarray, W: np.ndarray | None = None) -> np.ndarray:
    """N = I - A^dagger A with A^dagger = W^-1 A^T (A W^-1 A^T)^-1 (18): A N = 0, N N = N."""
    A = np.asarray(A, dtype=float)
    n = A.shape[1]
    Winv = np.eye(n) if W is None else np.linalg.inv(np.asarray(W, dtype=float))
    Adag = Winv @ A.T @ np.linalg.inv(A @ Winv @ A.T)
    return np.eye(n) - Adag @ A


# --------------------------------------------------------------------------- the axial reduction

H = 0.004          # 250 Hz
D0 = 0.0115        # d_0
K_BAR = 0.01       # k_i
DC1, Q1, M1, G1, C1 = 10.0, 25.0, 22.0, 60.0, 0.01   # D_f element 1, Table 1


def barrier_force_axial(gap: float) -> float:
    """|f| of (11)-(13) at gap = rho - d_c: 2 k ln(1/(1-psi)) (d_0 - gap) / (d_0^2 (1-psi)) in the
    band 0 < gap < d_0, 0 beyond it, +inf at or inside the ball."""
    if gap >= D0:
        return 0.0
    if gap <= 0.0:
        return math.inf
    y = gap * (2 * D0 - gap) / D0**2
    return 2 * K_BAR * math.log(1.0 / y) * (D0 - gap) / (D0**2 * y)


def damping_axial(w: float, f: float) -> float:
    """D_f1 = D_c + Q exp(-M |w|) + G (1 - exp(-C f^2)) (43)-(45), Table 1 element 1."""
    return DC1 + Q1 * math.exp(-M1 * abs(w)) + G1 * (1.0 - math.exp(-C1 * f * f))


def axial_euler_step(gap: float, w: float, push: float, h: float = H) -> tuple[float, float]:
    """One explicit Euler step of (27) on the tool axis, as the paper integrates it: the gap
    moves with the old approach speed w, then w := w + h (F - f - D w)."""
    f = barrier_force_axial(gap)
    d = damping_axial(w, f)
    return gap - h * w, w + h * (push - f - d * w)


_guard_checked = False


def _check_guard_extracted() -> None:
    """Refuse to run guard code extracted from a model that has changed since (once per process)."""
    global _guard_checked
    if _guard_checked:
        return
    from certiloop.models import library

    current = library.get(rcm_guard.MODEL).content_hash
    if current != rcm_guard.MODEL_HASH:
        raise RuntimeError(f"studies/rcm/generated/axial_guard.py was extracted from an older "
                           f"{rcm_guard.MODEL} (hash {rcm_guard.MODEL_HASH}, now {current}); run "
                           "`python -m certiloop.studies regenerate`")
    _guard_checked = True


def guard_speed(gap: float, speed: float, margin: float, period: float = H) -> float:
    """The control step of the proved model rcm.axial_guard, run by the code extracted from it
    (studies/rcm/generated/axial_guard.py): keep `speed` if one period at it keeps gap >= margin, else command
    (gap - margin)/period. Non-finite input or a gap already below the margin (outside the
    model's premise) gives 0. The model's decision is real-valued; the float result is
    lowered by a few ulps where rounding would end the period below the margin (checked exactly)."""
    vals = (gap, speed, margin, period)
    if not all(math.isfinite(x) for x in vals) or period <= 0 or margin <= 0 or gap < margin:
        return 0.0
    _check_guard_extracted()
    cmd, enabled = rcm_guard.controller(period, speed, gap, margin)
    if not enabled or not math.isfinite(cmd):
        return 0.0
    # the float decision and division may be off by an ulp: lower the command until one period
    # at it provably (in exact rationals) ends at >= margin; moving away (cmd <= 0) always does
    slack = Fraction(gap) - Fraction(margin)
    for _ in range(64):
        if cmd <= 0.0 or Fraction(period) * Fraction(cmd) <= slack:
            return cmd
        cmd = math.nextafter(cmd, -math.inf)
    return 0.0


@dataclass(frozen=True)
class GuardedCommand:
    velocity: np.ndarray      # the commanded tip velocity (3,), never NaN
    scale: float              # k in [0, 1]: velocity = k * requested
    gap: float                # smallest distance to a cloud ball (rho - d_c), inf without a cloud
    ok: bool
    reason: str


def _zero(reason: str, gap: float = math.nan) -> GuardedCommand:
    return GuardedCommand(np.zeros(3), 0.0, gap if math.isfinite(gap) else 0.0, False, reason)


def guarded_tip_velocity(p_tip, v_tip, cloud, d_c: float, margin: float,
                         period: float = H) -> GuardedCommand:
    """Scale the requested tip velocity so that one period at it keeps every gap >= margin:
    the model's guard with gap = min_i |p - c_i| - d_c and speed = |v|."""
    try:
        p = np.asarray(p_tip, dtype=float).reshape(3)
        v = np.asarray(v_tip, dtype=float).reshape(3)
        pts = np.asarray(cloud, dtype=float).reshape(-1, 3)
        d_c, margin, period = float(d_c), float(margin), float(period)
    except (TypeError, ValueError):
        return _zero("malformed input")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(v)) and np.all(np.isfinite(pts))
            and all(math.isfinite(x) for x in (d_c, margin, period))):
        return _zero("non-finite input")
    if period <= 0 or margin <= 0 or d_c < 0:
        return _zero("bad parameters")
    gap = float(np.min(np.linalg.norm(pts - p, axis=1)) - d_c) if len(pts) else math.inf
    speed = float(np.linalg.norm(v))
    if not math.isfinite(speed):
        return _zero("non-finite input")
    if gap < margin:
        return _zero("tip inside the inflated region (outside the guard's premise)", gap)
    if speed == 0.0 or math.isinf(gap):
        return GuardedCommand(v.copy(), 1.0, gap, True, "")
    allowed = guard_speed(gap, speed, margin, period)
    k = min(1.0, max(0.0, allowed / speed))
    # rounding: never let k * speed * period exceed gap - margin
    while k > 0.0 and k * speed * period > gap - margin:
        k = math.nextafter(k, 0.0)
    return GuardedCommand(k * v, k, gap, True, "" if k == 1.0 else "limited by the guard")


def guarded_axial_step(gap: float, w: float, push: float, margin: float,
                       h: float = H) -> tuple[float, float]:
    """The paper's Euler step with the guard on the position update: the gap moves with the
    guarded speed (the command the plant receives); the admittance state follows it."""
    if not all(math.isfinite(x) for x in (gap, w, push, margin, h)) or gap < margin or margin <= 0:
        return gap if math.isfinite(gap) else 0.0, 0.0   # hold: zero velocity command
    cmd = guard_speed(gap, w, margin, h)
    f = barrier_force_axial(gap)
    d = damping_axial(cmd, f)
    w_next = cmd + h * (push - f - d * cmd)
    return gap - h * cmd, w_next if math.isfinite(w_next) else 0.0
