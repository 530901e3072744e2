"""Fault-injection campaigns over a batched closed loop (the Raven-II paper, skeleton).

One campaign steps R runs at once, 1 kHz, for a fixed number of ticks:

    operator (reach towards a plane) -> fixture (keeps the *model* >= m from the plane, the
    contract of raven.deviation_stop) -> command stream -> [fault] -> robot (follows the
    command; brakes when stopped) -> encoder stream -> [fault] -> deviation monitor
    (studies/raven/deviation.py) -> stop (proved design) or haptic cue only (the paper's)

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
the same records, and a run's random draws (drop, noise) depend only on its own run seed
(a counter-based hash, not a generator shared by the batch), so a run replays alone and
batching does not change results.

Named setups (`SETUPS`, the `certiloop campaign` scenarios) draw one fault per run from a
per-run seed and run the batch in chunks (`run_setup`); `studies/raven/campaign/metrics.py` summarises the
rows; `raven.paper` runs the paper's fixed 4-window schedule (a periodic fault, `PAPER`).

The fixture is the kernel's proved `VirtualFixture` (the code extracted from sbs.ctrl2), its
plane `margin` above the workspace plane, the operator's force being the reach velocity (G =
1). Every run that is not stopped has the same model state as every other run of its
operator (the model gets the clean command), so the fixture is stepped once per operator
speed and tick (`model_trajectory`, cached per process) and its command shared: exactly the
calls a per-run fixture would make. Operator speeds come in SPEED_LEVELS levels for that
reason. A stopped run gets velocity 0 (k = 0, the fixture's own fallback).

The plant is a point tool that follows its command, or the Raven arm (`plant="arm"`); with
the arm, a "motor" stream carries the paper's fault: an "override" of the shoulder's DAC
command by a constant `magnitude` * MAX_DAC for the window (RavenArm.step's tau_override).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from certiloop.studies.raven.deviation import TOL, DeviationMonitor, residual
from certiloop.studies.sbs.fixture import VirtualFixture

FAULT_KINDS = ("stuck", "delay", "drop", "jump", "noise", "drift")
STREAMS = ("command", "encoder")
DT = 1e-3
RUN_STRIDE = 1_000_000  # run i of a campaign with seed S has the run seed S * RUN_STRIDE + i
MAX_RUNS = RUN_STRIDE
MAX_SEED = 2**32 - 1
MOTOR_KINDS = ("override",)  # the paper's constant DAC command, on the arm's "motor" stream only
SPEED_LEVELS = 8  # operator speeds are quantised: one fixture trajectory per level
FIXTURE_BUFFER = 0.001  # m: sbs.ctrl2's D (how far ahead the fixture slows the model)


@dataclass(frozen=True)
class Fault:
    kind: str
    stream: str
    start: int
    duration: int
    magnitude: float
    period: int = 0  # > 0: the window repeats every `period` ticks (the paper's schedule)

    def __post_init__(self) -> None:
        known = (self.kind in FAULT_KINDS and self.stream in STREAMS) or (
            self.kind in MOTOR_KINDS and self.stream == "motor")
        if not known:
            raise ValueError(f"unknown fault {self.kind!r} on {self.stream!r}")
        if self.start < 0 or self.duration < 0 or not math.isfinite(self.magnitude):
            raise ValueError("a fault needs start >= 0, duration >= 0 and a finite magnitude")
        if self.period < 0 or 0 < self.period < self.duration:
            raise ValueError("a periodic fault needs period >= duration")


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
    plant: str = "point"  # or "arm": the Raven arm (IK, joint PD/PID at 1 kHz) follows the command
    speed_spread: float = 0.0  # run i's operator moves at reach_speed * (1 - spread * u_i), u_i in [0, 1)


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
    alarms: np.ndarray | None = None  # (R, ticks) the monitor's alarm at each tick (trace=True)
    distances: np.ndarray | None = None  # (R, ticks) the robot's true distance to the plane (trace=True)

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


def _uniform(keys: np.ndarray, tick: int, lane: int) -> np.ndarray:
    """Uniform numbers in [0, 1), one per run, from (run key, tick, lane) alone (splitmix64):
    a run draws the same numbers whatever else is in its batch."""
    x = keys * np.uint64(0x9E3779B97F4A7C15) + np.uint64(tick * 16 + lane)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    x = x ^ (x >> np.uint64(31))
    return (x >> np.uint64(11)).astype(float) * 2.0 ** -53


def _normal(keys: np.ndarray, tick: int, lane: int) -> np.ndarray:
    """Standard normal numbers (Box-Muller over two hashed uniforms), one per run."""
    u1, u2 = _uniform(keys, tick, lane), _uniform(keys, tick, lane + 1)
    return np.sqrt(-2.0 * np.log1p(-u1)) * np.cos(2.0 * math.pi * u2)


class _Stream:
    """A batched stream of 3-vectors through the runs' faults (one fault per run at most)."""

    def __init__(self, faults: list, stream: str, runs: int, keys: np.ndarray, toward) -> None:
        self.keys, self.toward, self.lane = keys, toward, 0 if stream == "command" else 8
        active = [f if (f is not None and f.stream == stream) else None for f in faults]
        kind = np.array([f.kind if f else "" for f in active])
        self.is_kind = {k: kind == k for k in FAULT_KINDS}  # masks, not string compares per tick
        self.start = np.array([f.start if f else -1 for f in active])
        self.duration = np.array([f.duration if f else 0 for f in active])
        self.period = np.array([f.period if f else 0 for f in active])
        self.mag = np.array([f.magnitude if f else 0.0 for f in active])
        self.lag = int(max([round(f.magnitude) for f in active if f and f.kind == "delay"], default=0))
        self.history = np.zeros((self.lag + 1, runs, 3))  # a ring: slot t % (lag + 1) holds tick t
        self.held = np.zeros((runs, 3))
        self.was_on = np.zeros(runs, dtype=bool)

    def __call__(self, value: np.ndarray, tick: int) -> np.ndarray:
        """The stream's output at `tick`; ticks come in order from 0 (the delay ring needs it)."""
        value = np.asarray(value, dtype=float)
        if self.lag:
            self.history[tick % (self.lag + 1)] = value
        since = tick - self.start
        since = np.where(self.period > 0, since % np.maximum(self.period, 1), since)  # into the window
        on = (self.start <= tick) & (since < self.duration)
        if not on.any() and not self.was_on.any():  # most ticks: no window open, nothing held
            return value.copy()
        first = on & ~self.was_on
        self.held = np.where(first[:, None], value, self.held)
        self.was_on = on
        out = value.copy()
        mag, is_kind = self.mag, self.is_kind
        stuck = on & is_kind["stuck"]
        out[stuck] = self.held[stuck]
        delay = on & is_kind["delay"]
        if delay.any():
            steps = np.clip(np.round(mag[delay]).astype(int), 0, self.lag)
            out[delay] = self.history[(tick - steps) % (self.lag + 1), np.flatnonzero(delay)]
        drop = on & is_kind["drop"]
        if drop.any():
            lost = drop & (_uniform(self.keys, tick, self.lane) < mag)
            out[lost] = self.held[lost]
            self.held = np.where((drop & ~lost)[:, None], value, self.held)
        jump = on & is_kind["jump"]
        out[jump] += mag[jump, None] * self.toward
        noise = on & is_kind["noise"]
        if noise.any():
            keys = self.keys[noise]
            gauss = np.stack([_normal(keys, tick, self.lane + 1 + 2 * i) for i in range(3)], axis=1)
            out[noise] += gauss * mag[noise, None]
        drift = on & is_kind["drift"]
        out[drift] += ((since[drift] + 1) * mag[drift])[:, None] * self.toward
        return out


