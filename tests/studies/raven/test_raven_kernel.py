"""The Raven-II runtime kernels (the Raven-II paper): deviation monitor (eqs 3-6) and the arm."""

import math
import os
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
import sympy
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.falsify.evaluate import Compiler
from certiloop.models.lang.programs import Choice, Seq, Test, children
from certiloop.studies.raven import arm, models
from certiloop.studies.raven import deviation as dev

coord = st.floats(-0.1, 0.1, allow_nan=False, allow_infinity=False)
vec = st.tuples(coord, coord, coord)
anything = st.floats(allow_nan=True, allow_infinity=True)
wild = st.tuples(anything, anything, anything)
gain = st.floats(0, 1e4, allow_nan=False)
TOL = dev.TOL


def test_kernels_load_no_solver_or_test_tool():
    code = ("import sys, certiloop.studies.raven.arm, certiloop.studies.raven.deviation; "
            "print(sorted(m for m in ('z3', 'sympy', 'hypothesis', 'scipy', 'ompl') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


# --------------------------------------------------------------------------- eqs 5-6


# the spec's 10,000 examples per property in the deep profile; the profile's count otherwise
DEEP_EXAMPLES = (settings(max_examples=10_000) if os.environ.get("HYPOTHESIS_PROFILE") == "deep"
                 else (lambda test: test))


@DEEP_EXAMPLES
@given(wild, wild, wild, wild)
def test_non_finite_input_never_gives_nan_and_stops(pm, vm, pr, vr):
    force, d = dev.haptic_force(pm, vm, pr, vr)
    assert np.isfinite(force) and np.all(np.isfinite(d))
    monitor = dev.DeviationMonitor(runs=1)
    out = monitor.step(pm, vm, pr, vr)
    assert np.all(np.isfinite(out.force)) and np.all(np.isfinite(out.direction))
    if not all(math.isfinite(x) for x in (*pm, *vm, *pr, *vr)):
        assert out.alarm.all() and out.stop.all()
        assert force == 0.0 and not np.any(d)


@DEEP_EXAMPLES
@given(vec, vec, vec, st.floats(0, 1, allow_nan=False), gain, gain, st.floats(1e-3, 100, allow_nan=False))
def test_force_is_exactly_zero_at_or_below_tol(pm, vm, vr, scale, kp, kd, sat):
    direction = np.array([1.0, -2.0, 0.5]) / math.sqrt(5.25)
    pr = np.array(pm) - scale * TOL * direction  # ||p_model - p_robot|| <= tol
    force, d = dev.haptic_force(pm, vm, pr, vr, TOL, kp, kd, sat)
    exact = sum((Fraction(a) - Fraction(float(b))) ** 2 for a, b in zip(pm, pr))  # ||dp||², exactly
    if exact <= Fraction(TOL) ** 2:
        assert force == 0.0 and not np.any(d)


@DEEP_EXAMPLES
@given(vec, vec, vec, vec, gain, gain, st.floats(1e-3, 100, allow_nan=False))
def test_force_is_bounded_and_points_to_the_model(pm, vm, pr, vr, kp, kd, sat):
    force, d = dev.haptic_force(pm, vm, pr, vr, TOL, kp, kd, sat)
    assert 0.0 <= force <= sat
    dp = np.array(pm) - np.array(pr)
    above = sum((Fraction(a) - Fraction(b)) ** 2 for a, b in zip(pm, pr)) > Fraction(TOL) ** 2  # exactly
    if force > 0:
        assert above
        assert abs(np.dot(d, d) - 1.0) < 1e-12 and np.dot(d, dp) > 0
    elif kp > 0 and above:
        pytest.fail("the force must be on above tol when kp > 0")


def test_force_law_values():
    zero, off = [0, 0, 0], [0.004, 0, 0]
    force, d = dev.haptic_force(zero, zero, off, [0.1, 0, 0], TOL, kp=100, kd=2, saturation=5)
    assert force == pytest.approx(100 * 0.004 + 2 * 0.1) and d.tolist() == [-1.0, 0.0, 0.0]
    force, _ = dev.haptic_force(zero, zero, off, [0.1, 0, 0], TOL, kp=1e6, kd=0, saturation=5)
    assert force == 5.0
    robots = [[0.001, 0, 0], [0.004, 0, 0], [np.nan, 0, 0], [0, 0, 0.01]]
    batch = dev.haptic_force(np.zeros((4, 3)), np.zeros((4, 3)), robots, np.zeros((4, 3)))
    assert batch[0].shape == (4,) and batch[0][0] == 0 and batch[0][1] > 0 and batch[0][2] == 0


# --------------------------------------------------------------------------- the stop guard vs the theorem


def _stop_guard():
    """The alarm test of raven.deviation_stop_3d, taken from the theorem's program."""
    def walk(p):
        if isinstance(p, Choice) and "deviation > tol: stop" in p.labels:
            first = p.alternatives[p.labels.index("deviation > tol: stop")]
            assert isinstance(first, Seq) and isinstance(first.parts[0], Test)
            return first.parts[0].cond
        for c in children(p):
            found = walk(c)
            if found is not None:
                return found
        return None
    guard = walk(models.deviation_stop_3d().program)
    assert guard is not None
    return Compiler(exact=True)(guard)


GUARD = _stop_guard()
near = st.floats(-0.01, 0.01, allow_nan=False, allow_infinity=False)


direction = st.tuples(near, near, near).filter(lambda d: sum(x * x for x in d) > 1e-8)
# deviations around the threshold: exactly on it, within rounding of it, and a few % off
radius = st.one_of(st.just(1.0), st.floats(1 - 1e-9, 1 + 1e-9), st.floats(0.9, 1.1), st.floats(0, 3))


@st.composite
def model_and_robot(draw):
    pm = draw(st.tuples(near, near, near))
    if draw(st.booleans()):
        return pm, draw(st.tuples(near, near, near)), None
    d = np.array(draw(direction))
    return pm, None, (d / np.linalg.norm(d), draw(radius))


@settings(max_examples=400)
@given(model_and_robot(), st.booleans(), st.sampled_from([0.003, 0.001, 0.0045]))
def test_stop_decision_agrees_with_the_proved_guard(case, stopped, tol):
    """Evaluated exactly on the same floats: whenever the theorem's guard alarms the kernel
    stops; the kernel stops without it only within its 1e-9 guard band of tol²."""
    pm, pr, around = case
    if pr is None:
        unit, r = around
        pr = tuple(float(x) for x in np.array(pm) + r * tol * unit)
    state = {f"pm{a}": Fraction(x) for a, x in zip("xyz", pm)}
    state.update({f"pr{a}": Fraction(x) for a, x in zip("xyz", pr)})
    state.update(tol=Fraction(tol), stopped=Fraction(int(stopped)))
    exact = bool(GUARD(state))
    kernel = bool(dev.stop_decision(pm, pr, tol, stopped))
    if exact:
        assert kernel
    elif kernel:
        ee = sum((Fraction(b) - Fraction(a)) ** 2 for a, b in zip(pm, pr))
        assert ee > Fraction(tol) ** 2 * (1 - Fraction(2, 10**9))


def test_stop_decision_on_the_boundary_and_latch():
    assert not dev.stop_decision([0, 0, 0], [0.002, 0, 0])
    assert dev.stop_decision([0, 0, 0], [0.0031, 0, 0])
    assert dev.stop_decision([0, 0, 0], [0, 0, 0], stopped=True)
    mon = dev.DeviationMonitor(runs=2)
    mon.step([[0, 0, 0]] * 2, np.zeros((2, 3)), [[0.004, 0, 0], [0, 0, 0]], np.zeros((2, 3)))
    out = mon.step(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)))
    assert out.stop.tolist() == [True, False] and out.alarm.tolist() == [False, False]
    assert mon.first_alarm.tolist() == [0, -1]
    haptic = dev.DeviationMonitor(runs=1, fallback="haptic")
    assert not haptic.step([0, 0, 0], [0, 0, 0], [0.004, 0, 0], [0, 0, 0]).stop.any()


