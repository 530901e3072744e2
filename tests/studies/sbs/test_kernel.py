"""The runtime kernel: extraction, conformance with the model, closed-loop safety, monitor."""

import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.falsify.choosers import FirstEnabled
from certiloop.falsify.evaluate import Blocked, Table
from certiloop.falsify.interpreter import Interpreter
from certiloop.kernel.extract import ExtractError, controller, extract, shipped_drift
from certiloop.models import library
from certiloop.models.lang.terms import TRUE
from certiloop.models.lang.theorem import Theorem
from certiloop.studies.sbs import native
from certiloop.studies.sbs.fixture import VirtualFixture
from certiloop.studies.sbs.generated import ctrl2

CTRL2 = library.get("sbs.ctrl2")
# The kernel takes the real model's decisions (kernel/extract/certified.py) and returns its
# gain rounded down, within a relative 2^-20 (usually a few ulps): the oracle is the model's
# step run by the interpreter in exact rationals on the same inputs.
REL, ABS = 1e-6, 1e-300


@pytest.fixture(scope="module", autouse=True, params=["default", "python"])
def kernel_backend(request):
    """Every test here runs on both back ends of VirtualFixture.step: the default (the compiled
    C, where it builds; see test_kernel_native) and the numpy path alone."""
    with pytest.MonkeyPatch.context() as mp:
        if request.param == "python":
            mp.setenv("CERTILOOP_KERNEL", "python")
            mp.setattr(native, "_state", {})
        yield request.param


def test_shipped_kernel_is_a_fresh_extraction_of_the_model():
    assert shipped_drift("sbs.ctrl2") == ""
    assert (ctrl2.MODEL, ctrl2.MODEL_HASH) == ("sbs.ctrl2", CTRL2.content_hash)