def run_campaign(faults: list, scenario: Scenario | None = None, seed: int = 0,
                 run_seeds: list | None = None, trace: bool = False) -> Records:
    """Run len(faults) runs (None = a golden run without a fault) through the closed loop.
    Run i draws its random numbers from run_seeds[i] (default: seed * RUN_STRIDE + i). With
    `trace`, Records.alarms holds the monitor's alarm per run and tick (R, ticks)."""
    sc = scenario or Scenario()
    runs = len(faults)
    if run_seeds is None:
        run_seeds = [seed * RUN_STRIDE + i for i in range(runs)]
    keys = np.array(run_seeds, dtype=np.uint64).reshape(runs)
    n = sc.normal / np.linalg.norm(sc.normal)
    command_stream = _Stream(faults, "command", runs, keys, -n)
    encoder_stream = _Stream(faults, "encoder", runs, keys, -n)
    p_model = np.broadcast_to(sc.start_height * n, (runs, 3)).copy()
    p_robot = p_model.copy()
    arm = _ArmPlant(runs, p_robot) if sc.plant == "arm" else None
    level = np.floor(_uniform(keys, 0, 15) * SPEED_LEVELS) / SPEED_LEVELS  # the operators differ
    speed = sc.reach_speed * (1.0 - sc.speed_spread * level)
    speeds, operator = np.unique(speed, return_inverse=True)
    fixture_v = np.stack([model_trajectory(sc.ticks, sc.margin, float(s), sc.period, sc.start_height,
                                           tuple(n))[1] for s in speeds])  # (operators, ticks, 3)
    motor = _MotorStream(faults, runs)
    if motor.any and arm is None:
        raise ValueError("a motor-stream fault needs the arm plant (Scenario.plant='arm')")
    measured_prev = p_robot.copy()
    monitor = DeviationMonitor(runs, tol=sc.tol, fallback=sc.fallback)
    min_distance = p_robot @ n
    e_prev = np.zeros((runs, 3))
    residual_alarm = np.full(runs, -1, dtype=np.int64)
    alarms = np.zeros((runs, sc.ticks), dtype=bool) if trace else None
    distances = np.zeros((runs, sc.ticks)) if trace else None
    for tick in range(sc.ticks):
        stopped = monitor.stopped.copy()
        v = fixture_v[operator, tick]  # the proved fixture's command on the run's model state
        v[stopped] = 0.0
        target_model = p_model + v * DT
        target_robot = command_stream(target_model, tick)  # the robot's commanded position
        target_robot = np.where(np.isfinite(target_robot), target_robot, p_robot)
        p_model = target_model
        if arm is None:
            p_robot = np.where(stopped[:, None], p_robot, target_robot)  # stopped: brakes hold it
        else:
            p_robot = arm.step(target_robot, stopped, motor(tick))
        min_distance = np.minimum(min_distance, p_robot @ n)
        measured = encoder_stream(p_robot, tick)
        v_measured = (measured - measured_prev) / DT
        measured_prev = measured
        now = monitor.step(p_model, v, measured, v_measured)
        if alarms is not None:
            alarms[:, tick], distances[:, tick] = now.alarm, p_robot @ n
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
    return Records(list(faults), first, min_distance, monitor.peak, outcome, residual_alarm, alarms,
                   distances)


