"""The RCM paper's 7-DOF controller (studies/rcm/dynamics.py, rcm_cloud.py, rcm_demo.py), each claim
checked against something the kernel does not compute itself: a separately coded DH product,
rcm.rcm_error / rcm.barrier_force_axial, brute-force distances, the closed-form solution of (25)."""

import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.studies.rcm import kernel as rcm
from certiloop.studies.rcm.cloud import CloudBarrier
from certiloop.studies.rcm.demo import D_C, P_C, P_C_PAPER, TOOL_LENGTH, demo_controller
from certiloop.studies.rcm.dynamics import TABLE1, RcmAdmittance, mapping, variable_damping

RNG = np.random.default_rng(14)
NEAR_ANCHOR = [rcm.Q_ANCHOR + RNG.uniform(-0.4, 0.4, 7) for _ in range(12)]


# --------------------------------------------------------------------------- an independent DH product

def _rot_z(t):
    return np.array([[math.cos(t), -math.sin(t), 0, 0], [math.sin(t), math.cos(t), 0, 0], [0, 0, 1, 0],
                     [0, 0, 0, 1]])


def _rot_x(t):
    return np.array([[1, 0, 0, 0], [0, math.cos(t), -math.sin(t), 0], [0, math.sin(t), math.cos(t), 0],
                     [0, 0, 0, 1]])


def _trans_z(d):
    T = np.eye(4)
    T[2, 3] = d
    return T


def _flange_by_hand(q):
    """Standard DH as a product Rz(q) Tz(d) Rx(alpha) with the LWR4+ table typed in again."""
    table = [(0.31, 90), (0, -90), (0.40, -90), (0, 90), (0.39, 90), (0, -90), (0.078, 0)]
    T = np.eye(4)
    for qi, (d, alpha) in zip(q, table):
        T = T @ _rot_z(qi) @ _trans_z(d) @ _rot_x(math.radians(alpha))
    return T


def test_flange_anchor_against_an_independent_dh_product_and_the_paper():
    q = np.radians([20, 50, 0, -70, 0, 60, 0])
    T = _flange_by_hand(q)
    assert np.allclose(T[:3, 3], [-0.6053, -0.2203, 0.2941], atol=5e-5)    # the paper's number
    assert np.allclose(T[:3, 2], [0, 0, -1], atol=1e-12)
    for qq in [q, *NEAR_ANCHOR]:
        assert np.allclose(rcm.lwr4_forward(qq), _flange_by_hand(qq), atol=1e-12)
    # the demo's port is the paper's p_c to its printed precision, and exactly on the tool axis
    assert np.allclose(P_C, P_C_PAPER, atol=5e-5)
    assert np.linalg.norm(rcm.rcm_error(q, P_C, TOOL_LENGTH)) < 1e-12


# --------------------------------------------------------------------------- the mapping (15)-(21)

@pytest.mark.parametrize("q", NEAR_ANCHOR[:6])
def test_runtime_identities_of_the_null_space_mapping(q):
    m = mapping(q, P_C, TOOL_LENGTH)
    assert np.allclose(m.J, rcm.lwr4_jacobian(q, TOOL_LENGTH), atol=1e-12)
    assert np.allclose(m.A, rcm.rcm_constraint_jacobian(q, P_C, TOOL_LENGTH), atol=1e-12)
    assert np.allclose(m.x_c, rcm.rcm_error(q, P_C, TOOL_LENGTH), atol=1e-15)
    assert np.abs(m.A @ m.Z.T).max() < 1e-10                               # A Z^T = 0
    S = np.hstack([m.A_dag, m.Z.T])
    S_inv = np.vstack([m.A, m.Z_dag_T])
    assert np.abs(S_inv @ S - np.eye(7)).max() < 1e-9                      # (21)
    assert np.abs(m.Z @ m.J.T - np.vstack([m.Z_x, np.zeros((1, 6))])).max() < 1e-10   # Remark 3
    assert np.abs(m.Z[4] @ m.J.T).max() < 1e-10 and abs(np.linalg.norm(m.Z[4]) - 1) < 1e-12


def _no_cloud(q, **kw) -> RcmAdmittance:
    return RcmAdmittance(q, P_C, CloudBarrier(np.zeros((0, 3)), D_C), TOOL_LENGTH, **kw)