def test_the_kernel_imports_no_prover_or_test_library():
    code = ("import sys, certiloop.studies.sbs.fixture as k; "
            "k.VirtualFixture([], gain=1, buffer=1, period=1); "
            "print(sorted(m for m in ('z3', 'sympy', 'hypothesis', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_extraction_refuses_a_loop_it_cannot_vectorise():
    # (refusing unproved models is the CLI's job: tests/kernel/test_extract.py)
    with pytest.raises(ExtractError, match="last one wins"):
        extract(library.get("sbs.ctrl2_last_wins"))


def test_a_changed_model_is_refused(monkeypatch):
    import certiloop.studies.sbs.fixture as fixture

    monkeypatch.setattr(ctrl2, "MODEL_HASH", "0000000000000000")
    monkeypatch.setattr(fixture, "_checked", False)
    with pytest.raises(RuntimeError, match="certiloop.studies regenerate"):
        VirtualFixture([], gain=1, buffer=1, period=1)


# ------------------------------------------------------------------ conformance


_CONTROL = Theorem("sbs.ctrl2.controller", TRUE, controller(CTRL2, inputs=False), TRUE)


def model_gain(p, f, fp, points, normals, G, D, e) -> Fraction:
    """k by running the model's controller in the interpreter (first enabled case), exactly
    (Fractions of the float inputs): the real model's decision. Raises Blocked if none."""
    F = Fraction
    m = len(points)
    state = {"#universe:B": range(m), "G": F(G), "D": F(D), "e": F(e)}
    for a, name in enumerate("xyz"):
        state[f"p{name}"], state[f"f{name}"], state[f"f{name}p"] = F(p[a]), F(f[a]), F(fp[a])
        state[f"n{name}"] = Table({(j,): F(float(normals[j][a])) for j in range(m)})
        state[f"r{name}"] = Table({(j,): F(float(points[j][a])) for j in range(m)})
    run = Interpreter(_CONTROL, exact=True).run(FirstEnabled(), state, checked=True)
    return Fraction(run.final["k"])


def kernel_gain(p, f, fp, points, normals, G, D, e):
    n, r = np.array(normals, dtype=float).reshape(-1, 3), np.array(points, dtype=float).reshape(-1, 3)
    k, enabled = ctrl2.controller(*p, *fp, *f, D, e, G, r[:, 0], n[:, 0], r[:, 1], n[:, 1], r[:, 2], n[:, 2])
    return float(k), enabled


unit = st.tuples(*[st.floats(-1, 1, allow_subnormal=False)] * 3).filter(
    lambda v: np.linalg.norm(v) > 1e-3).map(lambda v: tuple(np.array(v) / np.linalg.norm(v)))
# (tiny and huge magnitudes: tests/kernel/test_float_sound.py)
coord = st.one_of(st.just(0.0), st.floats(-5, 5))
vec = st.tuples(coord, coord, coord)


@st.composite
def scenes(draw):
    """A tool position, force, force rate and 1..50 boundaries with the tool on their safe
    side, with the edge cases mixed in."""
    p = np.array(draw(vec))
    m = draw(st.integers(1, 50))
    normals = [np.array(draw(unit)) for _ in range(m)]
    if m > 1 and draw(st.booleans()):  # duplicate planes
        normals[1] = normals[0]
    if m > 1 and draw(st.booleans()):  # boundaries at an acute angle (normals opposed)
        normals[-1] = -normals[0] + 0.1 * np.array(draw(unit))
        normals[-1] /= np.linalg.norm(normals[-1])
    dists = [draw(st.one_of(st.just(0.0), st.floats(0, 3))) for _ in range(m)]  # 0: on the boundary
    points = [p - d * n for d, n in zip(dists, normals)]
    f = np.array(draw(st.one_of(st.just((0.0, 0.0, 0.0)), vec)))  # zero force
    if draw(st.booleans()):  # force parallel to the first plane
        f = f - np.dot(f, normals[0]) * normals[0]
    fp = np.array(draw(st.one_of(st.just((0.0, 0.0, 0.0)), vec)))
    G, D, e = (draw(st.floats(0.1, 5)) for _ in range(3))
    return p, f, fp, points, normals, G, D, e


@settings(max_examples=150, deadline=None)
@given(scenes())
def test_kernel_gain_equals_the_model_interpreter(scene):
    try:
        expected = model_gain(*scene)
    except Blocked:  # the real model has no run here: neither may the kernel
        assert not kernel_gain(*scene)[1]
        return
    k, enabled = kernel_gain(*scene)
    assert enabled
    assert Fraction(k) <= expected  # rounded down: never a larger gain than the model's
    assert k == pytest.approx(float(expected), rel=REL, abs=ABS)


def test_overflow_is_decided_exactly_and_no_run_only_where_the_model_has_none():
    # 1/(G fn²) overflows in floats for fn = -1.5e-159; the real model's k is 2 fnp d0/(G fn²) = 0
    tiny = ((0, 0, 0.0), (0, 0, -1.5e-159), (0, 0, 1.0), [(0, 0, 0.0)], [(0, 0, 1.0)], 1.0, 1.0, 1.0)
    assert kernel_gain(*tiny) == (0.0, True) and model_gain(*tiny) == 0
    fixture = VirtualFixture([((0, 0, 0), (0, 0, 1))], gain=1, buffer=1, period=1)
    cmd = fixture.step((0, 0, 0), (0, 0, -1.5e-159), (0, 0, 1))
    assert (cmd.k, cmd.ok) == (0.0, True)
    # G = 0 (outside the fixture's checked parameters): every safety case needs G != 0 or
    # G·(fn ε + fnp ε²/2) != 0, so the model has no run (the exact interpreter raises
    # ZeroDivisionError solving tmp·G·(...) = 1 here instead of blocking: not used)
    stuck = ((0, 0, 0.0), (0, 0, -1.0), (0, 0, 1.0), [(0, 0, 0.0)], [(0, 0, 1.0)], 0.0, 1.0, 1.0)
    assert kernel_gain(*stuck)[1] is False


def test_edge_cases_by_hand():
    n = [(0, 0, 1.0)]
    on_boundary = ((0, 0, 0.0), (0, 0, -1.0), (0, 0, 0.0), [(0, 0, 0.0)], n, 1.0, 1.0, 0.1)
    assert kernel_gain(*on_boundary) == (model_gain(*on_boundary), True)
    assert kernel_gain(*on_boundary)[0] == 0.0  # pushing into a boundary it touches: stop
    parallel = ((0, 0, 1.0), (3.0, 0, 0), (0, 0, 0.0), [(0, 0, 0.0)], n, 1.0, 1.0, 0.1)
    assert kernel_gain(*parallel)[0] == 1.0 == model_gain(*parallel)


# ------------------------------------------------------------------ closed loop


def distances(fixture, p):
    return [float(np.dot(p - pt, n)) for pt, n in fixture.planes.values()]


@settings(max_examples=100, deadline=None)
@given(scenes(), st.lists(vec, min_size=5, max_size=30))
def test_closed_loop_keeps_every_boundary(scene, rates):
    """The kernel against the exact plant p' = G k f, f' = fp over many periods with
    adversarial force rates: no distance ever below -1e-9 (rounding of the simulation)."""
    p, f, fp, points, normals, G, D, e = scene
    fixture = VirtualFixture(zip(points, normals), gain=G, buffer=D, period=e)
    for rate in rates:
        fp = np.array(rate)
        cmd = fixture.step(p, f, fp)
        assert cmd.ok, cmd.reason  # valid inputs and motion: the verified gain, not the fallback
        assert np.all(np.isfinite(cmd.velocity)) and 0 <= cmd.k <= 1
        # exact solution over the period, checked densely (the distance is quadratic in t)
        for t in np.linspace(0, e, 9):
            q = p + G * cmd.k * (f * t + fp * t * t / 2)
            assert min(distances(fixture, q)) >= -1e-9
        p, f = p + G * cmd.k * (f * e + fp * e * e / 2), f + fp * e


# ------------------------------------------------------------------ monitor and API


def fixture1():
    return VirtualFixture([((0, 0, 0), (0, 0, 1))], gain=1, buffer=0.5, period=0.1)


@pytest.mark.parametrize("p,f,fp,why", [
    ((0, 0, 1), (0, 0, float("nan")), (0, 0, 0), "force is not finite"),
    ((0, 0, float("inf")), (0, 0, 0), (0, 0, 0), "position is not finite"),
    ((0, 0, -0.1), (0, 0, 0), (0, 0, 0), "already past boundary 0"),
    ((0, 0), (0, 0, 0), (0, 0, 0), "3-vector"),
    (("a", 0, 0), (0, 0, 0), (0, 0, 0), "not numbers"),
])
def test_bad_inputs_command_the_fallback(p, f, fp, why):
    cmd = fixture1().step(p, f, fp)
    assert (cmd.k, cmd.ok) == (0.0, False) and why in cmd.reason
    assert not np.any(np.isnan(cmd.velocity))


def test_bad_parameters_and_normals():
    with pytest.raises(ValueError, match="length 1"):
        VirtualFixture([((0, 0, 0), (0, 0, 2))], gain=1, buffer=1, period=1)
    with pytest.raises(ValueError, match="zero"):
        VirtualFixture([((0, 0, 0), (0, 0, 0))], gain=1, buffer=1, period=1)
    cmd = VirtualFixture([], gain=-1, buffer=1, period=1).step((0, 0, 0), (1, 0, 0), (0, 0, 0))
    assert not cmd.ok and "G must be" in cmd.reason
    fx = fixture1()
    fx._normals[0] = (0, 0, 2.0)  # tampering after construction is still caught
    assert "length" in fx.step((0, 0, 1), (0, 0, 0), (0, 0, 0)).reason


def test_motion_that_the_model_does_not_allow_is_caught():
    fx = fixture1()
    assert fx.step((0, 0, 1), (0, 0, -1), (0, 0, 0)).ok
    cmd = fx.step((0, 0, 0.2), (0, 0, -1), (0, 0, 0))  # jumped 0.7 instead of 0.1
    assert not cmd.ok and "prediction" in cmd.reason


def test_planes_are_added_only_on_their_safe_side_and_removed_any_time():
    fx = fixture1()
    fx.step((0, 0, 1), (0, 0, 0), (0, 0, 0))
    with pytest.raises(ValueError, match="forbidden side"):
        fx.add_plane((0, 0, 2), (0, 0, 1))
    pid = fx.add_plane((0, 0, 2), (0, 0, -1))
    assert len(fx.planes) == 2
    fx.remove_plane(pid)
    assert list(fx.planes) == [0]


def test_monitor_rejects_a_gain_the_model_does_not_allow():
    from certiloop.studies.sbs import monitor
    d0, fn, fnp = np.array([0.1]), np.array([-1.0]), np.array([0.0])
    assert not monitor.check_command(1.0, d0, fn, fnp, gain=1.0, period=1.0).ok  # reaches -0.9
    assert monitor.check_command(0.1, d0, fn, fnp, gain=1.0, period=1.0).ok  # exactly reaches 0
    assert not monitor.check_command(float("nan"), d0, fn, fnp, 1.0, 1.0).ok


def test_rounding_noise_in_a_normal_does_not_stop_the_tool():
    # found by hypothesis: a 1e-159 component made the projected rates subnormal
    normals = [np.array([0.0, 0.0, 1.0])] * 13 + [np.array([0.0, 5.65112199e-159, -1.0])]
    fixture = VirtualFixture([(np.zeros(3), n) for n in normals], gain=1.0, buffer=1.0, period=1.0)
    p, f = np.zeros(3), np.zeros(3)
    for rate in [(0.0, 0.0, 0.0)] * 3 + [(0.0, -1.0, 0.0), (0.0, 2.0, 0.0)]:
        cmd = fixture.step(p, f, np.array(rate))
        assert cmd.ok, cmd.reason
        p = p + cmd.velocity * 1.0 + fixture.gain * cmd.k * np.array(rate) / 2
        f = f + np.array(rate)