class _ArmPlant:
    """The Raven arm as the robot: the commanded tip position goes through inverse kinematics
    (one Newton step a tick, warm-started) to joint targets, which the joint PD/PID dynamics
    follow at 1 kHz (studies/raven/arm.py); a stopped run's joints are braked where they are. The
    campaign's world frame is the tip's displacement from the arm's rest pose, placed at the
    scenario's start position."""

    def __init__(self, runs: int, start: np.ndarray) -> None:
        from certiloop.studies.raven.arm import Positioning, RavenArm

        self.arm, self.kin = RavenArm(), Positioning()
        self.state = self.arm.rest(runs)
        self.q_target = self.state.q[:, :3].copy()
        self.offset = self.kin.tip(self.q_target) - start  # world = tip - offset

    def step(self, target: np.ndarray, stopped: np.ndarray, tau_override=None) -> np.ndarray:
        self.q_target = self.kin.ik_step(target + self.offset, self.q_target)
        joints = np.concatenate([self.q_target, self.state.q[:, 3:]], axis=1)
        moved, _, _ = self.arm.step(self.state, joints, tau_override)
        hold = stopped[:, None]
        self.state.q = np.where(hold, self.state.q, moved.q)
        self.state.qdot = np.where(hold, 0.0, moved.qdot)
        self.state.integral = np.where(hold, self.state.integral, moved.integral)
        self.q_target = np.where(hold, self.state.q[:, :3], self.q_target)
        return self.kin.tip(self.state.q[:, :3]) - self.offset