def test_constraint_error_follows_the_closed_form_of_25():
    """From rest off the RCM, x_c(t) = x_c(0) (1 + alpha t) e^{-alpha t} (alpha = beta), measured
    with rcm.rcm_error; the free push must not disturb it (decoupling)."""
    q0 = rcm.Q_ANCHOR + np.array([0.0, 0.004, 0.0, -0.003, 0.0, 0.0, 0.0])
    x0 = rcm.rcm_error(q0, P_C, TOOL_LENGTH)
    assert np.linalg.norm(x0) > 1e-3
    dt, alpha = 1e-4, TABLE1.alpha
    c = _no_cloud(q0, dt=dt, wrench=np.array([0.0, 0.0, -3.0, 0.1, 0.0, 0.0]), integrator="semi-implicit")
    worst = 0.0
    for i in range(1, 801):
        assert c.step().ok
        t = i * dt
        x = rcm.rcm_error(c.q, P_C, TOOL_LENGTH)
        worst = max(worst, np.linalg.norm(x - x0 * (1 + alpha * t) * math.exp(-alpha * t)))
    assert worst < 1e-2 * np.linalg.norm(x0)
    assert np.linalg.norm(rcm.rcm_error(c.q, P_C, TOOL_LENGTH)) < 0.45 * np.linalg.norm(x0)


def test_an_axial_push_moves_the_tip_along_the_tool_axis_only():
    """On S from rest, (27) gives x_f1'' = n.f and zero angular acceleration for f along n: after one
    explicit Euler step the tip twist J q' is dt (f, 0)."""
    c = _no_cloud(rcm.Q_ANCHOR)
    n = rcm.tool_tip(rcm.Q_ANCHOR, TOOL_LENGTH)[1]
    c.step(np.concatenate([4.0 * n, np.zeros(3)]))
    twist = rcm.lwr4_jacobian(rcm.Q_ANCHOR, TOOL_LENGTH) @ c.qdot
    assert np.allclose(twist, np.concatenate([c.dt * 4.0 * n, np.zeros(3)]), atol=1e-12)


# --------------------------------------------------------------------------- barrier and damping

def _potential(p, c, d_c, d0=TABLE1.d0, k=TABLE1.k):
    """(9)-(10) as printed (with V_i(p_t), the erratum)."""
    rho = np.linalg.norm(p - c)
    if rho >= d_c + d0:
        return 0.0
    psi = (rho - (d0 + d_c)) ** 2 / d0**2
    return 0.5 * k * math.log(1.0 / (1.0 - psi)) ** 2


@pytest.mark.parametrize("gap", [2e-4, 1e-3, 4e-3, 9e-3, 0.0114, 0.02])
def test_one_point_force_is_the_axial_law_and_minus_the_gradient_of_v(gap):
    c = np.array([0.1, -0.2, 0.3])
    u = np.array([2.0, -1.0, 2.0]) / 3.0
    p = c + (D_C + gap) * u
    f, g = CloudBarrier([c], D_C).tip(p)
    assert g == pytest.approx(min(gap, TABLE1.d0), abs=1e-15)
    assert np.allclose(f, rcm.barrier_force_axial(gap) * u, rtol=1e-12, atol=1e-15)
    h = 1e-8
    grad = [(_potential(p + h * e, c, D_C) - _potential(p - h * e, c, D_C)) / (2 * h) for e in np.eye(3)]
    assert np.allclose(f, -np.array(grad), rtol=1e-5, atol=1e-9)


def _segment_gap_brute(p, n, length, pts, dc):
    s = p - np.outer(np.linspace(0, length, 4001), n)
    return min(np.linalg.norm(pts - x, axis=1).min() for x in s) - dc


@pytest.mark.parametrize("seed", range(5))
def test_kd_tree_matches_brute_force_for_tip_and_capsule(seed):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-0.05, 0.05, (800, 3))
    p = rng.uniform(-0.02, 0.02, 3)
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    bar = CloudBarrier(pts, 0.002, radius=0.003)
    f, gap = bar.tip(p)
    rho = np.linalg.norm(pts - p, axis=1)
    brute = sum(rcm.barrier_force_axial(r - 0.002) * (p - q) / r
                for r, q in zip(rho, pts) if r - 0.002 < TABLE1.d0)
    if gap > 0:
        assert np.allclose(f, brute, rtol=1e-10, atol=1e-12)
    assert gap == pytest.approx(min(rho.min() - 0.002, TABLE1.d0), abs=1e-15)
    F, cgap = bar.capsule(p, n, 0.08)
    exact = _segment_gap_brute(p, n, 0.08, pts, 0.005)
    assert cgap <= min(exact, TABLE1.d0) + 1e-12          # a lower bound, never more
    assert cgap >= min(exact, TABLE1.d0) - 1e-5           # and tight (brute force samples 20 um)
    assert np.all(np.isfinite(F))


