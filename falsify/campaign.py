"""Fault-injection campaigns over a batched closed loop (seed 003, skeleton).

One campaign steps R runs at once, 1 kHz, for a fixed number of ticks:

    operator (reach towards a plane) -> fixture (keeps the *model* >= m from the plane, the
    contract of raven.deviation_stop) -> command stream -> [fault] -> robot (follows the
    command; brakes when stopped) -> encoder stream -> [fault] -> deviation monitor
    (kernel/deviation.py) -> stop (proved design) or haptic cue only (the paper's)

The model receives the clean command (the paper's case (ii): the simulator gets the
original input); hazards are judged on the robot's *true* position, detection only on the
measured stream. Fault models (Table 1 and raven2_sim's injections), each active in the
window [start, start + duration) of a run, on the "command" or the "encoder" stream:

    stuck  the stream holds its value from the window start
    delay  the stream lags `magnitude` ticks (rounded)
    drop   each packet is lost with probability `magnitude`; the receiver holds the last one
    jump   an offset of `magnitude` metres (along -n, towards the plane) during the window
    noise  Gaussian noise of standard deviation `magnitude` metres (per axis)
    drift  an offset growing by `magnitude` metres per tick (towards the plane)

On the command stream (a commanded position), a fault moves the robot; on the encoder
stream it only corrupts what the monitor sees. Run-level confusion, as raven2_sim defines
it: a run with a fault is a true positive if its first alarm falls in [start, start +
duration + grace), a false negative if it never alarms in that window; any alarm in a run
without a fault (or before its window) is a false positive (a fault too small to matter
still counts as a miss: raven2_sim's labelling). Beside the monitor, the per-step residual
||e - e_prev|| > tol is recorded for comparison. Everything is seeded: the same seed gives
the same records. Not yet here: the Raven arm as the plant, the CLI, CSV/JSON output,
confidence intervals, plots, Dask.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from certiloop.kernel.deviation import TOL, DeviationMonitor, residual

FAULT_KINDS = ("stuck", "delay", "drop", "jump", "noise", "drift")
STREAMS = ("command", "encoder")
DT = 1e-3


@dataclass(frozen=True)
class Fault:
    kind: str
    stream: str
    start: int
    duration: int
    magnitude: float

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS or self.stream not in STREAMS:
            raise ValueError(f"unknown fault {self.kind!r} on {self.stream!r}")
        if self.start < 0 or self.duration < 0 or not math.isfinite(self.magnitude):
            raise ValueError("a fault needs start >= 0, duration >= 0 and a finite magnitude")


@dataclass
class Scenario:
    ticks: int = 2000
    margin: float = 0.006  # m: the fixture keeps the model this far from the plane
    start_height: float = 0.02  # m above the plane
    reach_speed: float = 0.05  # m/s: the operator's peak speed towards the plane
    period: float = 1.0  # s: the operator's reach-and-retract cycle
    tol: float = TOL
    fallback: str = "stop"  # or "haptic" (the paper's response)
    grace: int = 20  # ticks after the window in which an alarm still counts as detection
    normal: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))


@dataclass
class Records:
    """Per run: the fault (or None), first alarm tick (-1: none), minimum true distance to
    the plane, peak deviation, and the run-level outcome."""

    faults: list
    first_alarm: np.ndarray
    min_distance: np.ndarray
    peak_deviation: np.ndarray
    outcome: list  # "TP" | "FP" | "FN" | "TN"
    residual_alarm: np.ndarray  # first tick a per-step residual ||e - e_prev|| > tol (-1: none)

    @property
    def crossings(self) -> int:
        return int(np.sum(self.min_distance < 0))

    def metrics(self) -> dict:
        counts = {k: self.outcome.count(k) for k in ("TP", "FP", "FN", "TN")}
        tp, fp, fn, tn = counts["TP"], counts["FP"], counts["FN"], counts["TN"]
        tpr = tp / (tp + fn) if tp + fn else float("nan")
        fpr = fp / (fp + tn) if fp + tn else float("nan")
        f1 = 2 * tp / (2 * tp + fp + fn) if tp + fp + fn else float("nan")
        lat = [int(a - f.start) for f, a, o in zip(self.faults, self.first_alarm, self.outcome) if o == "TP"]
        return {**counts, "TPR": tpr, "FPR": fpr, "F1": f1, "crossings": self.crossings,
                "latency_median": float(np.median(lat)) if lat else float("nan"),
                "latency_p95": float(np.percentile(lat, 95)) if lat else float("nan")}


class _Stream:
    """A batched stream of 3-vectors through the runs' faults (one fault per run at most)."""

    def __init__(self, faults: list, stream: str, runs: int, rng: np.random.Generator, toward) -> None:
        self.rng, self.toward = rng, toward
        active = [f if (f is not None and f.stream == stream) else None for f in faults]
        self.kind = np.array([f.kind if f else "" for f in active])
        self.start = np.array([f.start if f else -1 for f in active])
        self.end = np.array([f.start + f.duration if f else -1 for f in active])
        self.mag = np.array([f.magnitude if f else 0.0 for f in active])
        self.lag = int(max([round(f.magnitude) for f in active if f and f.kind == "delay"], default=0))
        self.history = np.zeros((self.lag + 1, runs, 3))
        self.held = np.zeros((runs, 3))
        self.started = np.zeros(runs, dtype=bool)

    def __call__(self, value: np.ndarray, tick: int) -> np.ndarray:
        value = np.asarray(value, dtype=float)
        if self.lag:
            self.history = np.roll(self.history, 1, axis=0)
            self.history[0] = value
        on = (self.start <= tick) & (tick < self.end)
        first = on & ~self.started
        self.held = np.where(first[:, None], value, self.held)
        self.started |= on
        out = value.copy()
        k, mag = self.kind, self.mag
        stuck = on & (k == "stuck")
        out[stuck] = self.held[stuck]
        delay = on & (k == "delay")
        if delay.any():
            steps = np.clip(np.round(mag[delay]).astype(int), 0, self.lag)
            out[delay] = self.history[steps, np.flatnonzero(delay)]
        drop = on & (k == "drop")
        lost = drop & (self.rng.random(len(value)) < mag)
        out[lost] = self.held[lost]
        self.held = np.where((drop & ~lost)[:, None], value, self.held)
        jump = on & (k == "jump")
        out[jump] += mag[jump, None] * self.toward
        noise = on & (k == "noise")
        out[noise] += self.rng.normal(0.0, 1.0, (int(noise.sum()), 3)) * mag[noise, None]
        drift = on & (k == "drift")
        out[drift] += ((tick - self.start[drift] + 1) * mag[drift])[:, None] * self.toward
        return out