class _MotorStream:
    """The arm's motor (DAC) stream: a run's "override" fault replaces the shoulder's torque
    by magnitude * its DAC limit in the fault's (possibly periodic) window; NaN elsewhere (the
    controller's own torque)."""

    def __init__(self, faults: list, runs: int) -> None:
        active = [f if (f is not None and f.stream == "motor") else None for f in faults]
        self.any = any(f is not None for f in active)
        self.start = np.array([f.start if f else -1 for f in active])
        self.duration = np.array([f.duration if f else 0 for f in active])
        self.period = np.array([f.period if f else 0 for f in active])
        self.mag = np.array([f.magnitude if f else 0.0 for f in active])
        self.runs = runs

    def __call__(self, tick: int):
        if not self.any:
            return None
        from certiloop.studies.raven.arm import TAU_MAX

        since = tick - self.start
        since = np.where(self.period > 0, since % np.maximum(self.period, 1), since)
        on = (self.start >= 0) & (self.start <= tick) & (since < self.duration)
        tau = np.full((self.runs, 3), np.nan)
        tau[on, 0] = np.clip(self.mag[on], -1.0, 1.0) * TAU_MAX[0]
        return tau


@functools.lru_cache(maxsize=64)
def model_trajectory(ticks: int, margin: float, speed: float, period: float, start_height: float,
                     normal: tuple) -> tuple[np.ndarray, np.ndarray, int]:
    """The model's positions (before each tick) and the fixture's velocities (ticks, 3) for an
    operator reaching towards the plane at `speed` and back every `period` s, through the
    kernel's proved VirtualFixture (plane `margin` above the workspace plane, G = 1, so the
    force is the reach velocity), and how many ticks it fell back to k = 0. A pure function of
    its arguments: every run of this operator that is not stopped sees exactly these calls."""
    n = np.asarray(normal, dtype=float)
    fixture = VirtualFixture([(margin * n, n)], gain=1.0, buffer=FIXTURE_BUFFER, period=DT)
    p = start_height * n
    positions, velocities, fallbacks = np.zeros((ticks, 3)), np.zeros((ticks, 3)), 0
    omega = 2 * math.pi / period
    for tick in range(ticks):
        t = tick * DT
        f = -(speed * math.cos(omega * t)) * n  # reach in, then back out
        fp = (speed * omega * math.sin(omega * t)) * n  # df/dt
        command = fixture.step(p, f, fp)
        fallbacks += not command.ok
        positions[tick], velocities[tick] = p, command.velocity
        p = p + command.velocity * DT
    positions.setflags(write=False)
    velocities.setflags(write=False)
    return positions, velocities, fallbacks


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


# --- named setups: the scenarios of `certiloop campaign` --------------------------------------

# Fault magnitudes within the proved design's premise: no fault moves the robot by more than
# m - tol = 3 mm in one tick (jumps <= 2.9 mm, drifts <= 1 mm per tick, noise sigma <= 0.5 mm,
# i.e. 6 mm is 12 sigma; delays <= 40 ticks at <= 0.05 m/s). Log-uniform in each range.
BOUNDED = {"stuck": (1.0, 1.0), "delay": (1.0, 40.0), "drop": (0.1, 1.0), "jump": (1e-4, 2.9e-3),
           "noise": (1e-4, 5e-4), "drift": (1e-5, 1e-3)}


@dataclass(frozen=True)
class Setup:
    """A campaign scenario: the closed loop's response, the faults it is exposed to, the claim."""

    name: str
    description: str
    fallback: str  # "stop" (the proved design) or "haptic" (the paper's)
    claim: str = "no run crosses the boundary"
    margin: float = 0.006  # m >= tol + U eps with U eps <= 3 mm
    golden: float = 0.2  # share of runs without a fault
    magnitudes: dict = field(default_factory=lambda: dict(BOUNDED))
    grace: int = 20
    schedule: str = "random"  # or "paper": PAPER's fixed windows, one faulty and one golden run
    ticks: int = 2000
    # m/s: the operator reaches 16 mm deep from 20 mm, so the fixture holds the model at the margin
    # every cycle (at Scenario's 0.05 m/s the model never comes nearer than 12 mm)
    reach_speed: float = 0.1
    plant: str = "point"  # "arm": the Raven arm follows the command (Scenario.plant)
    speed_spread: float = 0.0

    def scenario(self, ticks: int) -> Scenario:
        return Scenario(ticks=ticks, margin=self.margin, fallback=self.fallback, grace=self.grace,
                        reach_speed=self.reach_speed, plant=self.plant, speed_spread=self.speed_spread)

    def holds(self, rows: list[dict]) -> bool:
        if self.schedule == "paper":
            return all(r["outcome"] in ("TP", "TN") for r in rows)
        return not any(r["crossed"] for r in rows)