@given(st.lists(st.floats(-10, 10), min_size=5, max_size=5), st.lists(st.floats(-500, 500), min_size=4,
                                                                       max_size=4))
@settings(max_examples=60, deadline=None)
def test_variable_damping_stays_in_the_paper_bounds(xf, frx):
    D = variable_damping(np.array(xf), np.array(frx))
    lo = np.array(TABLE1.d_const)
    hi = lo + np.array(TABLE1.q_gain) + np.array(TABLE1.g_gain)
    assert np.all(D >= lo - 1e-12) and np.all(D <= hi + 1e-12)
    assert np.allclose(variable_damping(np.zeros(5), np.zeros(4)), lo + np.array(TABLE1.q_gain))


# --------------------------------------------------------------------------- reproductions

def _tip_clearance(q, cloud, dc):
    return np.linalg.norm(cloud - rcm.tool_tip(q, TOOL_LENGTH)[0], axis=1).min() - dc


def test_fig8_rcm_error_is_about_a_micrometre_at_4ms():
    """Guidance for 5 s under a smooth human wrench (|f| <= 3 N): max ||x_c|| by rcm.rcm_error is of
    the order of the paper's 1e-6 m (the backward-difference A' error, O(dt))."""
    c = demo_controller(points=625, gap=0.05)
    worst = 0.0
    for i in range(1250):
        t = i * c.dt
        w = [2 * math.sin(0.5 * t), 1.5 * math.sin(0.7 * t + 1), -math.sin(0.3 * t), 0.1 * math.sin(0.9 * t),
             0.1 * math.cos(0.6 * t), 0.05 * math.sin(t)]
        assert c.step(w).ok
        worst = max(worst, np.linalg.norm(rcm.rcm_error(c.q, P_C, TOOL_LENGTH)))
    assert 1e-7 <= worst <= 1e-5
    assert np.linalg.norm(c.q - rcm.Q_ANCHOR) > 0.05          # it really moved


def test_fig8_error_shrinks_with_the_period():
    """The backward-difference error is O(dt): at 1 ms the worst ||x_c|| over the same 2 s is smaller."""
    worst = {}
    for dt in (0.004, 0.001):
        c = demo_controller(points=100, gap=0.05, dt=dt)
        xs = []
        for i in range(int(round(2.0 / dt))):
            assert c.step([2.0 * math.sin(3 * i * dt), 1.0, -1.0, 0.1, 0.0, 0.0]).ok
            xs.append(np.linalg.norm(rcm.rcm_error(c.q, P_C, TOOL_LENGTH)))
        worst[dt] = max(xs)
    assert worst[0.001] < 0.5 * worst[0.004]


@pytest.mark.parametrize("seed", range(4))
def test_the_guard_sweep_bound_covers_every_tool_point(seed):
    """sum_j |dq_j| L_j (the guard's lever bound) is at least how far any tool point moves along a
    linearly interpolated joint step, measured here on a fine path."""
    rng = np.random.default_rng(seed)
    c = _no_cloud(rcm.Q_ANCHOR)
    for _ in range(20):
        q = rcm.Q_ANCHOR + rng.uniform(-0.5, 0.5, 7)
        dq = rng.normal(size=7) * rng.uniform(1e-4, 0.05)
        bound = np.abs(dq) @ c.lever
        start = rcm.lwr4_forward(q)
        for sigma in (0.0, 0.5, 1.0):
            p0 = start[:3, 3] + sigma * TOOL_LENGTH * start[:3, 2]
            for s in np.linspace(0, 1, 21)[1:]:
                T = rcm.lwr4_forward(q + s * dq)
                assert np.linalg.norm(T[:3, 3] + sigma * TOOL_LENGTH * T[:3, 2] - p0) <= bound + 1e-15


PUSHES = [(0.03, 12.0), (0.015, 8.0), (0.015, 30.0), (0.03, 30.0)]


@pytest.mark.parametrize("gap,push", PUSHES)
def test_the_paper_euler_enters_the_cloud_and_the_guard_prevents_it(gap, push):
    wrench = np.array([0.0, 0.0, -push, 0.0, 0.0, 0.0])
    free = demo_controller(points=625, gap=gap, guard=False)
    cloud = free.barrier.points
    entered = None
    for i in range(250):
        q_before = free.q.copy()
        if not free.step(wrench).ok:
            entered = i
            break
    assert entered is not None and free.penetrated
    assert _tip_clearance(q_before, cloud, D_C) < 0 or _tip_clearance(free.q, cloud, D_C) < 0
    guarded = demo_controller(points=625, gap=gap, guard=True)
    for _ in range(250):
        q0 = guarded.q.copy()
        r = guarded.step(wrench)
        assert r.ok, r.reason
        # the whole inter-sample path (linear joint interpolation), not just the samples
        for s in np.linspace(0, 1, 6):
            assert _tip_clearance(q0 + s * (guarded.q - q0), cloud, D_C) >= guarded.margin - 1e-12


