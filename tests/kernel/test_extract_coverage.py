"""Extraction coverage (issue 19, item 4): every proved library model either extracts to code
that runs and agrees with the model's interpreter, or is refused with a one-line reason that
this file lists, so that a model moving from one list to the other is a visible change.

The conformance oracle is as in tests/kernel/test_extract.py: the model's control step run by the
interpreter (first enabled alternative, as the kernel), on states built inside each model's
assumptions, hand-picked edges plus seeded random ones; also values by hand where they are
short. The models already covered there (sbs.*, cfmpa.builtdr, textbook.*) are not repeated.
"""

import math
from fractions import Fraction

import numpy as np
import pytest

from certiloop.kernel.extract import ExtractError, extract
from certiloop.models import library
from kernel.test_extract import PROVED as CHECKED_IN_TEST_EXTRACT
from kernel.test_extract import Known, agree, call, check_scalar, run_step, step_theorem

# model -> why it is not extracted (a substring of the one-line refusal)
REFUSED = {
    "rcm.constraint_set_invariant": "not a control loop",  # a lone ODE: no control step
    "rcm.constraint_exponential": "not a control loop",  # a lone ODE: no control step
    "rcm.constraint_euler_4ms": "repeats any number of times",  # the plant's Euler map, no decision
    "rcm.barrier_clearance": "computes nothing",  # `?true`: an arithmetic fact, no step
    "rcm.constraint_euler_lyapunov": "repeats any number of times",  # the plant's Euler map
    "rcm.passivity_step_midpoint": "repeats any number of times",  # one plant period, no decision
    "rcm.cloud_cover": "computes nothing",  # draws a voxel point: an arithmetic fact, no step
    "raven.jump_detected": "2 plant ODEs",  # a fault (jump) between two flows
    # the dual-arm paper lemmas whose program only draws witnesses (no result) or repeats a motion step
    "cfmpa.hull_in_halfplane": "repeats any number of times",  # hull points drawn in a loop
    "cfmpa.sat_separates": "repeats any number of times",
    "cfmpa.property3": "computes nothing",
    "cfmpa.property4": "computes nothing",
    "cfmpa.searchoptpath": "inside a choice",  # `Li := *` (the search's result) drawn in a choice
    "cfmpa.execution": "a loop with no exit test",  # the execution of a plan, step after step
    "cfmpa.execution_original": "a loop with no exit test",
    "cfmpa.original_backward_half_unreachable": "a loop with no exit test",
}
EXTRACTS = [*dict.fromkeys([*CHECKED_IN_TEST_EXTRACT, "rcm.nullspace", "rcm.decoupling", "rcm.damping_bounds",
            "rcm.barrier_continuous", "rcm.axial_guard", "rcm.passivity", "rcm.capsule_continuous",
            "rcm.capsule_nearest_point", "raven.deviation_stop", "raven.deviation_stop_3d",
            "raven.haptic_force", "cfmpa.builtdr_inclusive", "cfmpa.property8", "cfmpa.halfspace_convex",
            "cfmpa.arc_in_triangle", "cfmpa.check_path", "cfmpa.segment_modified_full_speed",
            "cfmpa.joint_box_monotone", "textbook.adaptive_cruise"])]

rng = np.random.default_rng(19)


def proved_models() -> list[str]:
    return [n for n in library.names() if library.get(n).expected == "proved"]


def test_every_proved_model_is_classified():
    assert set(proved_models()) == set(EXTRACTS) | set(REFUSED), \
        "a proved model is neither extracted (EXTRACTS) nor listed with its refusal (REFUSED)"
    assert not set(EXTRACTS) & set(REFUSED)


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_refused_with_a_one_line_reason(name):
    with pytest.raises(ExtractError) as info:
        extract(library.get(name))
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{name}: ")
    assert REFUSED[name] in message


@pytest.mark.parametrize("name", EXTRACTS)
def test_extracts_and_runs(name):
    ns: dict = {}
    exec(compile(extract(library.get(name)), f"<extracted {name}>", "exec"), ns)
    assert callable(ns["controller"]) and ns["MODEL"] == name