# The paper's experiment (section 3.2): 32 s, the shoulder's DAC overridden by a constant command
# for 300 ticks every 8 s (4 windows), the haptic response, the Raven arm as the plant.
# `override` is the constant as a fraction of MAX_DAC (the paper: "zero or any in-range value").
PAPER = {"start": 4000, "window": 300, "period": 8000, "override": 0.5, "ticks": 32000}


SETUPS = {s.name: s for s in (
    Setup("raven.stop_margin", "the proved stop design (raven.deviation_stop_3d): margin 6 mm >= "
          "tol + U eps, stop on the first alarm", "stop"),
    Setup("raven.haptic_only", "the paper's response, the haptic cue only (raven.deviation_haptic_only): "
          "same faults, the arm is never stopped", "haptic"),
    Setup("raven.no_margin", "the stop design with a margin below tol + U eps (2 mm < 3 mm + U eps, "
          "raven.deviation_small_margin's premise): a fault below the threshold crosses", "stop",
          margin=0.002, reach_speed=0.15),  # reaching 24 mm deep from 20 mm: the fixture holds it at 2 mm
    Setup("raven.stop_margin_arm", "the proved stop design with the Raven arm as the plant (IK, joint "
          "PD/PID at 1 kHz): operators at 0.025-0.05 m/s, whose tracking lag stays under tol", "stop",
          plant="arm", reach_speed=0.05, speed_spread=0.5),
    Setup("raven.haptic_only_arm", "the paper's haptic-only response with the Raven arm as the plant, "
          "operators at 0.025-0.05 m/s", "haptic", plant="arm", reach_speed=0.05, speed_spread=0.5),
    Setup("raven.paper", "the paper's experiment: the Raven arm's shoulder DAC overridden by a constant "
          "50 % of MAX_DAC for 300 ticks every 8 s over 32 s (4 windows), haptic response",
          "haptic", claim="every fault window alarmed, no alarm outside them or in the golden run",
          schedule="paper", ticks=PAPER["ticks"], plant="arm", reach_speed=0.05,
          grace=1000),  # the settle: the arm, thrown ~14 cm, is pulled back within ~0.86 s
)}


