"""Float-sound, float-total extraction (issue 19 item 1; the scheme: kernel/extract/certified.py).

The oracle is independent of the generated code: the model's own control step run by the
interpreter in EXACT rational arithmetic (Fractions) on the same float inputs — the real
model's decisions on those inputs — and Table 2's safe-for-step condition checked exactly
for the gain the kernel returns. Inputs have extreme magnitudes: subnormals, 1e±300, exact
zeros and ties (the tool on a plane, a force parallel to it).
"""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.falsify.choosers import FirstEnabled
from certiloop.falsify.evaluate import Blocked, Table
from certiloop.falsify.interpreter import Interpreter
from certiloop.kernel import filtered
from certiloop.kernel.extract import controller
from certiloop.models import library
from certiloop.models.lang.terms import TRUE
from certiloop.models.lang.theorem import Theorem
from certiloop.studies.sbs.fixture import VirtualFixture
from certiloop.studies.sbs.generated import ctrl2

CTRL2 = library.get("sbs.ctrl2")
_STEP = Theorem("sbs.ctrl2.step", TRUE, controller(CTRL2, inputs=False), TRUE)


def exact_gain(p, f, fp, points, normals, G, D, e):
    """The real model's k on these (float) inputs, as a Fraction; None if it has no run."""
    F = Fraction
    m = len(points)
    state = {"#universe:B": range(m), "G": F(G), "D": F(D), "e": F(e)}
    for a, name in enumerate("xyz"):
        state[f"p{name}"], state[f"f{name}"], state[f"f{name}p"] = F(p[a]), F(f[a]), F(fp[a])
        state[f"n{name}"] = Table({(j,): F(float(normals[j][a])) for j in range(m)})
        state[f"r{name}"] = Table({(j,): F(float(points[j][a])) for j in range(m)})
    try:
        run = Interpreter(_STEP, exact=True).run(FirstEnabled(), state, checked=True)
    except Blocked:
        return None
    return Fraction(run.final["k"])


def kernel_gain(p, f, fp, points, normals, G, D, e):
    n = np.array(normals, dtype=float).reshape(-1, 3)
    r = np.array(points, dtype=float).reshape(-1, 3)
    k, enabled = ctrl2.controller(*p, *fp, *f, D, e, G, r[:, 0], n[:, 0], r[:, 1], n[:, 1], r[:, 2], n[:, 2])
    return k, enabled


def safe_for_step(k, p, f, fp, points, normals, G, e) -> bool:
    """Table 2's safe-for-step, exactly: for every boundary, d0 + G k (fn t + fnp t²/2) >= 0
    for all t in [0, e] (the quadratic's minimum: at 0, at e, or at its vertex)."""
    F = Fraction
    k, G, e = F(k), F(G), F(e)
    for r, n in zip(points, normals):
        d0 = sum((F(p[a]) - F(float(r[a]))) * F(float(n[a])) for a in range(3))
        fn = sum(F(f[a]) * F(float(n[a])) for a in range(3))
        fnp = sum(F(fp[a]) * F(float(n[a])) for a in range(3))
        times = [F(0), e]
        if fnp > 0 and 0 < -fn / fnp < e:
            times.append(-fn / fnp)
        if min(d0 + G * k * (fn * t + fnp * t * t / 2) for t in times) < 0:
            return False
    return True


def check(scene) -> None:
    want = exact_gain(*scene)
    k, enabled = kernel_gain(*scene)
    # float-total: no fallback where the reals have a run; and no run where they have none
    assert enabled is (want is not None), (want, k, enabled)
    if want is None:
        return
    # float-sound: the gain is the real model's, rounded down (never above it), and tight
    if not np.isfinite(k):  # the model's k is beyond the float range (a tool past a plane: d0 < 0)
        assert k == -np.inf and want < Fraction(-np.finfo(float).max)
        return
    assert Fraction(k) <= want
    assert Fraction(k) >= want - 2 * abs(want) * Fraction(filtered.TIGHT) - Fraction(2.0 ** -1074)
    p, f, fp, points, normals, G, D, e = scene
    d0 = [sum((Fraction(p[a]) - Fraction(float(r[a]))) * Fraction(float(n[a])) for a in range(3))
          for r, n in zip(points, normals)]
    if min(d0) >= 0:  # the tool on every safe side: the command keeps it there for the period
        assert 0 <= k <= 1
        assert safe_for_step(k, p, f, fp, points, normals, G, e)


