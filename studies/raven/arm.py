"""The Raven-II paper's arm: kinematics (eqs 3-4) and joint PD/PID dynamics (numpy only).

Kinematics: the modified (Craig) DH table of the public Raven II control software
(CSLDepend/raven2_sim, `include/raven/r2_kinematics.h` and `src/raven/r2_kinematics.cpp`;
the numbers are facts of the mechanism, the code here is our own):

    link          1      2      3 (insertion)   4        5      6
    alpha left    0      75°    180° - 52°      0        90°    90°
    alpha right   180°   75°    52°             0        90°    90°
    a             0      0      0               0        0      Lw = 0.013 m
    d             0      0      d3 (variable)   -0.47 m  0      0
    theta         th1    th2    +90° / -90°     th4      th5    th6

with link i's transform Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(d). The tool tip is
the origin of frame 6; the RCM (remote centre of motion) is the base origin, and the wrist
is |d3 - 0.47| from it. Joint values are DH thetas (the control software's joint-angle
offsets are not applied). Joint limits (defines.h): shoulder 0-90°, elbow 45-135°,
insertion 0.23-0.56 m.

Dynamics (the paper's §3.1: joint torque -> joint state, PD on the revolute joints, PID on
the insertion, hand-tuned, bounded torque): each positioning joint (shoulder, elbow,
insertion) is a decoupled inertia with viscous damping, I q'' = tau - b q', integrated
semi-implicitly at 1 kHz; the tool joints follow their targets kinematically. Torque limits
come from the control software's DAC limits (5000 counts shoulder/elbow, 4000 insertion)
times its DAC gain (2.7376e-4 N·m/count) through the cable reduction (r_l / r_mc = 63.095 /
5.675 mm), or for the insertion divided by the capstan radius r_mc — order-of-magnitude
values, not a calibrated plant. Everything is batched over runs: q is (R, 6).

Safety of the kernel itself: a non-finite target or state never produces a NaN torque; the
joint is braked instead (tau = -Kd q', clipped), and `step` reports which runs were.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DEG = np.pi / 180.0
LW = 0.013  # m, tool wrist length (a6)
D4 = -0.47  # m
ALPHA = {"left": np.array([0.0, 75 * DEG, np.pi - 52 * DEG, 0.0, 90 * DEG, 90 * DEG]),
         "right": np.array([np.pi, 75 * DEG, 52 * DEG, 0.0, 90 * DEG, 90 * DEG])}
A = np.array([0.0, 0.0, 0.0, 0.0, 0.0, LW])
THETA3 = {"left": np.pi / 2, "right": -np.pi / 2}
LIMITS = np.array([[0.0, 90 * DEG], [45 * DEG, 135 * DEG], [0.23, 0.56]])  # shoulder, elbow, insertion

DAC_GAIN = 2.7376e-4  # N·m per DAC count (motor side)
R_MC, R_L = 5.675e-3, 63.095e-3  # m: motor capstan and link radii
MAX_DAC = np.array([5000.0, 5000.0, 4000.0])
TAU_MAX = np.array([MAX_DAC[0] * DAC_GAIN * R_L / R_MC, MAX_DAC[1] * DAC_GAIN * R_L / R_MC,
                    MAX_DAC[2] * DAC_GAIN / R_MC])  # N·m, N·m, N
DT = 1e-3  # s: Raven's 1 kHz control loop


def _link(alpha, a, theta, d):
    """Craig's link transform for arrays of theta/d (shape (R,)), as (R, 4, 4)."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(np.shape(theta) + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = ct, -st, a
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st * ca, ct * ca, -sa, -sa * d
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = st * sa, ct * sa, ca, ca * d
    T[..., 3, 3] = 1.0
    return T