def draw_fault(run_seed: int, setup: Setup, kinds=FAULT_KINDS, ticks: int = 2000) -> Fault | None:
    """Run `run_seed`'s fault (None: a golden run), from that seed alone: kind, stream, window
    [start, start + duration) with 100 <= start < ticks/2, 1 <= duration < ticks/4, magnitude."""
    rng = np.random.default_rng(run_seed)
    if rng.random() < setup.golden:
        return None
    kind = kinds[rng.integers(len(kinds))]
    lo, hi = setup.magnitudes[kind]
    mag = float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
    if kind == "delay":
        mag = float(round(mag))
    stream = STREAMS[rng.integers(len(STREAMS))]
    start = int(rng.integers(100, ticks // 2))
    return Fault(kind, stream, start, int(rng.integers(1, ticks // 4)), mag)


def run_setup(setup: Setup, kinds=FAULT_KINDS, runs: int = 1000, seed: int = 0, ticks: int = 2000,
              batch: int = 500, on_batch=None, executor=None) -> list[dict]:
    """`runs` runs of `setup`, run i with the run seed seed * RUN_STRIDE + i, stepped `batch`
    at a time; one row per run, in run order. on_batch() is called after each batch. With a
    concurrent.futures `executor` (a process pool, a Dask cluster) the batches run there; a
    run depends only on its run seed, so neither `batch` nor the executor changes a row."""
    if not 1 <= runs <= MAX_RUNS or not 0 <= seed <= MAX_SEED or ticks < 400:
        raise ValueError(f"need 1 <= runs <= {MAX_RUNS}, 0 <= seed <= {MAX_SEED}, ticks >= 400")
    if setup.schedule == "paper":
        return _paper_rows(setup, seed)
    batches = [(setup, tuple(kinds), ticks, first, seed * RUN_STRIDE + first,
                min(runs, first + batch) - first) for first in range(0, runs, batch)]
    if executor is None:
        results = map(_batch_rows, batches)
    else:
        futures = [executor.submit(_batch_rows, b) for b in batches]
        results = (f.result() for f in futures)
    rows: list[dict] = []
    for part in results:
        rows.extend(part)
        if on_batch is not None:
            on_batch()
    return rows


def _batch_rows(spec: tuple) -> list[dict]:
    """One batch of a campaign (a picklable unit of work): runs first .. first + count - 1."""
    setup, kinds, ticks, first, first_seed, count = spec
    seeds = [first_seed + i for i in range(count)]
    faults = [draw_fault(s, setup, kinds, ticks) for s in seeds]
    rec = run_campaign(faults, setup.scenario(ticks), run_seeds=seeds)
    return [_row(first + i, s, f, int(rec.first_alarm[i]), rec.outcome[i], rec.min_distance[i],
                 rec.peak_deviation[i]) for i, (s, f) in enumerate(zip(seeds, faults))]


def _row(run: int, seed: int, f: Fault | None, alarm: int, outcome: str, min_distance, peak=None) -> dict:
    """One CSV row; `peak` is the run's largest measured deviation ||e|| (the ROC's score; None
    for the paper's per-window rows)."""
    return {"run": run, "seed": seed, "kind": f.kind if f else "none", "stream": f.stream if f else "",
            "start": f.start if f else -1, "duration": f.duration if f else 0,
            "magnitude": f.magnitude if f else 0.0, "alarmed": alarm >= 0, "first_alarm": alarm,
            "latency": alarm - f.start if f and outcome == "TP" else None, "outcome": outcome,
            "min_distance": float(min_distance), "crossed": bool(min_distance < 0),
            "peak_deviation": None if peak is None else float(peak)}


def _paper_rows(setup: Setup, seed: int) -> list[dict]:
    """The paper's experiment: a golden run and a run with PAPER's periodic fault. Rows: the
    golden run, each window (TP if an alarm in [start, start + 300 + grace), else FN) and the
    faulty run's stretches between the windows (kind "none": TN, or FP on any alarm)."""
    ticks, grace = PAPER["ticks"], setup.grace
    fault = Fault("override", "motor", PAPER["start"], PAPER["window"], PAPER["override"], PAPER["period"])
    seeds = [seed * RUN_STRIDE, seed * RUN_STRIDE + 1]
    rec = run_campaign([None, fault], setup.scenario(ticks), run_seeds=seeds, trace=True)

    def first(alarms: np.ndarray, offset: int = 0) -> int:
        hits = np.flatnonzero(alarms)
        return offset + int(hits[0]) if len(hits) else -1

    golden = first(rec.alarms[0])
    rows = [_row(0, seeds[0], None, golden, "FP" if golden >= 0 else "TN", rec.distances[0].min())]
    covered = np.zeros(ticks, dtype=bool)
    for k, start in enumerate(range(PAPER["start"], ticks, PAPER["period"])):
        end = min(ticks, start + PAPER["window"] + grace)
        covered[start:end] = True
        alarm = first(rec.alarms[1, start:end], start)
        window = Fault("override", "motor", start, PAPER["window"], PAPER["override"])
        rows.append(_row(k + 1, seeds[1], window, alarm, "TP" if alarm >= 0 else "FN",
                         rec.distances[1, start:end].min()))
    outside = first(rec.alarms[1] & ~covered)
    rows.append(_row(len(rows), seeds[1], None, outside, "FP" if outside >= 0 else "TN",
                     rec.distances[1, ~covered].min()))
    return rows


def replay(setup: Setup, run_seed: int, kinds=FAULT_KINDS, ticks: int = 2000) -> Records:
    """One run of a campaign again, alone, from its run seed (the CSV's `seed` column)."""
    fault = draw_fault(run_seed, setup, kinds, ticks)
    return run_campaign([fault], setup.scenario(ticks), run_seeds=[run_seed])