def test_slow_drift_accumulates_for_the_deviation_but_not_for_the_residual():
    """A drift of 0.4 mm per tick: the per-step residual never exceeds 3 mm, the
    accumulated deviation does at the 8th tick (the refuted raven.residual_drift, in numbers)."""
    pm = np.zeros(3)
    e_prev = np.zeros(3)
    alarms, residual_alarms = [], []
    for k in range(1, 11):
        pr = np.array([0.0004 * k, 0, 0])
        alarms.append(bool(dev.stop_decision(pm, pr)))
        residual_alarms.append(bool(dev.residual(pr - pm, e_prev) > TOL))
        e_prev = pr - pm
    assert not any(residual_alarms) and alarms.index(True) == 7


# --------------------------------------------------------------------------- the arm


def _fk_sympy(side):
    """The DH table evaluated independently: sympy matrices, Craig's convention, the product
    taken symbolically once and compiled (math module) for the random joint vectors."""
    th1, th2, d3, th4, th5, th6 = q = sympy.symbols("th1 th2 d3 th4 th5 th6")
    alpha = ([0, 75, 180 - 52, 0, 90, 90] if side == "left" else [180, 75, 52, 0, 90, 90])
    theta = [th1, th2, sympy.pi / 2 if side == "left" else -sympy.pi / 2, th4, th5, th6]
    d = [0, 0, d3, sympy.Rational(-47, 100), 0, 0]
    a = [0, 0, 0, 0, 0, sympy.Rational(13, 1000)]
    T = sympy.eye(4)
    for al, aa, th, dd in zip(alpha, a, theta, d):
        al = al * sympy.pi / 180
        rx = sympy.Matrix([[1, 0, 0, aa], [0, sympy.cos(al), -sympy.sin(al), 0],
                           [0, sympy.sin(al), sympy.cos(al), 0], [0, 0, 0, 1]])
        rz = sympy.Matrix([[sympy.cos(th), -sympy.sin(th), 0, 0], [sympy.sin(th), sympy.cos(th), 0, 0],
                           [0, 0, 1, dd], [0, 0, 0, 1]])
        T = T * rx * rz
    return sympy.lambdify(q, [T[i, 3] for i in range(3)], modules="math")