def frames(q, arm: str = "left") -> np.ndarray:
    """Transforms of frames 1..6 in the base frame, (R, 6, 4, 4), for q = (th1, th2, d3,
    th4, th5, th6) of shape (R, 6) or (6,)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    alpha = ALPHA[arm]
    theta = [q[:, 0], q[:, 1], np.full(len(q), THETA3[arm]), q[:, 3], q[:, 4], q[:, 5]]
    d = [np.zeros(len(q)), np.zeros(len(q)), q[:, 2], np.full(len(q), D4), np.zeros(len(q)),
         np.zeros(len(q))]
    out = np.empty((len(q), 6, 4, 4))
    T = np.broadcast_to(np.eye(4), (len(q), 4, 4))
    for i in range(6):
        T = T @ _link(alpha[i], A[i], theta[i], d[i])
        out[:, i] = T
    return out


def tip(q, arm: str = "left") -> np.ndarray:
    """Eq 4: the tool tip position (R, 3) (or (3,) for one configuration)."""
    single = np.ndim(q) == 1
    p = frames(q, arm)[:, 5, :3, 3]
    return p[0] if single else p


def jacobian(q, arm: str = "left", h: float = 1e-6) -> np.ndarray:
    """Eq 3's linear part: d tip / d q, (R, 3, 6), by central differences (accurate to about
    h², far below the monitor's millimetres). The tip velocity is J q'."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    J = np.empty((len(q), 3, 6))
    for k in range(6):
        dq = np.zeros(6)
        dq[k] = h
        J[:, :, k] = (tip(q + dq, arm) - tip(q - dq, arm)) / (2 * h)
    return J


def tip_velocity(q, qdot, arm: str = "left") -> np.ndarray:
    """Eq 3: v = J(q) q' for batches (R, 6) -> (R, 3)."""
    return np.einsum("rij,rj->ri", jacobian(q, arm), np.atleast_2d(np.asarray(qdot, dtype=float)))


# The positioning chain works on vectors as (x, y, z) tuples of per-run arrays (or scalars):
# one stack at the end instead of one per rotation, which was most of a campaign tick.
def _rot_x(cs: tuple[float, float], v: tuple) -> tuple:
    c, s = cs
    x, y, z = v
    return x, c * y - s * z, s * y + c * z


def _rot_z(ct, st, v: tuple) -> tuple:
    x, y, z = v
    return ct * x - st * y, st * x + ct * y, z


def _z_cross(v: tuple) -> tuple:
    """e_z x v: the derivative of Rot_z(theta) v with respect to theta, at theta = 0."""
    x, y, _ = v
    return -y, x, 0.0


def _columns(rows: int, *vectors: tuple) -> np.ndarray:
    """Vectors given as (x, y, z) tuples -> an array (rows, 3, len(vectors)); one vector -> (rows, 3)."""
    out = np.empty((rows, 3, len(vectors)))
    for j, v in enumerate(vectors):
        for i in range(3):
            out[:, i, j] = v[i]
    return out[..., 0] if len(vectors) == 1 else out


