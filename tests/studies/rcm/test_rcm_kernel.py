"""The RCM paper's kernel (certiloop.studies.rcm.kernel): kinematics, null space, the paper's 4 ms
crossing with the exact barrier, and the proved guard against its model."""

import ast
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models import library
from certiloop.models.lang.programs import Choice, Loop, Seq, Test
from certiloop.proofs.core.exact import evaluate
from certiloop.studies.rcm import kernel as k

RNG = np.random.default_rng(20261123)
RANDOM_Q = [RNG.uniform(-2.0, 2.0, 7) for _ in range(20)]


# --------------------------------------------------------------------------- kinematics

def test_flange_anchor_of_the_paper():
    """At q_d(0) the flange is at (-0.6053, -0.2203, 0.2941) m with the tool pointing down,
    so the paper's p_c = (-0.6053, -0.2203, 0) lies on the tool axis."""
    T = k.lwr4_forward(k.Q_ANCHOR)
    assert np.allclose(T[:3, 3], [-0.6053, -0.2203, 0.2941], atol=5e-5)
    assert np.allclose(T[:3, 2], [0, 0, -1], atol=1e-12)
    assert np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-12)
    x_c = k.rcm_error(k.Q_ANCHOR, [-0.6053, -0.2203, 0.0], tool_length=0.43)
    assert np.linalg.norm(x_c) < 1e-4


@pytest.mark.parametrize("tool_length", [0.0, 0.43])
def test_jacobian_matches_finite_differences_of_the_forward_kinematics(tool_length):
    eps = 1e-6
    for q in RANDOM_Q:
        J = k.lwr4_jacobian(q, tool_length)
        for i in range(7):
            dq = np.zeros(7)
            dq[i] = eps
            Tp, Tm = k.lwr4_forward(q + dq), k.lwr4_forward(q - dq)
            pp = Tp[:3, 3] + tool_length * Tp[:3, 2]
            pm = Tm[:3, 3] + tool_length * Tm[:3, 2]
            assert np.allclose((pp - pm) / (2 * eps), J[:3, i], atol=1e-7)
            # angular velocity: the skew part of R' R^T
            Rdot = (Tp[:3, :3] - Tm[:3, :3]) / (2 * eps)
            S = Rdot @ k.lwr4_forward(q)[:3, :3].T
            omega = np.array([S[2, 1], S[0, 2], S[1, 0]])
            assert np.allclose(omega, J[3:, i], atol=1e-7)


def test_rcm_constraint_jacobian_is_the_derivative_of_the_rcm_error():
    p_c = np.array([-0.6053, -0.2203, 0.0])
    eps = 1e-6
    for q in RANDOM_Q[:8]:
        A = k.rcm_constraint_jacobian(q, p_c, 0.43)
        num = np.column_stack([(k.rcm_error(q + eps * e, p_c, 0.43) - k.rcm_error(q - eps * e, p_c, 0.43))
                               / (2 * eps) for e in np.eye(7)])
        assert np.allclose(A, num, atol=1e-6)


@pytest.mark.parametrize("weighted", [False, True])
def test_null_space_projector_is_idempotent_and_annihilated(weighted):
    p_c = np.array([-0.6053, -0.2203, 0.0])
    W = 1.5 * np.eye(7) if weighted else None
    for q in RANDOM_Q:
        A = k.rcm_constraint_jacobian(q, p_c, 0.43)
        N = k.null_projector(A, W)
        assert np.allclose(A @ N, 0, atol=1e-10)
        assert np.allclose(N @ N, N, atol=1e-10)
        assert np.linalg.matrix_rank(N, tol=1e-8) == 5
        J = k.lwr4_jacobian(q)
        NJ = k.null_projector(J)
        assert np.allclose(J @ NJ, 0, atol=1e-10) and np.allclose(NJ @ NJ, NJ, atol=1e-10)


# --------------------------------------------------------------------------- the paper's 4 ms step

def _push(force, gap0, steps=3000, margin=None):
    gap, w, path = gap0, 0.0, []
    for n in range(1, steps + 1):
        if margin is None:
            gap, w = k.axial_euler_step(gap, w, force)
        else:
            gap, w = k.guarded_axial_step(gap, w, force, margin)
        path.append((n, gap, w))
        if gap <= 0:
            break
    return path


def test_a_steady_5N_push_drives_the_exact_euler_loop_into_the_ball():
    path = _push(5.0, 0.030)
    n, gap, _ = path[-1]
    assert gap < 0 and n == 35 and 0.7e-3 < -gap < 0.8e-3
    # it passes the state rcm.axial_euler_4ms starts from (3.3 mm, 0.355 m/s), or closer/faster
    assert any(g <= 0.0033 + 2e-4 and w >= 0.35 for _, g, w in path)
    # and where it enters the band it moves at about 0.32 m/s
    entry = next(w for _, g, w in path if g < k.D0)
    assert 0.30 < entry < 0.34


def test_in_continuous_time_the_same_push_does_not_enter():
    """A fine step (20 us) approximates the continuous flow: no entry, as claim 4 says."""
    gap, w = 0.030, 0.0
    h = 2e-5
    for _ in range(int(1.0 / h)):
        gap, w = k.axial_euler_step(gap, w, 5.0, h)
        assert gap > 0
    assert gap < k.D0