def test_semi_implicit_euler_resists_a_push_the_paper_euler_does_not():
    wrench = np.array([0.0, 0.0, -8.0, 0.0, 0.0, 0.0])
    out = {}
    for integ in ("euler", "semi-implicit"):
        c = demo_controller(points=625, gap=0.015, guard=False, integrator=integ)
        out[integ] = all(c.step(wrench).ok for _ in range(250))
    assert out == {"euler": False, "semi-implicit": True}


def _segment_gap_exact(p, n, length, pts, dc):
    """Point-to-segment distance by the textbook clamp, minimised over the cloud."""
    a, b = p, p - length * n
    t = np.clip((pts - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(pts - (a + np.outer(t, b - a)), axis=1).min() - dc


def test_the_capsule_guard_keeps_the_whole_tool_out():
    c = demo_controller(points=625, gap=0.015, mode="tool", guard=True)
    cloud, dc = c.barrier.points, D_C + c.barrier.radius
    for _ in range(200):
        q0 = c.q.copy()
        r = c.step([3.0, 0.0, -30.0, 0.0, 0.5, 0.0])
        assert r.ok, r.reason
        for s in np.linspace(0, 1, 4):
            p, n, _, _ = rcm.tool_tip(q0 + s * (c.q - q0), TOOL_LENGTH)
            assert _segment_gap_exact(p, n, TOOL_LENGTH, cloud, dc) >= c.margin - 1e-12


# --------------------------------------------------------------------------- never NaN, never unsafe

WRENCH = st.lists(st.one_of(st.floats(-300, 300), st.sampled_from([math.nan, math.inf, -math.inf, 1e300])),
                  min_size=6, max_size=6)


@given(st.sampled_from(["tip", "tool"]), st.sampled_from(["euler", "semi-implicit"]),
       st.lists(WRENCH, min_size=1, max_size=25))
@settings(max_examples=40, deadline=None)
def test_step_never_returns_nan_and_never_an_unsafe_command(mode, integ, wrenches):
    c = demo_controller(points=200, gap=0.004, mode=mode, integrator=integ)
    cloud = c.barrier.points
    for w in wrenches:
        q0 = c.q.copy()
        r = c.step(w)
        assert np.all(np.isfinite(r.q)) and np.all(np.isfinite(r.qdot)) and np.all(np.isfinite(r.x_c))
        assert math.isfinite(r.gap) and 0.0 <= r.scale <= 1.0
        if not np.all(np.isfinite(w)):
            assert not r.ok and np.array_equal(r.q, q0) and not r.qdot.any()
        assert _tip_clearance(r.q, cloud, D_C) > 0


def test_bad_input_gives_clear_errors_or_a_hold():
    with pytest.raises(ValueError, match="points"):
        demo_controller(points=-3)
    with pytest.raises(ValueError, match="mode"):
        demo_controller(points=10, mode="shaft")
    with pytest.raises(ValueError, match="finite"):
        CloudBarrier([[0, 0, math.nan]], 0.0035)
    c = demo_controller(points=10)
    r = c.step("not a wrench")
    assert not r.ok and "malformed" in r.reason


def test_a_robot_that_does_not_track_gives_a_hold():
    c = demo_controller(points=10)
    assert c.step([0, 0, -2.0, 0, 0, 0], q_measured=c.q + 1e-3).ok
    for bad in (c.q + np.array([0, 0, 0.02, 0, 0, 0, 0]), np.full(7, math.nan)):
        q0 = c.q.copy()
        r = c.step([0, 0, -2.0, 0, 0, 0], q_measured=bad)
        assert not r.ok and "tracking" in r.reason and np.array_equal(r.q, q0) and not r.qdot.any()
    assert "malformed" in c.step(q_measured=[1, 2]).reason


def test_demo_controller_is_exported_from_rcm_and_step_is_one_period():
    c = rcm.demo_controller(points=100)
    assert isinstance(c, rcm.RcmAdmittance) and c.dt == 0.004 and len(c.barrier.points) == 100
    r = c.step()
    assert r.ok and r.scale == 1.0


def test_the_controller_imports_no_prover_or_test_library():
    code = ("import sys, certiloop.studies.rcm.kernel as r; r.demo_controller(points=10).step(); "
            "print(sorted(m for m in ('z3', 'sympy', 'hypothesis', 'cvxpy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