class Positioning:
    """The tip as a function of the positioning joints (shoulder, elbow, insertion) alone, the
    tool joints held at `tool` (th4, th5, th6): a closed form with its analytic Jacobian, for
    the campaign loop, which evaluates them for every run at every tick (`tip` builds all
    six 4x4 frames). Link i maps a point x of its frame to Rot_x(alpha)(a e_x + Rot_z(theta)
    (x + d e_z)); the tool's frames 4-6 reduce to one constant point `c` in frame 3."""

    def __init__(self, arm: str = "left", tool=(0.0, 0.0, 0.0)) -> None:
        if arm not in ALPHA:
            raise ValueError("arm must be 'left' or 'right'")
        self.arm, self.alpha = arm, ALPHA[arm]
        q = np.array([0.0, 0.0, 0.0, *tool], dtype=float)
        f = frames(q, arm)[0]
        self.c = (np.linalg.inv(f[2]) @ f[5][:, 3])[:3]  # the tip in frame 3, whatever d3 (d3 = 0 here)
        self.c3, self.s3 = np.cos(THETA3[arm]), np.sin(THETA3[arm])
        self.rx = [(float(np.cos(a)), float(np.sin(a))) for a in self.alpha[:3]]

    def tip_and_jacobian(self, qp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """qp (R, 3) -> tip (R, 3) and d tip / d qp (R, 3, 3)."""
        qp = np.asarray(qp, dtype=float)
        r1, r2, r3 = self.rx
        c1, s1, c2, s2 = np.cos(qp[:, 0]), np.sin(qp[:, 0]), np.cos(qp[:, 1]), np.sin(qp[:, 1])
        ez = (0.0, 0.0, 1.0)
        x3 = (self.c[0], self.c[1], self.c[2] + qp[:, 2])  # in frame 3, before its rotation
        y2 = _rot_x(r3, _rot_z(self.c3, self.s3, x3))  # A[2] = 0: in frame 2
        dy2 = _rot_x(r3, _rot_z(self.c3, self.s3, ez))  # d/d d3
        y1 = _rot_x(r2, _rot_z(c2, s2, y2))  # A[1] = 0: in frame 1
        dy1_d3 = _rot_x(r2, _rot_z(c2, s2, dy2))
        dy1_th2 = _rot_x(r2, _rot_z(c2, s2, _z_cross(y2)))
        rows = len(qp)
        tip = _columns(rows, _rot_x(r1, _rot_z(c1, s1, y1)))  # A[0] = 0
        J = _columns(rows, _rot_x(r1, _rot_z(c1, s1, _z_cross(y1))), _rot_x(r1, _rot_z(c1, s1, dy1_th2)),
                     _rot_x(r1, _rot_z(c1, s1, dy1_d3)))
        return tip, J

    def tip(self, qp: np.ndarray) -> np.ndarray:
        return self.tip_and_jacobian(qp)[0]

    def ik_step(self, target: np.ndarray, qp: np.ndarray) -> np.ndarray:
        """One Newton step from qp towards the joints whose tip is `target` (R, 3), by Cramer's
        rule on the 3x3 Jacobian; warm-started from the last tick's solution, one step a tick
        converges quadratically. Rows whose step is not finite or whose Jacobian is
        (nearly) singular keep qp."""
        tip, J = self.tip_and_jacobian(qp)
        err = np.asarray(target, dtype=float) - tip
        j1, j2, j3 = J[..., 0], J[..., 1], J[..., 2]
        c23 = np.cross(j2, j3)
        det = np.einsum("ri,ri->r", j1, c23)
        ok = np.abs(det) > 1e-12
        safe = np.where(ok, det, 1.0)
        with np.errstate(invalid="ignore", over="ignore"):
            step = np.stack([np.einsum("ri,ri->r", err, c23), np.einsum("ri,ri->r", j1, np.cross(err, j3)),
                             np.einsum("ri,ri->r", j1, np.cross(j2, err))], axis=1) / safe[:, None]
            out = qp + step
        ok &= np.isfinite(out).all(axis=1)
        return np.where(ok[:, None], out, qp)


@dataclass
class ArmParams:
    """Decoupled joint dynamics of shoulder, elbow and insertion (hand-tuned, as the paper's)."""

    inertia: np.ndarray = field(default_factory=lambda: np.array([0.05, 0.03, 0.4]))  # kg m², kg m², kg
    damping: np.ndarray = field(default_factory=lambda: np.array([0.05, 0.03, 2.0]))
    kp: np.ndarray = field(default_factory=lambda: np.array([200.0, 120.0, 1600.0]))
    kd: np.ndarray = field(default_factory=lambda: np.array([6.0, 3.6, 48.0]))
    ki: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 4000.0]))  # PID on insertion only
    tau_max: np.ndarray = field(default_factory=lambda: TAU_MAX.copy())
    dt: float = DT


@dataclass
class ArmState:
    q: np.ndarray  # (R, 6)
    qdot: np.ndarray  # (R, 6)
    integral: np.ndarray  # (R, 3) integrated position error of the positioning joints


