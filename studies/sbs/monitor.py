"""Runtime monitor for the virtual-fixture kernel (the ModelPlex idea, for ctrl2).

What it checks, every control period, in floating point with the tolerance below:

1. **Inputs** are what the model assumes: position, force and force rate finite 3-vectors;
   every normal finite and of unit length (|n|² = 1 within 1e-9); G > 0, ε > 0, D > 0,
   all finite; the tool not past any boundary (d0 = (p - r)·n >= -tol).
2. **Controller**: the commanded gain satisfies what the proof's inner-loop invariant
   requires of it: 0 <= k <= 1 and, for every boundary, the distance predicted by the
   model's plant over the whole period stays non-negative,
       ∀t∈[0,ε]  d0 + G k (fn t + fnp t²/2) >= -tol        (Table 2's safe-for-step)
   decided exactly for the quadratic: at t = 0, t = ε and at the vertex when it lies in
   between.
3. **Plant**: the previous period's motion was one the model allows: the measured
   position equals the model's prediction p + G k (f dt + fp dt²/2) for the elapsed dt
   (ε unless given) within `position_tolerance`.

Guarantee: whenever the monitor passes, the command is one the verified model could have
issued in the measured state, so (the plant behaving as modelled) every boundary distance
stays >= -tol over the next period. Whenever it fails, the kernel commands k = 0 — the
tool stops, which keeps every distance as it is — and reports the first failed check.
tol = 1e-9 · (1 + |d0| + G|fn|ε + G|fnp|ε²) absorbs floating-point rounding of the check
itself; it is not a licence to cross.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RELATIVE_TOLERANCE = 1e-9
UNIT_TOLERANCE = 1e-9


@dataclass
class Verdict:
    ok: bool
    reason: str = ""


OK = Verdict(True)


def check_inputs(p, f, fp, normals, points, gain, buffer, period) -> Verdict:
    for name, v in (("position", p), ("force", f), ("force rate", fp)):
        if v.shape != (3,):
            return Verdict(False, f"{name} must be a 3-vector, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            return Verdict(False, f"{name} is not finite: {v.tolist()}")
    for name, v in (("G", gain), ("D", buffer), ("ε", period)):
        if not (np.isfinite(v) and v > 0):
            return Verdict(False, f"{name} must be finite and positive, got {v}")
    if len(normals):
        if not (np.all(np.isfinite(normals)) and np.all(np.isfinite(points))):
            return Verdict(False, "a boundary plane has a non-finite point or normal")
        length2 = np.einsum("ij,ij->i", normals, normals)
        bad = np.flatnonzero(np.abs(length2 - 1.0) > UNIT_TOLERANCE)
        if bad.size:
            b = int(bad[0])
            return Verdict(False, f"boundary {b} has a normal of length {np.sqrt(length2[b]):.6g}, not 1")
        d0 = np.einsum("ij,ij->i", p - points, normals)
        past = np.flatnonzero(d0 < -RELATIVE_TOLERANCE * (1 + np.abs(d0)))
        if past.size:
            b = int(past[0])
            return Verdict(False, f"the tool is already past boundary {b} (distance {d0[b]:.6g})")
    return OK


def check_command(k: float, d0, fn, fnp, gain: float, period: float) -> Verdict:
    """k is what the model's controller may command: 0 <= k <= 1 and every boundary safe
    for the whole period."""
    if not (np.isfinite(k) and 0.0 <= k <= 1.0):
        return Verdict(False, f"gain k = {k} is outside [0, 1]")
    if not len(d0):
        return OK
    e = period
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tol = RELATIVE_TOLERANCE * (1 + np.abs(d0) + gain * np.abs(fn) * e + gain * np.abs(fnp) * e * e)
        at_end = d0 + gain * k * (fn * e + fnp * e * e / 2)
        vertex_t = np.where(fnp > 0, -fn / fnp, -1.0)
        inside = (vertex_t > 0) & (vertex_t < e)
        at_vertex = np.where(inside, d0 + gain * k * (fn * vertex_t + fnp * vertex_t**2 / 2), np.inf)
        worst = np.minimum(np.minimum(d0, at_end), at_vertex)
        bad = np.flatnonzero(~(worst >= -tol))  # NaN (an overflow met 0 or inf) is not shown safe
    if bad.size:
        b = int(bad[0])
        return Verdict(False, f"k = {k:.6g} lets the tool reach distance {worst[b]:.6g} from boundary {b} "
                       "within the period")
    return OK


def check_motion(previous, p, gain: float, dt: float, position_tolerance: float) -> Verdict:
    """The measured position is where the model's plant takes the previous command."""
    if previous is None:
        return OK
    p0, f0, fp0, k0 = previous
    predicted = p0 + gain * k0 * (f0 * dt + fp0 * dt * dt / 2)
    error = float(np.max(np.abs(p - predicted)))
    if error > position_tolerance:
        return Verdict(False, f"the tool moved {error:.6g} away from the model's prediction "
                       f"(tolerance {position_tolerance:g})")
    return OK