# ------------------------------------------------------------------ rcm


def _orthogonal(n):
    v = rng.normal(size=3)
    return v - (v @ n) / (n @ n) * n


def test_rcm_nullspace():
    for _ in range(40):
        n = rng.normal(size=3)
        a, o, r = _orthogonal(n), _orthogonal(n), rng.normal(size=3)
        state = {f"{s}{i + 1}": float(x[i]) for s, x in (("a", a), ("o", o), ("n", n), ("r", r))
                 for i in range(3)}
        outs = ["AZ11", "AZ12", "AZ13", "AZ14", "AZ21", "AZ22", "AZ23", "AZ24"]
        values, enabled = check_scalar("rcm.nullspace", state, outs)
        assert enabled and all(abs(v) < 1e-9 for v in values)  # by hand: the guarantee, A_x Z_x^T = 0


def test_rcm_decoupling():
    for _ in range(40):
        W1, W2 = rng.uniform(0.1, 5, 2)
        A1, A2 = rng.normal(size=2)
        Z1, Z2 = -A2, A1  # A·Z = 0
        state = {"A1": A1, "A2": A2, "W1": W1, "W2": W2, "Z1": Z1, "Z2": Z2}
        (Ad1, Ad2, Zd1, Zd2, which), enabled = check_scalar("rcm.decoupling", state,
                                                             ["Ad1", "Ad2", "Zd1", "Zd2", "which"])
        assert which == 0 and agree(A1 * Ad1 + A2 * Ad2, 1.0) and agree(Z1 * Zd1 + Z2 * Zd2, 1.0)


def test_rcm_damping_bounds():
    for ev1, er1, ev2, er2 in [(1.0, 1.0, 1.0, 1.0), (1e-9, 1e-9, 0.5, 0.5), *rng.uniform(1e-6, 1, (30, 4))]:
        state = {"ev1": ev1, "er1": er1, "ev2": ev2, "er2": er2}
        (Df1, Df2), _ = check_scalar("rcm.damping_bounds", state, ["Df1", "Df2"])
        assert agree(Df1, 10 + 25 * ev1 + 60 * (1 - er1)) and 10 <= Df1 <= 95 and 4 <= Df2 <= 54
    # outside (0, 1]: the model has no run, the code says so
    for bad in [0.0, -0.5, 1.5]:
        state = {"ev1": bad, "er1": 0.5, "ev2": 0.5, "er2": 0.5}
        assert call("rcm.damping_bounds", state)[-1] is False
        assert run_step(step_theorem("rcm.damping_bounds"), state) is None


def test_rcm_barrier_continuous_admits_non_negative_damping():
    for dmp in [0.0, 1e-300, 3.0]:
        (got,), enabled = check_scalar("rcm.barrier_continuous", {"dmp": dmp}, ["dmp"])
        assert (got, enabled) == (dmp, True)
    for dmp in [-1e-300, -2.0]:
        assert call("rcm.barrier_continuous", {"dmp": dmp})[-1] is False
        assert run_step(step_theorem("rcm.barrier_continuous"), {"dmp": dmp}) is None


def test_rcm_axial_guard_limits_the_command():
    for _ in range(60):
        m, eps = rng.uniform(0.001, 0.01), rng.uniform(0.001, 0.1)
        gap = m + rng.choice([0.0, rng.uniform(0, 0.02)])
        wcmd = rng.choice([0.0, rng.uniform(-1, 1), (gap - m) / eps])
        state = {"gap": gap, "m": m, "eps": eps, "wcmd": wcmd}
        (w,), _ = check_scalar("rcm.axial_guard", state, ["wcmd"])
        # by hand, in the reals: the code returns the largest float <= the model's value
        F = Fraction
        want = F(wcmd) if F(eps) * F(wcmd) <= F(gap) - F(m) else (F(gap) - F(m)) / F(eps)
        assert F(w) <= want < F(math.nextafter(w, math.inf))
        assert gap - eps * w >= m - 1e-12  # the margin holds after one period