@pytest.mark.parametrize("side", ["left", "right"])
def test_forward_kinematics_matches_an_independent_evaluation(side):
    rng = np.random.default_rng(3)
    n = 1000
    q = np.column_stack([rng.uniform(0, np.pi / 2, n), rng.uniform(np.pi / 4, 3 * np.pi / 4, n),
                         rng.uniform(0.23, 0.56, n), rng.uniform(-np.pi, np.pi, (n, 3))])
    got = arm.tip(q, side)
    fk = _fk_sympy(side)
    expected = np.array([fk(*map(float, qi)) for qi in q])
    assert np.max(np.abs(got - expected)) <= 1e-12
    wrist = arm.frames(q, side)[:, 4, :3, 3]
    assert np.allclose(np.linalg.norm(wrist, axis=1), np.abs(q[:, 2] - 0.47), atol=1e-12)


def test_tip_velocity_matches_motion():
    rng = np.random.default_rng(4)
    q = np.column_stack([rng.uniform(0.1, 1.4, 10), rng.uniform(0.9, 2.2, 10), rng.uniform(0.25, 0.5, 10),
                         rng.uniform(-1, 1, (10, 3))])
    qdot = rng.uniform(-1, 1, (10, 6))
    h = 1e-6
    numeric = (arm.tip(q + h * qdot) - arm.tip(q - h * qdot)) / (2 * h)
    assert np.allclose(arm.tip_velocity(q, qdot), numeric, atol=1e-7)


finite_joint = st.floats(-10, 10, allow_nan=False, allow_infinity=False)


@given(st.lists(st.tuples(*[anything] * 6), min_size=1, max_size=4), st.integers(1, 50))
def test_arm_never_gives_nan_torque_and_respects_the_limits(targets, ticks):
    robot = arm.RavenArm()
    state = robot.rest(len(targets))
    target = np.array(targets, dtype=float)
    for _ in range(ticks):
        state, tau, braked = robot.step(state, target)
        assert np.all(np.isfinite(tau)) and np.all(np.abs(tau) <= robot.p.tau_max)
        assert np.all(np.isfinite(state.q)) and np.all(np.isfinite(state.qdot))
        bad = ~np.all(np.isfinite(target), axis=1)
        assert np.all(braked[bad])


def test_arm_tracks_a_step_with_pd_and_pid():
    robot = arm.RavenArm()
    state = robot.rest(3)
    target = state.q.copy()
    target[:, 0] += np.array([0.02, 0.05, 0.1])
    target[:, 2] += 0.01
    for _ in range(2000):  # 2 s at 1 kHz
        state, tau, _ = robot.step(state, target)
    assert np.allclose(state.q[:, :3], target[:, :3], atol=1e-4)
    # a constant torque override (the paper's DAC fault) moves the joint away, within the limit
    faulty, hold = robot.rest(1), robot.rest(1).q
    for _ in range(300):
        faulty, tau, _ = robot.step(faulty, hold, tau_override=[[1e9, np.nan, np.nan]])
    assert tau[0, 0] == robot.p.tau_max[0] and faulty.q[0, 0] > robot.rest(1).q[0, 0] + 0.01