def test_issue_19_tiny_normal_component_is_not_a_spurious_stop():
    """The issue's case: normal (1, 2.1e-162, 0), the tool on the plane, force (-2.1e-162, 1, 0),
    G = D = ε = 1 (force rate along the normal). The model allows a run (k = 0: pushing into a
    plane the tool touches); the kernel fell back ("no enabled case") since 1/(G fn²) overflowed."""
    scene = ((0.0, 0.0, 0.0), (-2.1e-162, 1.0, 0.0), (1.0, 0.0, 0.0), [(0.0, 0.0, 0.0)],
             [(1.0, 2.1e-162, 0.0)], 1.0, 1.0, 1.0)
    check(scene)
    assert kernel_gain(*scene) == (exact_gain(*scene), True)
    fixture = VirtualFixture([((0, 0, 0), (1, 2.1e-162, 0))], gain=1, buffer=1, period=1)
    cmd = fixture.step((0, 0, 0), (-2.1e-162, 1, 0), (1, 0, 0))
    assert cmd.ok, cmd.reason
    # the normal as given (1, 2.1e-162, 0): the model's k for it (the fixture keeps it as is)
    assert Fraction(cmd.k) == exact_gain((0, 0, 0), (-2.1e-162, 1, 0), (1, 0, 0), [(0, 0, 0)],
                                         [fixture.planes[0][1]], 1.0, 1.0, 1.0)


def test_overflowing_division_is_decided_exactly():
    # fn = -1.5e-159: G fn² is subnormal and 1/(G fn²) overflows; the model's k is 2 fnp d0/(G fn²) = 0
    scene = ((0, 0, 0.0), (0, 0, -1.5e-159), (0, 0, 1.0), [(0, 0, 0.0)], [(0, 0, 1.0)], 1.0, 1.0, 1.0)
    check(scene)
    assert kernel_gain(*scene) == (0.0, True)


def test_near_tie_rows_only_are_redone_exactly(monkeypatch):
    calls = []
    exact = ctrl2._exact
    monkeypatch.setattr(ctrl2, "_exact", lambda *a: calls.append(len(a[-1])) or exact(*a))
    normals = [(0, 0, 1.0)] * 5
    points = [(0, 0, -2.0)] * 4 + [(0, 0, 0.0)]
    scene = ((0, 0, 0.0), (0, 0, -1e-170), (0, 0, 1.0), points, normals, 1.0, 1.0, 1.0)
    check(scene)
    assert calls == [1]  # the one boundary the tool touches, with a force of 1e-170 into it
    calls.clear()
    points[-1] = (0, 0, -0.5)
    check(((0, 0, 0.0), (0, 0, -1.0), (0, 0, 1.0), points, normals, 1.0, 1.0, 0.5))
    assert calls == []  # a generic state: floats decide everything


# ------------------------------------------------------------------ properties, extreme magnitudes

magnitude = st.one_of(
    st.just(0.0),
    st.floats(-1e3, 1e3, allow_nan=False),
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e300, max_value=1e300),
    st.sampled_from([5e-324, -5e-324, 2.2250738585072014e-308, 1e-300, -1e-300, 1e300, -1e300,
                     2.1e-162, -2.1e-162, 1e-160, 1e150, -1e150]),
    st.floats(-1e-300, 1e-300, allow_nan=False),  # includes subnormals
)
vec3 = st.tuples(magnitude, magnitude, magnitude)
positive = st.one_of(st.floats(1e-3, 1e3), st.sampled_from([1.0, 1e-300, 1e300, 5e-324, 0.5]))


@st.composite
def extreme_scenes(draw):
    """Any finite inputs in the model's domain (G, D, ε > 0): 1..5 boundaries whose normal
    and point are arbitrary (the step itself does not read |n| = 1), ties mixed in."""
    p = draw(vec3)
    m = draw(st.integers(1, 5))
    normals, points = [], []
    for _ in range(m):
        n = draw(st.one_of(vec3, st.sampled_from([(1.0, 2.1e-162, 0.0), (0.0, 0.0, 1.0), (0.6, 0.8, 0.0)])))
        normals.append(n)
        # the tool on the plane (r = p), or the plane anywhere
        points.append(p if draw(st.booleans()) else draw(vec3))
    f = draw(st.one_of(vec3, st.just((0.0, 0.0, 0.0))))
    fp = draw(st.one_of(vec3, st.just((0.0, 0.0, 0.0))))
    if draw(st.booleans()):  # force along the first plane's tangent: fn = 0 in the reals
        n = normals[0]
        f = (n[1], -n[0], 0.0)
    G, D, e = draw(positive), draw(positive), draw(positive)
    return p, f, fp, points, normals, G, D, e


