"""Deviation monitor of the Raven-II paper (eqs 3-6): model vs robot, haptic cue, stop (numpy only).

The paper runs a dynamical model of the arm beside the robot; both get the same command.
With p from forward kinematics (eq 4) and v from the tip Jacobian (eq 3) of each:

* **deviation** e = p_robot - p_model, *accumulated*: the model is never re-anchored to
  the robot, so a drift of any speed adds up (unlike a per-step residual, which compares
  only the last period's motion and never sees a drift below its threshold per period:
  `residual` below, and the refuted theorem `raven.residual_drift`);
* **haptic force** (eq 5, with the reading of its garbled second branch the text supports:
  no force at or below tol, a saturation): F = min(Kp ||dp|| + Kd ||dv||, Fsat) when
  ||dp|| > tol, else exactly 0, with dp = p_model - p_robot, dv = v_model - v_robot;
* **direction** (eq 6) d = dp / ||dp|| when F > 0, else 0 (eq 6 alone divides by zero);
* **stop**: the deviation exceeds tol (3 mm, the paper's threshold) — the guard of the
  proved `raven.deviation_stop_3d`, alarm iff e·e > tol² — or any input is not finite, or
  the run was already stopped (the stop latches: pedal-up, brakes). Stopping is the safe
  action: with it and a fixture keeping the model at m >= tol + U eps from every boundary,
  the robot never crosses (`raven.deviation_stop`, `raven.deviation_stop_3d`); the paper's
  haptic cue alone does not (`raven.deviation_haptic_only`).

Everything is vectorised over a batch of runs: positions and velocities are (..., 3)
arrays. Nothing returns NaN: a non-finite input gives F = 0, d = 0, stop = True.

The comparison is made conservative by a relative guard band of 1e-9: the kernel stops
when e·e > tol² (1 - 1e-9), so whenever the exact guard holds the kernel stops too, and it
may stop where the exact guard is false only within rounding of tol² (tested against an
exact evaluation of the theorem's guard).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

TOL = 0.003  # m: the paper's 3 mm threshold, from its fault-free runs (Fig 4)
GUARD_BAND = 1e-9  # relative: stop slightly early rather than late under rounding
TIE_BAND = 1e-12  # relative: a force decision with ||dp|| this close to tol is re-decided exactly


def _vec(x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape[-1:] != (3,):
        raise ValueError(f"expected (..., 3) positions or velocities, got shape {a.shape}")
    return a


def _finite(*arrays: np.ndarray) -> np.ndarray:
    """Per run: every coordinate of every array is finite."""
    ok = None
    for a in arrays:
        f = np.isfinite(a).all(axis=-1)
        ok = f if ok is None else ok & f
    return ok


def deviation(p_model, p_robot) -> tuple[np.ndarray, np.ndarray]:
    """e = p_robot - p_model and e·e per run (non-finite inputs give e = 0, e·e = inf)."""
    pm, pr = _vec(p_model), _vec(p_robot)
    ok = _finite(pm, pr)
    with np.errstate(invalid="ignore", over="ignore"):
        e = np.where(ok[..., None], pr - pm, 0.0)
        ee = np.einsum("...i,...i->...", e, e)
    ee = np.where(ok & np.isfinite(ee), ee, np.inf)
    return e, ee


def exceeds(ee, tol: float = TOL) -> np.ndarray:
    """The proved guard e·e > tol², made conservative by the guard band (see above)."""
    return np.asarray(ee) > tol * tol * (1.0 - GUARD_BAND)


def stop_decision(p_model, p_robot, tol: float = TOL, stopped=False) -> np.ndarray:
    """Stop (True) when already stopped, when an input is not finite, or when the deviation
    exceeds tol: the alarm guard of `raven.deviation_stop_3d`."""
    _, ee = deviation(p_model, p_robot)
    return np.asarray(stopped, dtype=bool) | exceeds(ee, tol)


def haptic_force(p_model, v_model, p_robot, v_robot, tol: float = TOL, kp: float = 1000.0,
                 kd: float = 10.0, saturation: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Eqs 5-6: the force magnitude F (...,) and unit direction d (..., 3) towards the model.

    F = min(kp ||dp|| + kd ||dv||, saturation) if ||dp|| > tol else 0, d = dp / ||dp|| if
    F > 0 else 0. A non-finite input gives F = 0 and d = 0 (the monitor stops instead)."""
    if not (np.isfinite(tol) and tol > 0 and np.isfinite(saturation) and saturation > 0
            and np.isfinite(kp) and kp >= 0 and np.isfinite(kd) and kd >= 0):
        raise ValueError("need tol > 0, saturation > 0, kp >= 0, kd >= 0, all finite")
    pm, vm, pr, vr = _vec(p_model), _vec(v_model), _vec(p_robot), _vec(v_robot)
    ok = _finite(pm, vm, pr, vr)
    with np.errstate(invalid="ignore", over="ignore"):
        dp = np.where(ok[..., None], pm - pr, 0.0)
        dv = np.where(ok[..., None], vm - vr, 0.0)
        ndp = np.sqrt(np.einsum("...i,...i->...", dp, dp))
        ndv = np.sqrt(np.einsum("...i,...i->...", dv, dv))
        raw = kp * ndp + kd * ndv
        # above tol the real F is > 0 when kp > 0 (or kd > 0 and the velocities differ); a
        # product that underflowed to 0 (kp = 5e-324) keeps the least positive float instead
        positive = (kp > 0) | ((kd > 0) & (ndv > 0))
        raw = np.where(positive & (raw == 0.0), np.nextafter(0.0, 1.0), raw)
    finite = ok & np.isfinite(ndp) & np.isfinite(ndv)
    on = _above(pm, pr, ndp, tol, finite)
    force = np.where(on, np.minimum(np.where(np.isfinite(raw), raw, saturation), saturation), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where((on & (force > 0))[..., None], dp / np.where(ndp > 0, ndp, 1.0)[..., None], 0.0)
    return force, d


def _above(pm: np.ndarray, pr: np.ndarray, ndp: np.ndarray, tol: float, finite: np.ndarray) -> np.ndarray:
    """||p_model - p_robot|| > tol, as the reals decide it: the float norm is within a few ulps
    of the real one, so only rows within TIE_BAND of tol are re-decided, in exact rationals of
    the float inputs (F = 0 at or below tol is a proved property: `raven.haptic_force`)."""
    on = finite & (ndp > tol)
    near = finite & (np.abs(ndp - tol) <= TIE_BAND * tol)
    if not near.any():
        return on
    pm_b, pr_b = np.broadcast_arrays(pm, pr)
    shape = np.shape(on)
    on, near = on.reshape(-1).copy(), near.reshape(-1)
    pm_b, pr_b = pm_b.reshape(-1, 3), pr_b.reshape(-1, 3)
    bound = Fraction(tol) ** 2
    for i in np.flatnonzero(near):
        on[i] = sum((Fraction(a) - Fraction(b)) ** 2 for a, b in zip(pm_b[i], pr_b[i])) > bound
    return on.reshape(shape)


def residual(e, e_previous) -> np.ndarray:
    """The per-step residual ||e - e_previous||: the change of the deviation over the last
    period, which is what a detector re-anchored to the robot every period sees."""
    r = _vec(e) - _vec(e_previous)
    with np.errstate(invalid="ignore", over="ignore"):
        out = np.sqrt(np.einsum("...i,...i->...", r, r))
    return np.where(np.isfinite(out), out, np.inf)


@dataclass
class Deviation:
    force: np.ndarray  # (R,) eq 5
    direction: np.ndarray  # (R, 3) eq 6
    alarm: np.ndarray  # (R,) bool: the deviation exceeds tol now, or an input is not finite
    stop: np.ndarray  # (R,) bool: latched stop (fallback "stop"); never set for "haptic"
    deviation: np.ndarray  # (R,) ||e|| (inf for non-finite input)
    peak: np.ndarray  # (R,) largest ||e|| seen so far


class DeviationMonitor:
    """The monitor over a batch of R runs, one call per 1 kHz tick.

    fallback="stop": an alarm latches the stop (the proved design); "haptic": the paper's
    design, only the force (the refuted `raven.deviation_haptic_only`): `stop` stays False,
    `alarm` still reports the exceedance."""

    def __init__(self, runs: int = 1, tol: float = TOL, kp: float = 1000.0, kd: float = 10.0,
                 saturation: float = 1.0, fallback: str = "stop") -> None:
        if fallback not in ("stop", "haptic"):
            raise ValueError("fallback must be 'stop' or 'haptic'")
        if not (np.isfinite(tol) and tol > 0):
            raise ValueError("tol must be finite and positive")
        self.tol, self.kp, self.kd, self.saturation, self.fallback = tol, kp, kd, saturation, fallback
        self.stopped = np.zeros(runs, dtype=bool)
        self.peak = np.zeros(runs)
        self.first_alarm = np.full(runs, -1, dtype=np.int64)
        self.tick = 0

    def step(self, p_model, v_model, p_robot, v_robot) -> Deviation:
        _, ee = deviation(p_model, p_robot)
        bad = ~_finite(_vec(v_model), _vec(v_robot))
        alarm = exceeds(ee, self.tol) | bad
        force, direction = haptic_force(p_model, v_model, p_robot, v_robot, self.tol, self.kp, self.kd,
                                        self.saturation)
        norm = np.sqrt(ee)
        self.peak = np.maximum(self.peak, norm)
        self.first_alarm = np.where(alarm & (self.first_alarm < 0), self.tick, self.first_alarm)
        if self.fallback == "stop":
            self.stopped = self.stopped | alarm
        self.tick += 1
        return Deviation(force, direction, alarm, self.stopped.copy(), norm, self.peak.copy())
