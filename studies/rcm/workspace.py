"""The RCM step's arithmetic in buffers made once per controller, so that a tick allocates no
arrays: every product, sum and factorisation writes into its buffer (`out=`), and views of the
buffers are taken once here. The operations are those of `dynamics.mapping` and of the step's
formulas, in the same order and on arrays of the same layout, so the results are the same bits
(tests/studies/rcm/test_rcm_workspace.py compares them with the formulas as first written).

numpy's `linalg` functions allocate their results; the generalized ufuncs under them
(`numpy.linalg._umath_linalg`: solve, inv, det, svd) take `out=` and compute the same, under
the same error state (a singular matrix raises LinAlgError, as `np.linalg.solve` does).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.linalg import LinAlgError

from certiloop.studies.rcm.arm import DH_ALPHA, DH_D
from certiloop.studies.rcm.cloud import TipScratch


class _LinalgCopying:
    """The same operations through the public np.linalg, copied into `out` (allocates)."""

    @staticmethod
    def solve(a, b, signature, out):
        np.copyto(out, np.linalg.solve(a, b))

    @staticmethod
    def inv(a, signature, out):
        np.copyto(out, np.linalg.inv(a))

    @staticmethod
    def det(a, signature, out):
        np.copyto(out, np.linalg.det(a))

    @staticmethod
    def svd(a, signature, out):
        np.copyto(out, np.linalg.svd(a, compute_uv=False))


try:  # a private numpy module: should a release move it, the step still runs, allocating
    from numpy.linalg import _umath_linalg as gufuncs
except ImportError:  # pragma: no cover - numpy of today has it
    gufuncs = _LinalgCopying()


_MINORS = np.array([[j for j in range(7) if j != i] for i in range(7)])   # column i left out, row i
_COFACTOR_SIGNS = np.array([1, -1, 1, -1, 1, -1, 1])


def _singular(err, flag):
    raise LinAlgError("Singular matrix")


def _svd_failed(err, flag):
    raise LinAlgError("SVD did not converge")


class StepWorkspace:
    """Buffers and their views for one controller's mapping (15)-(21) and target dynamics."""

    def __init__(self, gains) -> None:
        e = np.empty
        # the DH chain: frames[0] = I, frames[i + 1] = frames[i] @ dh[i]
        self.frames = np.zeros((8, 4, 4))
        self.frames[0] = np.eye(4)
        self.frame = [self.frames[i] for i in range(8)]
        self.dh = [np.zeros((4, 4)) for _ in range(7)]
        self.dh_fixed = [(math.cos(al), math.sin(al), float(d)) for d, al in zip(DH_D, DH_ALPHA)]
        for m, (ca, sa, d) in zip(self.dh, self.dh_fixed):
            m[2, 1], m[2, 2], m[2, 3], m[3, 3] = sa, ca, d, 1.0
        T = self.frames[7]
        self.n, self.a, self.o, self.p_e = T[:3, 2], T[:3, 0], T[:3, 1], T[:3, 3]
        self.axes, self.origins = self.frames[:7, :3, 2], self.frames[:7, :3, 3]
        self.p_t, self.r = e(3), e(3)
        # J_t (6x7): the cross products of the axes with (p_t - origins), then the axes
        self.lever_arms = e((7, 3))
        self.b = [self.lever_arms[:, k] for k in range(3)]
        self.ax = [self.axes[:, k] for k in range(3)]
        self.J = e((6, 7), order="F")             # the layout np.vstack gave it: the same BLAS calls
        self.J_rows = [self.J[k] for k in range(3)]
        self.J_angular = self.J[3:]
        self.axes_T = self.axes.T
        self.J_T = self.J.T
        self.t1, self.t2 = e(7), e(7)
        # A (2x7) from B_c^T = [a; o] and [B_c^T  B_c^T hat(r)]
        self.Bt, self.hat_r, self.Bt_hat = e((2, 3)), np.zeros((3, 3)), e((2, 3))
        self.Ax = e((2, 6))
        self.Ax_left, self.Ax_right = self.Ax[:, :3], self.Ax[:, 3:]
        self.x_c, self.A = e(2), e((2, 7))
        self.A_T = self.A.T
        self.AAt, self.AAt_inv, self.A_dag = e((2, 2)), e((2, 2)), e((7, 2))
        # Z (5x7): Z_x (J J^T)^-1 J over the cofactor row
        self.Z_x = np.zeros((4, 6))
        self.Z_x[1:, 3:] = np.eye(3)
        self.Z_x_n, self.Z_x_hat = self.Z_x[0, :3], self.Z_x[1:, :3]
        self.JJt, self.JJt_J = e((6, 6)), e((6, 7))
        self.Z = e((5, 7))
        self.Z_top, self.Z_row = self.Z[:4], self.Z[4]
        self.Z_T = self.Z.T
        self.minors_raw = e((6, 7, 6))
        self.minors = self.minors_raw.transpose(1, 0, 2)        # minors[i] = J without column i
        self.cof = e(7)
        self.ZZt, self.Z_dag_T = e((5, 5)), e((5, 7))
        self.sv = e(6)
        # the previous tick's A and Z_dag_T (backward differences) and their rates
        self.prev_A, self.prev_Z_dag_T = e((2, 7)), e((5, 7))
        self.prev = (self.prev_A, self.prev_Z_dag_T)
        self.A_dot, self.Zd_dot = e((2, 7)), e((5, 7))
        # the target dynamics
        self.F_h, self.F_r, self.F_th, self.F_sum, self.JtF = e(6), np.zeros(6), e(6), e(6), e(7)
        self.F_r_force = self.F_r[:3]
        self.f_h, self.t_h = self.F_h[:3], self.F_h[3:]
        self.F_th_f, self.F_th_t = self.F_th[:3], self.F_th[3:]
        self.arm, self.hat_arm, self.arm_f = e(3), np.zeros((3, 3)), e(3)
        self.xc_dot, self.xf_dot, self.frx = e(2), e(5), e(4)
        self.xf_rot, self.frx_rot = self.xf_dot[1:4], self.frx[1:4]
        self.s, self.z = np.zeros(5), np.zeros(5)
        self.D_f, self.damp_t = e(5), e(5)
        self.h, self.h2, self.u, self.u2 = e(2), e(2), e(5), e(5)
        self.force, self.qdd, self.qdd2 = e(5), e(7), e(7)
        self.q_next, self.qd_next, self.dq, self.abs7 = e(7), e(7), e(7), e(7)
        self.finite6, self.finite7 = np.empty(6, dtype=bool), np.empty(7, dtype=bool)
        self.tip_scratch: TipScratch | None = None
        self.set_gains(gains)

    def scratch_for(self, barrier) -> TipScratch:
        """Buffers for the barrier's points in reach (made again for a larger cloud)."""
        scratch = self.tip_scratch
        if scratch is None or scratch.capacity < len(barrier.points):
            scratch = self.tip_scratch = TipScratch(len(barrier.points))
        return scratch

    def set_gains(self, g) -> None:
        self.gains = g
        self.d_const, self.q_gain = np.asarray(g.d_const, dtype=float), np.asarray(g.q_gain, dtype=float)
        self.neg_m_gain = -np.asarray(g.m_gain, dtype=float)
        self.g_gain, self.neg_c_gain = np.asarray(g.g_gain, dtype=float), -np.asarray(g.c_gain, dtype=float)

    # ------------------------------------------------------------------ the mapping (15)-(21)

    def mapping(self, q: np.ndarray, p_c: np.ndarray, tool_length: float) -> float:
        """Fill p_t, p_e, n, J, x_c, A, Z_x, Z, A_dag, Z_dag_T at q; returns sigma_min(J_t)."""
        frame, dh = self.frame, self.dh
        for i in range(7):
            th = float(q[i])
            ca, sa, _ = self.dh_fixed[i]
            ct, st = math.cos(th), math.sin(th)
            m = dh[i]
            m[0, 0], m[0, 1], m[0, 2] = ct, -st * ca, st * sa
            m[1, 0], m[1, 1], m[1, 2] = st, ct * ca, -ct * sa
            np.matmul(frame[i], m, out=frame[i + 1])
        np.multiply(tool_length, self.n, out=self.p_t)
        np.add(self.p_e, self.p_t, out=self.p_t)
        # J_t: rows 0-2 = axes x (p_t - origins) with np.cross's arithmetic, rows 3-5 = axes
        np.subtract(self.p_t, self.origins, out=self.lever_arms)
        (a0, a1, a2), (b0, b1, b2), t1, t2 = self.ax, self.b, self.t1, self.t2
        for row, (x, y, u, v) in zip(self.J_rows, ((a1, b2, a2, b1), (a2, b0, a0, b2), (a0, b1, a1, b0))):
            np.multiply(x, y, out=t1)
            np.multiply(u, v, out=t2)
            np.subtract(t1, t2, out=row)
        np.copyto(self.J_angular, self.axes_T)
        np.subtract(self.p_t, p_c, out=self.r)
        self.Bt[0], self.Bt[1] = self.a, self.o
        np.matmul(self.Bt, self.r, out=self.x_c)
        _hat_into(self.hat_r, self.r)
        np.matmul(self.Bt, self.hat_r, out=self.Bt_hat)
        np.copyto(self.Ax_left, self.Bt)
        np.copyto(self.Ax_right, self.Bt_hat)
        np.matmul(self.Ax, self.J, out=self.A)
        np.copyto(self.Z_x_n, self.n)
        np.copyto(self.Z_x_hat, self.hat_r)
        np.matmul(self.J, self.J_T, out=self.JJt)
        np.matmul(self.A, self.A_T, out=self.AAt)
        with np.errstate(call=_singular, invalid="call", over="ignore", divide="ignore", under="ignore"):
            gufuncs.solve(self.JJt, self.J, signature="dd->d", out=self.JJt_J)
            gufuncs.inv(self.AAt, signature="d->d", out=self.AAt_inv)
        np.matmul(self.Z_x, self.JJt_J, out=self.Z_top)
        # the cofactor row G (G J^T = 0), unit norm: dynamics.redundancy_row
        np.take(self.J, _MINORS, axis=1, out=self.minors_raw, mode="clip")   # "raise" buffers out
        gufuncs.det(self.minors, signature="d->d", out=self.cof)
        np.multiply(self.cof, _COFACTOR_SIGNS, out=self.cof)
        np.divide(self.cof, math.sqrt(self.cof.dot(self.cof)), out=self.Z_row)
        np.matmul(self.A_T, self.AAt_inv, out=self.A_dag)
        np.matmul(self.Z, self.Z_T, out=self.ZZt)
        with np.errstate(call=_singular, invalid="call", over="ignore", divide="ignore", under="ignore"):
            gufuncs.solve(self.ZZt, self.Z, signature="dd->d", out=self.Z_dag_T)
        with np.errstate(call=_svd_failed, invalid="call", over="ignore", divide="ignore", under="ignore"):
            gufuncs.svd(self.J, signature="d->d", out=self.sv)
        return float(self.sv[5])

    # ------------------------------------------------------------------ the target dynamics (22)-(23)

    def acceleration(self, qd: np.ndarray, has_prev: bool, dt: float) -> np.ndarray:
        """q'' of (22)-(23) from F_h and F_r (filled by the caller) at the mapped configuration."""
        g = self.gains
        if has_prev:
            np.subtract(self.A, self.prev_A, out=self.A_dot)
            np.divide(self.A_dot, dt, out=self.A_dot)
            np.subtract(self.Z_dag_T, self.prev_Z_dag_T, out=self.Zd_dot)
            np.divide(self.Zd_dot, dt, out=self.Zd_dot)
        else:
            self.A_dot.fill(0.0)
            self.Zd_dot.fill(0.0)
        np.matmul(self.A, qd, out=self.xc_dot)
        np.matmul(self.Z_dag_T, qd, out=self.xf_dot)
        # F_th = T_te F_h: [f; t + hat(p_e - p_t) f]
        np.copyto(self.F_th_f, self.f_h)
        np.subtract(self.p_e, self.p_t, out=self.arm)
        _hat_into(self.hat_arm, self.arm)
        np.matmul(self.hat_arm, self.f_h, out=self.arm_f)
        np.add(self.t_h, self.arm_f, out=self.F_th_t)
        # D_f (43)-(45): dynamics.variable_damping
        np.matmul(self.Z_x, self.F_r, out=self.frx)
        s, z, xf, frx = self.s, self.z, self.xf_dot, self.frx
        s[0] = abs(xf[0])
        s[1] = s[2] = s[3] = math.sqrt(self.xf_rot.dot(self.xf_rot))
        z[0] = abs(frx[0])
        z[1] = z[2] = z[3] = math.sqrt(self.frx_rot.dot(self.frx_rot))
        D_f, t = self.D_f, self.damp_t
        np.multiply(self.neg_m_gain, s, out=t)
        np.exp(t, out=t)
        np.multiply(self.q_gain, t, out=t)
        np.add(self.d_const, t, out=D_f)
        np.multiply(self.neg_c_gain, z, out=t)
        np.multiply(t, z, out=t)
        np.exp(t, out=t)
        np.subtract(1.0, t, out=t)
        np.multiply(self.g_gain, t, out=t)
        np.add(D_f, t, out=D_f)
        # h = A' q' + 2 alpha x_c' + beta^2 x_c;  u = D_f x_f' + d(Z^daggerT)/dt q'
        h, h2 = self.h, self.h2
        np.matmul(self.A_dot, qd, out=h)
        np.multiply(2 * g.alpha, self.xc_dot, out=h2)
        np.add(h, h2, out=h)
        np.multiply(g.beta**2, self.x_c, out=h2)
        np.add(h, h2, out=h)
        u, u2 = self.u, self.u2
        np.multiply(D_f, xf, out=u)
        np.matmul(self.Zd_dot, qd, out=u2)
        np.add(u, u2, out=u)
        # force = Z (J^T (F_th + F_r));  q'' = -(A^dagger h + Z^T u) + Z^T force
        np.add(self.F_th, self.F_r, out=self.F_sum)
        np.matmul(self.J_T, self.F_sum, out=self.JtF)
        np.matmul(self.Z, self.JtF, out=self.force)
        qdd, qdd2 = self.qdd, self.qdd2
        np.matmul(self.A_dag, h, out=qdd)
        np.matmul(self.Z_T, u, out=qdd2)
        np.add(qdd, qdd2, out=qdd)
        np.negative(qdd, out=qdd)
        np.matmul(self.Z_T, self.force, out=qdd2)
        np.add(qdd, qdd2, out=qdd)
        return qdd


def _hat_into(out: np.ndarray, r: np.ndarray) -> None:
    """out = hat(r) (its zero diagonal is never written)."""
    r0, r1, r2 = float(r[0]), float(r[1]), float(r[2])
    out[0, 1], out[0, 2] = -r2, r1
    out[1, 0], out[1, 2] = r2, -r0
    out[2, 0], out[2, 1] = -r1, r0
