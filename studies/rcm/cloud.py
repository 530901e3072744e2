"""Barrier forces of the RCM paper's controller from an N-point cloud, through a KD-tree.

A cloud point p_i is a forbidden ball of radius d_c (8); within d_0 of that ball it pushes with
f_i = k_v ((d_0 + d_c) - rho) (x - p_i)/rho (11)-(14), the negative gradient of V_i (9)-(10).
`CloudBarrier.tip(p_t)` sums the forces on the tip; `CloudBarrier.capsule(p_t, n_t, L)` applies
the whole-tool extension (34)-(37): each point acts on its nearest point of the tool segment,
d_c grows by the capsule radius r, and the force is transported to the tip as [f; (p* - p_t) x f].

Both also return `gap`, a LOWER BOUND on the clearance min_i rho_i - d_c (- r): exact when some
point lies in the influence band, else d_0 (every point is farther than the band). The guard only
needs a lower bound, so using it is sound. A gap <= 0 means the tool is inside a ball: the barrier
is undefined there and the force is returned as zero with that gap, for the caller to refuse.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

VIEWS_KEPT = 256  # sizes of the in-reach set whose buffer views are kept (about 1 KiB each)


class TipScratch:
    """Buffers for `CloudBarrier.tip_into` over up to `capacity` points in reach, owned by one
    controller (a barrier shared by several stays free of state)."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        n = capacity
        self.buffers = (np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                        np.empty(n, dtype=bool), np.empty((n, 3)))
        self.kept: dict[int, tuple] = {}

    def views(self, m: int) -> tuple:
        """The first m rows of diff (N, 3), rho, e, y, kv (N,), band (N,) bool, f (N, 3), then kv and
        band as columns; the views of the first VIEWS_KEPT sizes are kept (a tick then makes none)."""
        found = self.kept.get(m)
        if found is None:
            found = tuple(b[:m] for b in self.buffers)
            found += (found[4][:, None], found[5][:, None])
            if len(self.kept) < VIEWS_KEPT:
                self.kept[m] = found
        return found


class CloudBarrier:
    def __init__(self, points, d_c: float, d0: float = 0.0115, k: float = 0.01, radius: float = 0.0):
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        if not np.all(np.isfinite(pts)):
            raise ValueError("cloud points must be finite")
        if not (d_c >= 0 and d0 > 0 and k > 0 and radius >= 0):
            raise ValueError("need d_c >= 0, d0 > 0, k > 0, radius >= 0")
        self.points, self.d_c, self.d0 = pts, float(d_c), float(d0)
        self.k, self.radius = float(k), float(radius)
        self.tree = cKDTree(pts) if len(pts) else None

    def _forces(self, x: np.ndarray, c: np.ndarray, dc: float) -> tuple[np.ndarray, float]:
        """Per-point forces (m, 3) at the points x (m, 3) from the cloud points c, and the smallest gap."""
        diff = x - c
        rho = np.sqrt(np.einsum("ij,ij->i", diff, diff))
        e = rho - dc                                   # gap to each ball
        gap = float(e.min())
        if gap <= 0.0:
            return np.zeros_like(diff), gap
        band = e < self.d0
        e, diff, rho = e[band], diff[band], rho[band]
        y = e * (2 * self.d0 - e) / self.d0**2         # 1 - psi, in (0, 1] on the band
        kv = 2 * self.k * np.log(1.0 / y) / (self.d0**2 * y)
        f = np.zeros((len(band), 3))
        f[band] = (kv * (self.d0 - e) / rho)[:, None] * diff
        return f, gap

    def tip(self, p_t) -> tuple[np.ndarray, float]:
        """(f_r (3,), gap) for the tool tip alone (d_c, no capsule)."""
        p = np.asarray(p_t, dtype=float).reshape(3)
        if self.tree is None:
            return np.zeros(3), np.inf
        idx = self.tree.query_ball_point(p, self.d_c + self.d0)
        if not idx:
            return np.zeros(3), self.d0
        f, gap = self._forces(p[None, :], self.points[idx], self.d_c)
        return f.sum(axis=0), min(gap, self.d0)

    def tip_into(self, p: np.ndarray, out: np.ndarray, scratch: TipScratch) -> float:
        """`tip` for a step's hot path: the force written into `out` (3,), the gap returned, the
        same operations in the caller's buffers (`scratch`, for as many points as the cloud)."""
        if self.tree is None:
            out.fill(0.0)
            return np.inf
        idx = self.tree.query_ball_point(p, self.d_c + self.d0)
        m = len(idx)
        if not m:
            out.fill(0.0)
            return self.d0
        diff, rho, e, y, kv, band, f, kv_col, band_col = scratch.views(m)
        np.take(self.points, idx, axis=0, out=diff, mode="clip")
        np.subtract(p, diff, out=diff)                            # x - c
        np.einsum("ij,ij->i", diff, diff, out=rho)
        np.sqrt(rho, out=rho)
        np.subtract(rho, self.d_c, out=e)
        gap = float(e.min())
        if gap <= 0.0:
            out.fill(0.0)
            return gap
        np.less(e, self.d0, out=band)
        # every point in reach has 0 < e <= d0 (+ rounding): the band's formulas are finite on
        # all of them, and only the band's rows are kept, as in `_forces`
        np.subtract(2 * self.d0, e, out=y)
        np.multiply(e, y, out=y)
        np.divide(y, self.d0**2, out=y)                           # 1 - psi
        np.divide(1.0, y, out=kv)
        np.log(kv, out=kv)
        np.multiply(2 * self.k, kv, out=kv)
        np.multiply(self.d0**2, y, out=y)
        np.divide(kv, y, out=kv)
        np.subtract(self.d0, e, out=y)
        np.multiply(kv, y, out=kv)
        np.divide(kv, rho, out=kv)
        f.fill(0.0)
        np.multiply(kv_col, diff, out=f, where=band_col)
        np.sum(f, axis=0, out=out)
        return min(gap, self.d0)

    def capsule(self, p_t, n_t, length: float) -> tuple[np.ndarray, float]:
        """(F_r (6,) at the tip, gap) for the segment p_t - n_t L sigma, sigma in [0, 1], of radius r."""
        p = np.asarray(p_t, dtype=float).reshape(3)
        n = np.asarray(n_t, dtype=float).reshape(3)
        if self.tree is None:
            return np.zeros(6), np.inf
        dc = self.d_c + self.radius
        reach = dc + self.d0
        # candidates: every point within `reach` of the segment is within reach + s/2 of a sample
        m = max(2, int(np.ceil(length / reach)) + 1)
        s = length / (m - 1)
        samples = p - np.outer(np.linspace(0.0, length, m), n)
        hits = self.tree.query_ball_point(samples, reach + 0.5 * s, return_sorted=False)
        idx = np.unique(np.fromiter((i for h in hits for i in h), dtype=np.intp))
        if len(idx) == 0:
            return np.zeros(6), self.d0
        c = self.points[idx]
        sigma = np.clip((p - c) @ n / length, 0.0, 1.0)      # (35): nearest point of the segment
        near = p - np.outer(sigma * length, n)
        f, gap = self._forces(near, c, dc)
        torque = np.cross(near - p, f).sum(axis=0)            # (37): transport to the tip
        return np.concatenate([f.sum(axis=0), torque]), min(gap, self.d0)