def test_rcm_capsule_nearest_point_is_the_nearest_tool_point():
    grid = np.linspace(0.0, 1.0, 2001)
    for _ in range(60):
        a, b, c = rng.uniform(-0.1, 0.1, (3, 3))
        state = {f"{n}{i + 1}": float(v[i]) for n, v in (("pa", a), ("pb", b), ("pc", c)) for i in range(3)}
        state["tau"] = float(rng.uniform(0, 1))
        (num, den, sigma), enabled = check_scalar("rcm.capsule_nearest_point", state, ["num", "den", "sigma"])
        assert enabled and 0.0 <= sigma <= 1.0
        # independent: no point of a dense sample of the segment is nearer (by hand, numpy)
        dist = np.linalg.norm(a + np.outer(grid, b - a) - c, axis=1)
        assert np.linalg.norm(a + sigma * (b - a) - c) <= dist.min() + 1e-12


# ------------------------------------------------------------------ raven


def test_raven_deviation_stop():
    seen = set()
    for _ in range(120):
        tol, U, eps = rng.uniform(1e-3, 5e-3), rng.uniform(0, 0.05), rng.uniform(1e-3, 0.02)
        m = tol + U * eps + rng.choice([0.0, rng.uniform(0, 0.01)])
        dm = m + rng.choice([0.0, rng.uniform(0, 0.02)])
        dr = max(0.0, dm + rng.choice([0.0, rng.uniform(-2 * tol, 2 * tol)]))
        stopped = float(rng.choice([0.0, 1.0], p=[0.8, 0.2]))
        u, v = rng.uniform(-U, U), rng.uniform(-1, 1)
        state = {"tol": tol, "U": U, "eps": eps, "m": m, "dm": dm, "dr": dr, "stopped": stopped,
                 "u": u, "v": v}
        (v_out, u_out, stop_out), _ = check_scalar("raven.deviation_stop", state, ["v", "u", "stopped"],
                                                   chooser=Known({"u": u, "v": v}))
        deviates = stopped == 1 or abs(dr - dm) > tol
        assert (v_out, u_out, stop_out) == ((0.0, 0.0, 1.0) if deviates else (0.0, -U, stopped))  # by hand
        seen.add(deviates)
    assert seen == {True, False}


def _haptic_known(state):
    n2 = state["dpx"] ** 2 + state["dpy"] ** 2 + state["dpz"] ** 2
    nv2 = state["dvx"] ** 2 + state["dvy"] ** 2 + state["dvz"] ** 2
    return Known({"nrm": math.sqrt(n2), "nv": math.sqrt(nv2)})  # the interpreter solves linear pins only


def test_raven_haptic_force():
    outs = ["n2", "dx", "dy", "dz", "F"]
    forces = set()
    for _ in range(80):
        tol = rng.uniform(1e-3, 5e-3)
        dp = rng.normal(size=3) * rng.choice([tol / 4, 3 * tol])
        dv = rng.normal(size=3) * rng.choice([0.0, 0.01])
        state = {"tol": tol, "Kp": rng.uniform(0, 500), "Kd": rng.uniform(0, 10), "Fsat": rng.uniform(0.5, 3),
                 **{f"dp{x}": dp[i] for i, x in enumerate("xyz")},
                 **{f"dv{x}": dv[i] for i, x in enumerate("xyz")}}
        (n2, dx, dy, dz, F), _ = check_scalar("raven.haptic_force", state, outs, chooser=_haptic_known(state))
        if n2 > tol**2:  # by hand: eq 5-6, saturated spring-damper along dp
            spring = state["Kp"] * math.sqrt(n2) + state["Kd"] * np.linalg.norm(dv)
            assert agree(F, min(spring, state["Fsat"])) and agree(dx * dx + dy * dy + dz * dz, 1.0)
            forces.add("saturated" if spring > state["Fsat"] else "spring")
        else:
            assert (F, dx, dy, dz) == (0.0, 0.0, 0.0, 0.0)
            forces.add("off")
    assert forces == {"off", "spring", "saturated"}