def run_campaign(faults: list, scenario: Scenario | None = None, seed: int = 0) -> Records:
    """Run len(faults) runs (None = a golden run without a fault) through the closed loop."""
    sc = scenario or Scenario()
    runs = len(faults)
    rng = np.random.default_rng(seed)
    n = sc.normal / np.linalg.norm(sc.normal)
    command_stream = _Stream(faults, "command", runs, rng, -n)
    encoder_stream = _Stream(faults, "encoder", runs, rng, -n)
    p_model = np.broadcast_to(sc.start_height * n, (runs, 3)).copy()
    p_robot = p_model.copy()
    measured_prev = p_robot.copy()
    monitor = DeviationMonitor(runs, tol=sc.tol, fallback=sc.fallback)
    min_distance = p_robot @ n
    e_prev = np.zeros((runs, 3))
    residual_alarm = np.full(runs, -1, dtype=np.int64)
    for tick in range(sc.ticks):
        t = tick * DT
        stopped = monitor.stopped.copy()
        # operator: reach towards the plane and back; fixture: keep the model >= margin
        v = -sc.reach_speed * math.cos(2 * math.pi * t / sc.period) * n
        v = np.broadcast_to(v, (runs, 3)).copy()
        dist_m = p_model @ n
        vn = v @ n
        limit = (sc.margin - dist_m) / DT  # the least normal speed keeping d_m >= margin
        v += np.maximum(limit - vn, 0.0)[:, None] * n
        v[stopped] = 0.0
        target_model = p_model + v * DT
        target_robot = command_stream(target_model, tick)  # the robot's commanded position
        target_robot = np.where(np.isfinite(target_robot), target_robot, p_robot)
        p_model = target_model
        p_robot = np.where(stopped[:, None], p_robot, target_robot)  # stopped: brakes hold it
        min_distance = np.minimum(min_distance, p_robot @ n)
        measured = encoder_stream(p_robot, tick)
        v_measured = (measured - measured_prev) / DT
        measured_prev = measured
        monitor.step(p_model, v, measured, v_measured)
        e = measured - p_model
        jumped = residual(e, e_prev) > sc.tol  # the per-step residual, for comparison only
        residual_alarm = np.where(jumped & (residual_alarm < 0), tick, residual_alarm)
        e_prev = e
    first = monitor.first_alarm
    outcome = []
    for f, a in zip(faults, first):
        if f is None:
            outcome.append("FP" if a >= 0 else "TN")
        elif 0 <= a < f.start:
            outcome.append("FP")
        elif f.start <= a < f.start + f.duration + sc.grace:
            outcome.append("TP")
        else:
            outcome.append("FN")
    return Records(list(faults), first, min_distance, monitor.peak, outcome, residual_alarm)


def random_faults(runs: int, seed: int = 0, kinds=FAULT_KINDS, streams=STREAMS, ticks: int = 2000,
                  golden: float = 0.2) -> list:
    """A seeded random campaign: a share `golden` of runs without a fault, the others with one
    fault of a random kind, stream, window and (log-uniform) magnitude."""
    rng = np.random.default_rng(seed)
    scale = {"stuck": (1, 1), "delay": (1, 50), "drop": (0.1, 1.0), "jump": (1e-4, 2e-2),
             "noise": (1e-4, 5e-3), "drift": (1e-6, 1e-3)}
    out: list = []
    for _ in range(runs):
        if rng.random() < golden:
            out.append(None)
            continue
        kind = kinds[rng.integers(len(kinds))]
        lo, hi = scale[kind]
        mag = float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
        start = int(rng.integers(100, ticks // 2))
        duration = int(rng.integers(1, ticks // 4))
        out.append(Fault(kind, streams[rng.integers(len(streams))], start, duration, mag))
    return out