@pytest.mark.parametrize("force", [3.0, 5.0, 15.0, 30.0])
def test_the_guard_keeps_the_exact_euler_loop_out(force):
    margin = 2e-4
    path = _push(force, 0.030, steps=1500, margin=margin)
    assert all(g >= margin - 1e-15 for _, g, _ in path)
    assert all(math.isfinite(w) for _, _, w in path)


# --------------------------------------------------------------------------- guard = model

GUARD = library.get("rcm.axial_guard")


def _model_guard_test():
    """The test of the model's first control branch ("command keeps the margin")."""
    body = GUARD.program
    assert isinstance(body, Loop)
    control = next(p for p in body.body.parts if isinstance(p, Choice))
    first = control.alternatives[0]
    first = first.parts[0] if isinstance(first, Seq) else first
    assert isinstance(first, Test) and control.labels[0] == "command keeps the margin"
    return first.cond


KEEP = _model_guard_test()
small = st.fractions(min_value=-1, max_value=1, max_denominator=1000)
positive = st.fractions(min_value=Fraction(1, 1000), max_value=1, max_denominator=1000)


@settings(max_examples=300, deadline=None)
@given(s=positive, w=small, m=positive, eps=positive)
def test_guard_decision_agrees_with_the_proved_model(s, w, m, eps):
    if s < m:
        s = s + m  # the model's premise: the gap is at least the margin
    keep = evaluate(KEEP, {"gap": s, "wcmd": w, "m": m, "eps": eps})
    out = k.guard_speed(float(s), float(w), float(m), float(eps))
    if keep:  # (on the boundary eps*w = gap - m the branches command the same speed)
        assert out == pytest.approx(float(w), rel=1e-12, abs=1e-15)
    else:  # the model's other branch: wcmd := (gap - m)/eps
        assert out == pytest.approx(float((s - m) / eps), rel=1e-12, abs=1e-15)
    assert float(s) - float(eps) * out >= float(m) - 1e-12


def test_guard_names_match_the_model():
    names = set(GUARD.program.symbols())
    assert {"gap", "wcmd", "m", "eps"} <= names


# --------------------------------------------------------------------------- never NaN

finite = st.floats(-1e3, 1e3, allow_nan=False)
anything = st.one_of(finite, st.just(math.nan), st.just(math.inf), st.just(-math.inf))


@settings(max_examples=300, deadline=None)
@given(p=st.lists(anything, min_size=3, max_size=3), v=st.lists(anything, min_size=3, max_size=3),
       c=st.lists(anything, min_size=3, max_size=9), d_c=anything, m=anything)
def test_guarded_velocity_is_never_nan_and_zero_on_bad_input(p, v, c, d_c, m):
    c = c[: len(c) // 3 * 3]
    cmd = k.guarded_tip_velocity(p, v, np.reshape(c, (-1, 3)), d_c, m)
    assert np.all(np.isfinite(cmd.velocity)) and 0.0 <= cmd.scale <= 1.0
    bad = not all(math.isfinite(x) for x in (*p, *v, *c, d_c, m))
    if bad:
        assert not cmd.ok and np.all(cmd.velocity == 0)


@settings(max_examples=200, deadline=None)
@given(p=st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3),
       v=st.lists(st.floats(-2, 2), min_size=3, max_size=3),
       pts=st.lists(st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3), min_size=1, max_size=30),
       t=st.floats(0, 1))
def test_guarded_velocity_keeps_every_gap_above_the_margin_for_the_period(p, v, pts, t):
    d_c, m, h = 0.0035, 2e-4, k.H
    cmd = k.guarded_tip_velocity(p, v, pts, d_c, m, h)
    if not cmd.ok:
        assert np.all(cmd.velocity == 0)
        return
    at = np.asarray(p) + cmd.velocity * (t * h)
    gaps = np.linalg.norm(np.asarray(pts) - at, axis=1) - d_c
    assert gaps.min() >= m - 1e-12


@settings(max_examples=200, deadline=None)
@given(g=anything, w=anything, f=anything, m=anything)
def test_guard_speed_and_guarded_step_never_nan(g, w, f, m):
    out = k.guard_speed(g, w, m)
    assert math.isfinite(out)
    if not all(math.isfinite(x) for x in (g, w, m)):
        assert out == 0.0
    gap, speed = k.guarded_axial_step(g, w, f, m)
    assert math.isfinite(speed)


def test_the_kernel_imports_no_prover_or_test_library():
    from certiloop.studies.rcm import arm as rcm_arm  # the kernel itself (kernel.rcm re-exports it)

    tree = ast.parse(Path(rcm_arm.__file__).read_text())
    mods = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    mods |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert not mods & {"z3", "sympy", "hypothesis", "scipy"}, mods
    ours = {n.module for n in ast.walk(tree)
            if isinstance(n, ast.ImportFrom) and (n.module or "").startswith("certiloop")}
    # the extracted guard, and the library for its hash check (once, off the hot path)
    assert ours <= {"certiloop.kernel", "certiloop.models", "certiloop.studies.rcm.generated"}, ours
