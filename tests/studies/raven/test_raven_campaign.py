"""The fault-injection campaign skeleton (studies/raven/campaign/run.py) over the batched closed loop."""

import numpy as np
import pytest

from certiloop.studies.raven.campaign.run import (
    FAULT_KINDS,
    STREAMS,
    Fault,
    Scenario,
    random_faults,
    run_campaign,
)


def _same(a, b):
    return (np.array_equal(a.first_alarm, b.first_alarm) and np.array_equal(a.min_distance, b.min_distance)
            and a.outcome == b.outcome)


def test_same_seed_same_records():
    faults = random_faults(60, seed=3, ticks=600)
    sc = Scenario(ticks=600)
    assert _same(run_campaign(faults, sc, seed=3), run_campaign(faults, sc, seed=3))


def test_golden_runs_never_alarm_or_cross():
    rec = run_campaign([None] * 8, Scenario(ticks=1500))
    assert rec.outcome == ["TN"] * 8 and rec.crossings == 0 and np.all(rec.first_alarm < 0)


def test_every_fault_kind_and_stream_runs_and_stays_finite():
    faults = [Fault(k, s, 50, 100, {"stuck": 1, "delay": 5, "drop": 0.5}.get(k, 1e-3))
              for k in FAULT_KINDS for s in STREAMS]
    rec = run_campaign(faults, Scenario(ticks=300))
    assert np.all(np.isfinite(rec.min_distance)) and np.all(np.isfinite(rec.peak_deviation))
    assert len(rec.outcome) == len(faults)


@pytest.mark.parametrize("size", [0.0061, 0.0075, 0.02])
def test_encoder_jump_above_two_tol_is_detected_at_once(size):
    rec = run_campaign([Fault("jump", "encoder", 200, 5, size)] * 3, Scenario(ticks=400))
    assert rec.outcome == ["TP"] * 3 and np.all(rec.first_alarm == 200)


def test_slow_drift_caught_by_the_monitor_missed_by_the_per_step_residual():
    """0.5 mm per tick towards the plane, for 200 ticks: the deviation monitor alarms after
    about 6 ticks and stops the arm before the plane; the per-step residual never alarms."""
    drift = [Fault("drift", "command", 100, 200, 5e-4)]
    stop = run_campaign(drift, Scenario(ticks=400))
    assert stop.outcome == ["TP"] and 100 <= stop.first_alarm[0] <= 110
    assert stop.residual_alarm[0] == -1 and stop.crossings == 0
    haptic = run_campaign(drift, Scenario(ticks=400, fallback="haptic"))
    assert haptic.first_alarm[0] == stop.first_alarm[0] and haptic.crossings == 1


def test_drift_below_tol_per_tick_eq5_detects_what_the_per_step_residual_misses():
    """The spec's criterion 6 over a campaign: 100 command drifts of 10 µm to 1 mm per tick (each
    far below tol = 3 mm per tick), long enough to accumulate past tol: the accumulated
    deviation (eq 5) alarms in >= 95 % of them, the per-step residual in <= 5 % (counted while
    the drift lasts: when it ends, the command snaps back by the whole drift, which any
    detector sees)."""
    rng = np.random.default_rng(11)
    drifts = []
    for _ in range(100):
        rate = float(np.exp(rng.uniform(np.log(1e-5), np.log(1e-3))))
        start, lasting = int(rng.integers(100, 300)), int(2 * 0.003 / rate) + 10  # past 2 tol
        drifts.append(Fault("drift", "command", start, lasting, rate))
    rec = run_campaign(drifts, Scenario(ticks=1000, fallback="haptic"), seed=2)

    def share_alarmed(first_alarm) -> float:
        return np.mean([f.start <= a < f.start + f.duration for f, a in zip(drifts, first_alarm)])

    eq5, per_step = share_alarmed(rec.first_alarm), share_alarmed(rec.residual_alarm)
    assert eq5 >= 0.95 and per_step <= 0.05, (eq5, per_step)