class RavenArm:
    """R Raven-II arms stepped together at 1 kHz: `step(state, target)` -> new state, torque."""

    def __init__(self, arm: str = "left", params: ArmParams | None = None) -> None:
        if arm not in ALPHA:
            raise ValueError("arm must be 'left' or 'right'")
        self.arm, self.p = arm, params or ArmParams()

    def rest(self, runs: int, q0=None) -> ArmState:
        q0 = np.array([45 * DEG, 90 * DEG, 0.4, 0.0, 0.0, 0.0]) if q0 is None else np.asarray(q0, float)
        q = np.broadcast_to(q0, (runs, 6)).copy()
        return ArmState(q, np.zeros((runs, 6)), np.zeros((runs, 3)))

    def torque(self, state: ArmState, target) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """PD (PID on insertion) torque on the positioning joints, clipped to the limits.
        Returns (tau (R, 3), new integral, braked (R,) bool). A run whose target or state is
        not finite is braked: tau = -Kd q' (finite state) or 0."""
        p = self.p
        target = np.asarray(target, dtype=float)
        qp, vp = state.q[:, :3], state.qdot[:, :3]
        ok_state = np.isfinite(state.q).all(axis=1) & np.isfinite(state.qdot).all(axis=1)
        ok = ok_state & np.isfinite(target).all(axis=-1) & np.isfinite(state.integral).all(axis=1)
        with np.errstate(invalid="ignore", over="ignore"):
            err = np.where(ok[:, None], target[..., :3] - qp, 0.0)
            integral = np.where(ok[:, None], state.integral + err * p.dt, 0.0)
            tau = p.kp * err - p.kd * vp + p.ki * integral
            brake = np.where(ok_state[:, None], -p.kd * vp, 0.0)
            tau = np.where(ok[:, None], tau, brake)
        tau = np.where(np.isfinite(tau), tau, 0.0)
        return tau.clip(-p.tau_max, p.tau_max), integral, ~ok

    def step(self, state: ArmState, target, tau_override=None) -> tuple[ArmState, np.ndarray, np.ndarray]:
        """One 1 ms tick. `tau_override` (R, 3), where finite, replaces the controller's
        torque (the motor stream a fault can corrupt, e.g. the paper's constant DAC command);
        it is clipped to the torque limits like any command."""
        p = self.p
        tau, integral, braked = self.torque(state, target)
        if tau_override is not None:
            over = np.asarray(tau_override, dtype=float)
            tau = np.where(np.isfinite(over), over, tau).clip(-p.tau_max, p.tau_max)
        qp, vp = state.q[:, :3], state.qdot[:, :3]
        finite = np.isfinite(qp).all(axis=1) & np.isfinite(vp).all(axis=1)
        vp = np.where(finite[:, None], vp, 0.0)
        qp = np.where(np.isfinite(qp), qp, 0.0)  # a non-finite joint held at 0, the finite ones kept
        acc = (tau - p.damping * vp) / p.inertia
        v_new = vp + acc * p.dt  # semi-implicit Euler
        q_new = qp + v_new * p.dt
        tool_target = np.asarray(target, dtype=float)[..., 3:]
        tool_ok = np.isfinite(tool_target).all(axis=-1)
        tool_q = np.where(tool_ok[:, None], tool_target, state.q[:, 3:])
        tool_q = np.where(np.isfinite(tool_q), tool_q, 0.0)
        with np.errstate(over="ignore", invalid="ignore"):
            tool_v = np.where(tool_ok[:, None], (tool_q - state.q[:, 3:]) / p.dt, 0.0)
        tool_v = np.where(np.isfinite(tool_v), tool_v, 0.0)
        q = np.concatenate([q_new, tool_q], axis=1)
        qdot = np.concatenate([v_new, tool_v], axis=1)
        return ArmState(q, qdot, integral), tau, braked
