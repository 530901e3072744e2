"""The RCM paper's target dynamics (22)-(23) for the 7-DOF LWR4+, integrated at 250 Hz.

q'' = -S [h; u] + Z^T Z J_t^T (F_th + F_r), with S = [A^dagger  Z^T] (21),
h = A' q' + 2 alpha x_c' + beta^2 x_c and u = D_f x_f' + d(Z^daggerT)/dt q' (23); so the
constraint coordinates obey x_c'' + 2 alpha x_c' + beta^2 x_c = 0 (25) and the free ones
x_f'' + D_f x_f' = Z J_t^T F (27). A' and d(Z^daggerT)/dt are backward differences, as in the paper.

`RcmAdmittance.step(wrench)` integrates one period with the paper's explicit Euler ("euler") or
semi-implicit Euler ("semi-implicit": the velocity first, then the position with the new
velocity), then applies the proved guard `rcm.guard_speed`: the sweep of any tool point in one
period is at most sum_j |dq_j| L_j (L_j: the link lengths from joint j to the tip, a bound on the
lever arm), so scaling the joint step by k = guard_speed(gap, sweep/dt)/(sweep/dt) keeps every
gap >= margin for the whole period. Anything non-finite, singular or already inside gives a hold
(q unchanged, q' = 0) with a reason; nothing here returns NaN.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field

import numpy as np

from certiloop.studies.rcm.arm import DH_D, guard_speed, link_frames
from certiloop.studies.rcm.cloud import CloudBarrier
from certiloop.studies.rcm.workspace import StepWorkspace

# ATI Mini40 ranges (force N, torque N m): a larger reading is clipped, a non-finite one refused.
FORCE_RANGE, TORQUE_RANGE = 240.0, 4.0
JOINT_LIMITS = np.radians([170, 120, 170, 120, 170, 120, 170])
SIGMA_FLOOR = 1e-3          # smallest singular value of J_t accepted
TRACKING_TOL = 5e-3         # rad: the paper's "faithful tracking" premise, checked when q is measured


@dataclass(frozen=True)
class Gains:
    """Table 1 of the paper; D_f elements 1 (axial), 2-4 (angular), 5 (redundancy)."""
    alpha: float = 25.0
    beta: float = 25.0
    w: float = 1.5
    d0: float = 0.0115
    k: float = 0.01
    d_const: tuple = (10.0, 4.0, 4.0, 4.0, 60.0)
    q_gain: tuple = (25.0, 20.0, 20.0, 20.0, 0.0)
    m_gain: tuple = (22.0, 19.0, 19.0, 19.0, 0.0)
    g_gain: tuple = (60.0, 30.0, 30.0, 30.0, 0.0)
    c_gain: tuple = (0.01, 0.2, 0.2, 0.2, 0.0)


TABLE1 = Gains()


def variable_damping(xf_dot: np.ndarray, f_rx: np.ndarray, g: Gains = TABLE1) -> np.ndarray:
    """diag(D_f) = D_c + Q exp(-M s) + G (1 - exp(-C z^2)) (43)-(45): s and z are |.| of the axial
    element and ||.|| of elements 2-4 of x_f' and of F_rx = Z_x F_r (the erratum's Z_x, not Z_x^T)."""
    s = np.array([abs(xf_dot[0]), *[np.linalg.norm(xf_dot[1:4])] * 3, 0.0])
    z = np.array([abs(f_rx[0]), *[np.linalg.norm(f_rx[1:4])] * 3, 0.0])
    d_const, q_gain, m_gain, g_gain, c_gain = _gain_arrays(g)
    return d_const + q_gain * np.exp(-m_gain * s) + g_gain * (1.0 - np.exp(-c_gain * z * z))


_GAIN_ARRAYS: dict = {}


def _gain_arrays(g: Gains) -> tuple:
    """D_c, Q, M, G, C as arrays, made once per gain table (Gains is frozen)."""
    arrays = _GAIN_ARRAYS.get(g)
    if arrays is None:
        arrays = _GAIN_ARRAYS[g] = tuple(np.asarray(x, dtype=float) for x in (g.d_const, g.q_gain, g.m_gain,
                                                                               g.g_gain, g.c_gain))
    return arrays


def hat(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


_MINORS = np.array([[j for j in range(7) if j != i] for i in range(7)])   # column i left out, row i
_COFACTOR_SIGNS = np.array([1, -1, 1, -1, 1, -1, 1])


def redundancy_row(J: np.ndarray) -> np.ndarray:
    """G (1x7) with G J^T = 0: signed 6x6 cofactors (continuous, unlike an SVD null vector), unit norm."""
    minors = J[:, _MINORS].transpose(1, 0, 2)          # minors[i] = J without column i
    g = np.linalg.det(minors) * _COFACTOR_SIGNS
    return g / np.linalg.norm(g)


def _cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of (m, 3) rows, with its arithmetic (a1 b2 - a2 b1, ...), without its axis handling."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


@dataclass
class Mapping:
    """Everything (15)-(21) defines at one configuration."""
    p_t: np.ndarray
    p_e: np.ndarray
    n: np.ndarray
    J: np.ndarray          # J_t, 6x7
    x_c: np.ndarray        # (1)
    A: np.ndarray          # 2x7 (7)
    Z_x: np.ndarray        # 4x6 (15)
    Z: np.ndarray          # 5x7 (16)
    A_dag: np.ndarray      # 7x2 (18)
    Z_dag_T: np.ndarray    # 5x7 (19)
    sigma_min: float


def mapping(q: np.ndarray, p_c: np.ndarray, tool_length: float) -> Mapping:
    """(15)-(21) at q. W = w I as in Table 1: a scalar W cancels in both pseudo-inverses."""
    frames = np.stack(link_frames(q))                     # one DH pass (rcm_arm.py's table) for pose and J
    T = frames[-1]
    n, a, o = T[:3, 2], T[:3, 0], T[:3, 1]
    p_e = T[:3, 3]
    p_t = p_e + tool_length * n
    axes, origins = frames[:7, :3, 2], frames[:7, :3, 3]
    J = np.vstack([_cross_rows(axes, p_t - origins).T, axes.T])   # as rcm.lwr4_jacobian, vectorised
    r = p_t - p_c
    Bt = np.vstack([a, o])
    x_c = Bt @ r
    A = np.hstack([Bt, Bt @ hat(r)]) @ J
    Z_x = np.zeros((4, 6))
    Z_x[0, :3] = n
    Z_x[1:, :3] = hat(r)
    Z_x[1:, 3:] = np.eye(3)
    Z = np.vstack([Z_x @ np.linalg.solve(J @ J.T, J), redundancy_row(J)])
    A_dag = A.T @ np.linalg.inv(A @ A.T)               # W = w I: the w cancels in (18)
    Z_dag_T = np.linalg.solve(Z @ Z.T, Z)              # (Z W Z^T)^-1 Z W with W = w I
    sigma_min = float(np.linalg.svd(J, compute_uv=False)[-1])
    return Mapping(p_t, p_e, n, J, x_c, A, Z_x, Z, A_dag, Z_dag_T, sigma_min)


@dataclass(frozen=True)
class StepResult:
    q: np.ndarray          # the next q_d (7, rad)
    qdot: np.ndarray       # the next q_d' (7, rad/s)
    x_c: np.ndarray        # RCM error at the start of the step (m)
    gap: float             # lower bound on the clearance at the start of the step (m)
    scale: float           # guard factor k in [0, 1]
    ok: bool
    reason: str


@dataclass
class RcmAdmittance:
    """The controller state (q_d, q_d') and its configuration; `step` advances one period."""
    q: np.ndarray
    p_c: np.ndarray
    barrier: CloudBarrier
    tool_length: float = 0.43
    mode: str = "tip"                  # "tip" or "tool" (the capsule)
    integrator: str = "euler"          # "euler" (the paper's) or "semi-implicit"
    guard: bool = True
    margin: float = 2e-4               # the guard keeps every gap >= margin
    dt: float = 0.004
    gains: Gains = TABLE1
    wrench: np.ndarray = field(default_factory=lambda: np.zeros(6))   # F_h at the flange, base frame
    qdot: np.ndarray = field(default_factory=lambda: np.zeros(7))
    penetrated: bool = False
    _prev: tuple | None = None

    def __post_init__(self):
        if self.mode not in ("tip", "tool"):
            raise ValueError(f"mode must be 'tip' or 'tool', not {self.mode!r}")
        if self.integrator not in ("euler", "semi-implicit"):
            raise ValueError(f"integrator must be 'euler' or 'semi-implicit', not {self.integrator!r}")
        self.q = np.asarray(self.q, dtype=float).reshape(7).copy()
        self.p_c = np.asarray(self.p_c, dtype=float).reshape(3)
        # lever-arm bound per joint: distance from joint j's origin to any tool point
        self.lever = np.array([DH_D[j:].sum() for j in range(7)]) + self.tool_length

    def _hold(self, reason: str, x_c=None, gap: float = 0.0) -> StepResult:
        self.qdot = np.zeros(7)
        self._prev = None
        xc = np.zeros(2) if x_c is None or not np.all(np.isfinite(x_c)) else x_c
        return StepResult(self.q.copy(), self.qdot.copy(), xc, gap if math.isfinite(gap) else 0.0,
                          0.0, False, reason)

    def step(self, wrench=None, q_measured=None) -> StepResult:
        """One period from the human wrench (default: `self.wrench`). With `q_measured`, a robot
        more than TRACKING_TOL from the last q_d (the proofs assume it tracks) gives a hold.

        The arithmetic runs in the controller's `StepWorkspace`: no arrays are allocated but the
        new state and the result, which the caller keeps (tests/studies/rcm/test_rcm_workspace.py
        holds the step written with fresh arrays, as the formulas read, and compares the bits)."""
        ws = self._workspace()
        F_h = ws.F_h
        w = self.wrench if wrench is None else wrench
        if type(w) is np.ndarray and w.shape == (6,) and w.dtype == np.float64:
            np.copyto(F_h, w)
        else:
            try:
                np.copyto(F_h, np.asarray(w, dtype=float).reshape(6))
            except (TypeError, ValueError):
                return self._hold("malformed human wrench (need 6 numbers)")
        if not np.isfinite(F_h, out=ws.finite6).all():
            return self._hold("non-finite human wrench")
        if q_measured is not None:
            q_msr = q_measured
            if not (type(q_msr) is np.ndarray and q_msr.shape == (7,) and q_msr.dtype == np.float64):
                try:
                    q_msr = np.asarray(q_measured, dtype=float).reshape(7)
                except (TypeError, ValueError):
                    return self._hold("malformed measured joints (need 7 numbers)")
            np.subtract(q_msr, self.q, out=ws.dq)
            if not np.abs(ws.dq, out=ws.dq).max() <= TRACKING_TOL:      # NaN fails this too
                return self._hold("tracking error: the robot is not following q_d")
        _clip_wrench_into(F_h)
        dt = self.dt
        sigma_min = ws.mapping(self.q, self.p_c, self.tool_length)
        if not sigma_min > SIGMA_FLOOR:
            return self._hold("Jacobian near singular", ws.x_c.copy())
        if self.mode == "tip":
            gap = self.barrier.tip_into(ws.p_t, ws.F_r_force, ws.scratch_for(self.barrier))
        else:
            F_r, gap = self.barrier.capsule(ws.p_t, ws.n, self.tool_length)
            np.copyto(ws.F_r, F_r)
        if gap <= 0.0:
            self.penetrated = True
            return self._hold("inside the forbidden region", ws.x_c.copy(), gap)
        qd = self.qdot
        qdd = ws.acceleration(qd, self._prev is not None, dt)
        q_next, qd_next = ws.q_next, ws.qd_next
        np.multiply(dt, qdd, out=qd_next)
        np.add(qd, qd_next, out=qd_next)
        np.multiply(dt, qd if self.integrator == "euler" else qd_next, out=q_next)
        np.add(self.q, q_next, out=q_next)
        scale = 1.0
        if self.guard:
            np.subtract(q_next, self.q, out=ws.dq)
            scale = self._guard_scale(ws.dq, gap)
            if scale < 1.0:
                np.subtract(q_next, self.q, out=ws.dq)
                np.multiply(scale, ws.dq, out=ws.dq)
                np.add(self.q, ws.dq, out=q_next)
                np.multiply(scale, qd_next, out=qd_next)
        if not (np.isfinite(q_next, out=ws.finite7).all() and np.isfinite(qd_next, out=ws.finite7).all()):
            return self._hold("non-finite step", ws.x_c.copy(), gap)
        np.abs(q_next, out=ws.abs7)
        if np.greater(ws.abs7, JOINT_LIMITS, out=ws.finite7).any():
            return self._hold("joint limit", ws.x_c.copy(), gap)
        np.copyto(ws.prev_A, ws.A)
        np.copyto(ws.prev_Z_dag_T, ws.Z_dag_T)
        self._prev = ws.prev
        self.q, self.qdot = q_next.copy(), qd_next.copy()
        reason = "" if scale == 1.0 else "limited by the guard"
        return StepResult(q_next.copy(), qd_next.copy(), ws.x_c.copy(), gap, scale, True, reason)

    def __getstate__(self) -> dict:
        """Copies and pickles carry the state, not the buffers: the previous tick's A and Z_dag_T
        as arrays of their own (the buffers are this controller's, rewritten every tick)."""
        state = dict(self.__dict__)
        state.pop("_ws", None)
        if self._prev is not None:
            state["_prev"] = (self._prev[0].copy(), self._prev[1].copy())
        return state

    def _workspace(self) -> StepWorkspace:
        """This controller's buffers (a copied controller gets its own, with the previous tick's
        A and Z_dag_T), with the current gain table."""
        ws = self.__dict__.get("_ws")
        if ws is None or ws.owner() is not self:
            ws = StepWorkspace(self.gains)
            ws.owner = weakref.ref(self)
            self.__dict__["_ws"] = ws
        if self._prev is not None and self._prev is not ws.prev:   # a copied controller's
            np.copyto(ws.prev_A, self._prev[0])
            np.copyto(ws.prev_Z_dag_T, self._prev[1])
            self._prev = ws.prev
        if ws.gains is not self.gains:
            ws.set_gains(self.gains)
        return ws

    def _guard_scale(self, dq: np.ndarray, gap: float) -> float:
        """k in [0, 1] with k * sweep <= gap - margin, from the proved guard_speed."""
        ws = self.__dict__.get("_ws")
        # any tool point moves at most this far
        sweep = float((np.abs(dq) if ws is None else np.abs(dq, out=ws.abs7)) @ self.lever)
        if sweep == 0.0 or math.isinf(gap):
            return 1.0
        if not math.isfinite(sweep):
            return 0.0
        speed = sweep / self.dt
        allowed = guard_speed(gap, speed, self.margin, self.dt)
        k = min(1.0, max(0.0, allowed / speed))
        while k > 0.0 and k * speed * self.dt > gap - self.margin:   # rounding: never overshoot
            k = math.nextafter(k, 0.0)
        return k


def _clip_wrench_into(F: np.ndarray) -> None:
    """F clipped to the sensor's ranges, in place (hypot: no overflow for huge readings)."""
    nf, nt = math.hypot(F[0], F[1], F[2]), math.hypot(F[3], F[4], F[5])
    if nf > FORCE_RANGE:
        np.multiply(F[:3], FORCE_RANGE / nf, out=F[:3])
    if nt > TORQUE_RANGE:
        np.multiply(F[3:], TORQUE_RANGE / nt, out=F[3:])