def test_stop_keeps_every_bounded_fault_on_the_safe_side():
    """The proved design's premise in numbers: the fixture keeps the model >= 6 mm from the
    plane, tol = 3 mm, and no fault moves the robot by more than 3 mm in one tick (jumps
    <= 2.9 mm, drifts <= 1 mm per tick): no crossing with the stop, some without it."""
    rng = np.random.default_rng(7)
    faults = []
    for _ in range(120):
        kind = FAULT_KINDS[rng.integers(len(FAULT_KINDS))]
        mag = {"stuck": 1.0, "delay": float(rng.integers(1, 40)), "drop": float(rng.uniform(0.1, 1)),
               "jump": float(rng.uniform(1e-4, 2.9e-3)), "noise": float(rng.uniform(1e-4, 1e-3)),
               "drift": float(rng.uniform(1e-5, 1e-3))}[kind]
        stream = "encoder" if kind == "noise" else STREAMS[rng.integers(2)]
        faults.append(Fault(kind, stream, int(rng.integers(100, 900)), int(rng.integers(1, 600)), mag))
    sc = Scenario(ticks=1500)
    stop = run_campaign(faults, sc, seed=7)
    assert stop.crossings == 0
    haptic = run_campaign(faults, Scenario(ticks=1500, fallback="haptic"), seed=7)
    assert haptic.crossings > 0
    m = stop.metrics()
    assert m["TP"] + m["FP"] + m["FN"] + m["TN"] == len(faults) and 0 <= m["TPR"] <= 1


def test_the_fixture_in_the_loop_is_the_kernels_proved_virtual_fixture():
    """The shared model trajectory is what a fresh VirtualFixture (sbs.ctrl2) commands on each
    state, the model integrates exactly, and it never comes nearer the plane than the margin."""
    from certiloop.studies.raven.campaign.run import DT, model_trajectory
    from certiloop.studies.sbs.fixture import VirtualFixture
    n = np.array([0.0, 0.0, 1.0])
    positions, velocities, fallbacks = model_trajectory(600, 0.006, 0.1, 2.0, 0.02, tuple(n))
    for t in range(0, 600, 7):
        omega = 2 * np.pi / 2.0  # the operator of model_trajectory, same arithmetic
        f = -(0.1 * np.cos(omega * (t * DT))) * n
        fp = (0.1 * omega * np.sin(omega * (t * DT))) * n
        # a fresh fixture (no motion history): only the decision on this state is compared
        fixture = VirtualFixture([(0.006 * n, n)], gain=1.0, buffer=0.001, period=DT)
        assert np.array_equal(fixture.step(positions[t], f, fp).velocity, velocities[t])
    assert np.array_equal(positions[1:], positions[:-1] + velocities[:-1] * DT)
    assert fallbacks == 0 and positions[:, 2].min() >= 0.006 and positions[:, 2].min() < 0.0065


def test_dac_override_needs_the_arm_and_is_detected_in_its_window():
    override = Fault("override", "motor", 300, 200, 0.5)
    with pytest.raises(ValueError, match="arm plant"):
        run_campaign([override], Scenario(ticks=600))
    rec = run_campaign([None, override], Scenario(ticks=800, plant="arm", fallback="haptic", grace=400))
    assert rec.outcome == ["TN", "TP"] and 300 <= rec.first_alarm[1] < 500


@pytest.mark.parametrize("magnitude", [-1.0, -0.5, 0.5, 1.0])
def test_dac_override_of_half_the_range_or_more_alarms_within_tens_of_ticks(magnitude):
    """The paper's fault, either sign: the deviation passes tol within a few tens of 1 ms ticks
    (the spec's latency target is a median of 20 ms); golden runs beside it never alarm."""
    override = Fault("override", "motor", 400, 300, magnitude)
    rec = run_campaign([None, override], Scenario(ticks=800, plant="arm", fallback="haptic", grace=0))
    assert rec.first_alarm[0] < 0 and 400 <= rec.first_alarm[1] <= 430