@settings(max_examples=300, deadline=None)
@given(extreme_scenes())
def test_decisions_are_the_real_models_on_extreme_inputs(scene):
    check(scene)


@st.composite
def plain_scenes(draw):
    """Ordinary magnitudes, unit normals, the tool on the safe side (tests/studies/sbs/test_kernel.py's
    shape), with exact ties: on the plane, zero force, force parallel to a plane."""
    coord = st.one_of(st.just(0.0), st.floats(-5, 5))
    p = np.array(draw(st.tuples(coord, coord, coord)))
    m = draw(st.integers(1, 20))
    normals = []
    for _ in range(m):
        v = np.array(draw(st.tuples(*[st.floats(-1, 1)] * 3)))
        normals.append(v / np.linalg.norm(v) if np.linalg.norm(v) > 1e-3 else np.array([0.0, 0.0, 1.0]))
    dists = [draw(st.one_of(st.just(0.0), st.floats(0, 3))) for _ in range(m)]
    points = [p - d * n for d, n in zip(dists, normals)]
    f = np.array(draw(st.one_of(st.just((0.0, 0.0, 0.0)), st.tuples(coord, coord, coord))))
    if draw(st.booleans()):
        f = f - np.dot(f, normals[0]) * normals[0]
    fp = np.array(draw(st.one_of(st.just((0.0, 0.0, 0.0)), st.tuples(coord, coord, coord))))
    G, D, e = (draw(st.floats(0.1, 5)) for _ in range(3))
    return p, f, fp, points, normals, G, D, e


@settings(max_examples=200, deadline=None)
@given(plain_scenes())
def test_decisions_are_the_real_models_on_ordinary_inputs(scene):
    check(scene)


def test_the_oracle_can_fail():
    """The check is not vacuous: a gain above the model's, or a fallback where the model
    has a run, is caught."""
    # outside the slow zone (d0 = 0.05 >= D = 0.01), pushing in: k = d0/(G |fn| ε) = 0.5 exactly
    # reaches the plane at the end of the period
    scene = ((0, 0, 0.0), (0, 0, -1.0), (0, 0, 0.0), [(0, 0, -0.05)], [(0, 0, 1.0)], 1.0, 0.01, 0.1)
    want = exact_gain(*scene)
    assert abs(want - Fraction(1, 2)) < Fraction(1, 10**12)
    p, f, fp, points, normals, G, D, e = scene
    assert safe_for_step(float(want) * (1 - 1e-12), p, f, fp, points, normals, G, e)
    assert not safe_for_step(min(1.0, float(want) * 1.01), p, f, fp, points, normals, G, e)
    with pytest.raises(AssertionError):
        original = ctrl2.controller
        try:
            ctrl2.controller = lambda *a: (0.0, False)
            check(scene)
        finally:
            ctrl2.controller = original


# ------------------------------------------------------------------ the error bounds themselves

finite = st.one_of(magnitude, st.floats(allow_nan=False, allow_infinity=False))


@st.composite
def bounded(draw):
    """(float v, its bound e or None, a real x with |v - x| <= e)."""
    v = draw(finite)
    if draw(st.booleans()):
        return v, None, Fraction(v)
    e = abs(draw(st.one_of(st.sampled_from([0.0, 5e-324, 1e-300]), st.floats(0, 1e10), finite)))
    t = draw(st.fractions(-1, 1, max_denominator=1000))
    return v, e, Fraction(v) + t * Fraction(e)


@settings(max_examples=400, deadline=None)
@given(bounded(), bounded(), st.sampled_from(["add", "sub", "mul", "div"]))
def test_every_operation_bounds_its_error(a, b, op):
    """|v - x| <= e·INFL for the real x of the operation on any reals within the operands'
    bounds (the comparison rule's premise), including underflow, overflow (e = inf) and
    zero divisors (never certain)."""
    (va, ea, xa), (vb, eb, xb) = a, b
    with np.errstate(all="ignore"):
        v, e = getattr(filtered, op)(va, ea, vb, eb)
    v, e = float(v), float(e)
    if not (np.isfinite(v) and np.isfinite(e)):
        assert not np.isfinite(e) or not np.isfinite(v)  # then no comparison on it is certain
        assert bool(filtered.uncertain(v, e, 0.0, None))
        return
    if op == "div":
        assert xb != 0  # a finite bound certifies the divisor's sign
    x = {"add": xa + xb, "sub": xa - xb, "mul": xa * xb, "div": xa / xb if xb else None}[op]
    assert abs(Fraction(v) - x) <= Fraction(e) * Fraction(filtered.INFL)