def stop_3d_scene(m: int):
    """A state of raven.deviation_stop_3d inside its assumptions (m planes): the scalars and the
    families as numpy arrays (for the code) and as Tables with the universe (the interpreter)."""
    from certiloop.falsify.evaluate import Table

    tol, U, eps = rng.uniform(1e-3, 5e-3), rng.uniform(0, 0.05), rng.uniform(1e-3, 0.02)
    margin = tol + U * eps
    pm = rng.uniform(-0.05, 0.05, 3)
    normals = [v / np.linalg.norm(v) for v in rng.normal(size=(m, 3))]
    points = [pm - (margin + rng.choice([0.0, rng.uniform(0, 0.01)]) + 1e-12) * n for n in normals]
    pr = pm + rng.normal(size=3) * rng.choice([tol / 4, 2 * tol])
    if any((pr - r) @ n < 0 for r, n in zip(points, normals)):
        pr = pm.copy()  # the assumptions: the robot tip on the model's tip or on every plane's safe side
    u = rng.normal(size=3)
    u *= rng.uniform(0, U) / np.linalg.norm(u)
    v = rng.normal(size=3) * rng.choice([0.0, 0.01, 1.0])
    scalars = {"tol": tol, "U": U, "eps": eps, "stopped": float(rng.choice([0.0, 1.0], p=[0.8, 0.2])),
               **{f"{name}{x}": vec[a] for name, vec in (("pm", pm), ("pr", pr), ("u", u), ("v", v))
                  for a, x in enumerate("xyz")}}
    arrays = {f"{f}{x}": np.array([float(p[a]) for p in pts]) for f, pts in (("r", points), ("n", normals))
              for a, x in enumerate("xyz")}
    tables = {k: Table({(j,): float(x) for j, x in enumerate(arr)}) for k, arr in arrays.items()}
    return {**scalars, **arrays}, {**scalars, **tables, "#universe:B": range(m)}


def test_raven_deviation_stop_3d():
    """First enabled: stop on a deviation above tol, else the fault at its given value (the
    model's only fault alternative) with the operator's velocity, where it keeps every plane's
    margin for the period; the interpreter agrees, families of 0 to 4 planes."""
    name = "raven.deviation_stop_3d"
    outs = ["vx", "vy", "vz", "ux", "uy", "uz", "stopped"]
    outcomes = set()
    for trial in range(60):
        values, state = stop_3d_scene(trial % 5)
        known = Known({k: values[k] for k in outs[:6]})
        final = run_step(step_theorem(name), state, known)
        *got, enabled = call(name, values)
        assert enabled == (final is not None)
        if final is None:
            outcomes.add("no run")
            continue
        assert all(agree(g, float(final[o])) for g, o in zip(got, outs)), (got, final)
        deviation = sum((values[f"pr{x}"] - values[f"pm{x}"]) ** 2 for x in "xyz")
        outcomes.add("stop" if got[-1] == 1.0 and (values["stopped"] == 1 or deviation > values["tol"] ** 2)
                     else "follow")
    assert outcomes == {"stop", "follow", "no run"}


# ------------------------------------------------------------------ cfmpa (the dual-arm paper)


@pytest.mark.parametrize("name, inputs, outputs", [
    ("cfmpa.halfspace_convex", ["t", "x1", "y1", "x2", "y2"], ["z1", "z2"]),
    ("cfmpa.arc_in_triangle", ["u", "ua"], ["cs", "sn"]),
    ("cfmpa.segment_modified_full_speed", ["sg1", "w1", "sg2", "w2", "lam", "b1", "dt", "b2"], ["p1", "p2"]),
])
def test_cfmpa_scalar_steps_agree_with_the_model(name, inputs, outputs):
    runs = 0
    for k in range(60):
        state = {v: float(x) for v, x in zip(inputs, rng.uniform(-1.5, 1.5, len(inputs)))}
        if k % 3 == 0:  # also states on the edges of the models' tests
            state = {v: float(round(x * 2) / 2) for v, x in state.items()}
        values, enabled = check_scalar(name, state, outputs)
        runs += bool(enabled)
    assert runs > 0  # some states are inside the step's tests
