"""The compiled back end of VirtualFixture.step (studies/sbs/native.py): the same commands as the
numpy path on sequences of steps (fallbacks with the same reason, certified gains), the numpy
path taking over wherever the C does not pass, and a clear refusal when it is unavailable."""

import re
from fractions import Fraction

import numpy as np
import pytest

from certiloop.studies.sbs import monitor, native
from certiloop.studies.sbs.fixture import VirtualFixture
from certiloop.studies.sbs.generated import ctrl2

NATIVE = native.load(ctrl2.MODEL_HASH)
needs_c = pytest.mark.skipif(NATIVE is None, reason=f"no compiled kernel: {native.why_not()}")


def _scene(rng):
    """Inside the model's assumptions: unit normals, the tool on the safe side (often exactly
    on a plane), forces often zero."""
    m = int(rng.integers(1, 8))
    p = rng.uniform(-3, 3, 3)
    normals = rng.normal(size=(m, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    d = np.where(rng.random(m) < 0.3, 0.0, rng.uniform(0, 3, m))
    points = p - d[:, None] * normals
    f = rng.uniform(-3, 3, 3) * (rng.random() < 0.8)
    fp = rng.uniform(-3, 3, 3) * (rng.random() < 0.8)
    G, D, e = rng.uniform(0.1, 3, 3)
    return p, f, fp, list(zip(points, normals)), G, D, e


def _exact_k(fixture: VirtualFixture, p, f, fp) -> Fraction:
    """The real model's gain on these float inputs, in rationals (the generated exact path)."""
    n, r = fixture._normals, fixture._points
    x = [Fraction(float(v)) for v in (*p, *fp, *f, fixture.buffer, fixture.period, fixture.gain)]
    fams = [np.array([Fraction(float(v)) for v in col], dtype=object)
            for col in (r[:, 0], n[:, 0], r[:, 1], n[:, 1], r[:, 2], n[:, 2])]
    k, enabled = ctrl2._exact(*x, *fams)
    assert enabled
    return k


@needs_c
def test_c_backend_gives_the_numpy_paths_commands():
    """Steps through both back ends, the tool moving as the model says (sometimes off it, or
    with a non-finite force): the same fallbacks with the same reasons; a passed C command is
    the real gain rounded down (checked in rationals) and passes the Python monitor."""
    rng = np.random.default_rng(7)
    passed = fell_back = 0
    for _ in range(200):
        p, f, fp, planes, G, D, e = _scene(rng)
        fast = VirtualFixture(planes, gain=G, buffer=D, period=e, backend="c")
        slow = VirtualFixture(planes, gain=G, buffer=D, period=e, backend="python")
        assert fast.backend == "c" and slow.backend == "python"
        for step in range(4):
            if step and rng.random() < 0.2:
                p = p + rng.normal(scale=1e-3, size=3)  # off the model's prediction
            if rng.random() < 0.05:
                f = np.array([np.nan, 0.0, 0.0])
            got, want = fast.step(p, f, fp), slow.step(p, f, fp)
            assert got.ok == want.ok and got.reason == want.reason, (got, want)
            if not got.ok:
                assert got.k == 0.0 and not np.any(got.velocity)
                fell_back += 1
                continue
            k = _exact_k(fast, p, f, fp)
            if k >= 0:  # (a tool on a plane by rounding only: both command 0, see fixture.ROUNDING)
                assert Fraction(got.k) <= k and got.k >= float(k) * (1 - 2.0 ** -19), (got.k, k)
            assert np.array_equal(got.velocity, G * got.k * f)
            assert np.array_equal(got.distances, want.distances)
            d0, n = got.distances, fast._normals
            assert monitor.check_command(got.k, d0, n @ f, n @ fp, G, e).ok
            passed += 1
            p = p + G * got.k * (f * e + fp * e * e / 2)
    assert passed > 300 and fell_back > 30


@needs_c
def test_where_c_cannot_decide_the_numpy_path_does():
    """The issue's plane (normal (1, 2.1e-162, 0), the tool on it, force (-2.1e-162, 1, 0),
    G = D = e = 1, subnormal products): the C-backed fixture commands the full gain, as the
    exact path does, with no spurious stop; a tool on a plane up to a rounding that C cannot
    certify is handed to the numpy path, never stopped for that reason."""
    fixture = VirtualFixture([((0, 0, 0), (1.0, 2.1e-162, 0.0))], gain=1, buffer=1, period=1, backend="c")
    command = fixture.step((0, 0, 0), (-2.1e-162, 1, 0), (0, 0, 0))
    assert command.ok and command.k == 1.0
    rng = np.random.default_rng(11)
    handed = 0
    for _ in range(300):
        p, f, fp, planes, G, D, e = _scene(rng)
        fixture = VirtualFixture(planes, gain=G, buffer=D, period=e, backend="c")
        numpy_path: list = []
        fixture._step_python = _spy(fixture._step_python, numpy_path)
        for _ in range(3):
            command = fixture.step(p, f, fp)
            if numpy_path and numpy_path[-1] is command and command.ok:
                handed += 1  # C did not pass it; the numpy path decided it and it passed
            if not command.ok:
                break
            p = p + G * command.k * (f * e + fp * e * e / 2)
    assert handed > 0


def _spy(run, seen: list):
    def wrapped(*args):
        seen.append(run(*args))
        return seen[-1]
    return wrapped


def test_unknown_backend_and_unavailable_c_are_refused_in_one_line(monkeypatch, tmp_path):
    with pytest.raises(ValueError, match="backend must be"):
        VirtualFixture([], gain=1, buffer=1, period=1, backend="fortran")
    monkeypatch.setattr(native, "_state", {})
    monkeypatch.setenv("CERTILOOP_KERNEL", "python")
    assert native.load() is None and native.why_not() == "CERTILOOP_KERNEL=python"
    assert VirtualFixture([], gain=1, buffer=1, period=1).backend == "python"
    with pytest.raises(ValueError, match="backend='c' is not available: CERTILOOP_KERNEL=python"):
        VirtualFixture([], gain=1, buffer=1, period=1, backend="c")
    monkeypatch.setattr(native, "_state", {})
    monkeypatch.delenv("CERTILOOP_KERNEL")
    monkeypatch.setenv("CERTILOOP_CACHE", str(tmp_path))  # nothing built yet
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.delenv("CC", raising=False)
    assert native.load() is None and "no C compiler" in native.why_not()
    command = VirtualFixture([((0, 0, -1), (0, 0, 1))], gain=1, buffer=0.5, period=0.01).step(
        (0, 0, 0), (1, 0, 0), (0, 0, 0))
    assert command.ok and command.k == 1.0  # the numpy path, unchanged


@needs_c
def test_a_different_model_hash_is_not_loaded():
    assert native.load(ctrl2.MODEL_HASH) is not None
    assert native.load("0" * 16) is None


def test_flags_and_declarations_are_the_extractors_and_the_headers():
    from certiloop.kernel.extract.c.syntax import CFLAGS

    assert native.FLAGS == CFLAGS
    header = " ".join((native.FIXTURE_C / "sbs_ctrl2_fixture.h").read_text().split())
    proto = " ".join(native.CDEF.split("\n", 2)[2].split())
    assert proto in header
    assert native.model_hash((native.KERNEL_C / "sbs_ctrl2.h").read_text()) == ctrl2.MODEL_HASH


def test_the_calls_declarations_are_the_headers():
    """Python's declarations of sbs_ctrl2_fixture_calls.h are the header's, field for field."""
    text = (native.FIXTURE_C / "sbs_ctrl2_fixture_calls.h").read_text()
    header = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    header = " ".join(header.split())
    for declaration in native.CDEF_CALLS.split(";"):
        assert " ".join(declaration.split()) in header, declaration


def _random_run(rng, count: int):
    """A scene and `count` rows of p, f, fp: the tool moving as the model says, sometimes off
    it, sometimes a non-finite force or position."""
    p, f, fp, planes, G, D, e = _scene(rng)
    rows = []
    for _ in range(count):
        rows.append(np.concatenate([p, f, fp]))
        off_model = rng.normal(scale=1e-3, size=3) if rng.random() < 0.1 else 0
        p = p + G * 0.5 * (f * e + fp * e * e / 2) + off_model
        if rng.random() < 0.05:
            f = np.array([np.nan, 0.0, 0.0])
        elif rng.random() < 0.3:
            f = rng.uniform(-3, 3, 3)
    return planes, G, D, e, np.array(rows)


def _same(a, b) -> bool:
    return np.array_equal(np.asarray(a), np.asarray(b)) and np.array_equal(np.signbit(a), np.signbit(b))


def _raw_c_step(fixture: VirtualFixture, p, f, fp, previous):
    """The C entry point sbs_ctrl2_fixture_step called with arrays (no context), from the
    memory `previous` (the numpy path's (p, f, fp, k) or None): (reason, k)."""
    memory, k = NATIVE.memory(), NATIVE.out()
    memory.has_previous = previous is not None
    if previous is not None:
        memory.p, memory.f, memory.fp = (list(map(float, v)) for v in previous[:3])
        memory.k = previous[3]
    arrays = [np.ascontiguousarray(v, dtype=float) for v in (p, f, fp)]
    cols = [np.ascontiguousarray(a[:, j]) for a in (fixture._points, fixture._normals) for j in range(3)]
    ptr = [NATIVE.doubles(a.ctypes.data) for a in arrays + cols]
    reason = NATIVE.step(*ptr, len(cols[0]), fixture.gain, fixture.buffer, fixture.period, fixture.period,
                         fixture.position_tolerance, memory, k)
    return reason, k[0]


@needs_c
def test_c_back_end_commands_are_the_c_steps_and_the_numpy_paths_verdicts():
    """On random runs, with inputs as arrays, lists and tuples: every command of the C-backed
    fixture is bit for bit the C step's own (called with arrays, from the same memory) where
    that passes, and has the numpy back end's verdict and reason; velocities and distances are
    G k f and the distances numpy computes, bit for bit, never NaN."""
    rng = np.random.default_rng(3)
    passed = 0
    for trial in range(150):
        planes, G, D, e, rows = _random_run(rng, 5)
        fast = VirtualFixture(planes, gain=G, buffer=D, period=e, backend="c")
        slow = VirtualFixture(planes, gain=G, buffer=D, period=e, backend="python")
        for row in rows:
            p, f, fp = row[0:3], row[3:6], row[6:9]
            as_given = [p, f.tolist(), tuple(fp)] if trial % 2 else [p, f, fp]
            reason, raw_k = _raw_c_step(fast, p, f, fp, fast._previous)
            got, want = fast.step(*as_given), slow.step(p, f, fp)
            assert (got.ok, got.reason) == (want.ok, want.reason), (got, want)
            if reason == native.OK:
                assert got.k == raw_k
            if got.ok:
                assert _same(got.velocity, G * got.k * f) and _same(got.distances, want.distances)
                assert abs(got.k - want.k) <= 2.0 ** -19 * want.k  # both round the real gain down
            assert np.all(np.isfinite(got.velocity))
            passed += got.ok
    assert passed > 100


@needs_c
@pytest.mark.parametrize("backend", ["c", "python"])
def test_step_many_is_repeated_step(backend):
    """step_many over a run equals step called on each row (gains, velocities, fallbacks and
    their reasons, and the memory it leaves: the next step agrees too), for one dt, a dt per
    row, and a run whose first rows fall back."""
    rng = np.random.default_rng(5)
    fell_back = 0
    for trial in range(60):
        planes, G, D, e, rows = _random_run(rng, 8)
        dt = [None, e, rng.uniform(0.5, 1.5, len(rows)) * e][trial % 3]
        many = VirtualFixture(planes, gain=G, buffer=D, period=e, backend=backend)
        one = VirtualFixture(planes, gain=G, buffer=D, period=e, backend=backend)
        steps = many.step_many(rows, dt=dt)
        for i, row in enumerate(rows):
            d = None if dt is None else (dt if np.ndim(dt) == 0 else dt[i])
            want = one.step(row[0:3], row[3:6], row[6:9], d)
            assert (steps.k[i], steps.ok[i], steps.reasons[i]) == (want.k, want.ok, want.reason)
            assert _same(steps.velocity[i], want.velocity)
            fell_back += not want.ok
        assert np.all(np.isfinite(steps.velocity)) and len(steps) == len(rows)
        after = rows[-1][0:3], rows[-1][3:6], rows[-1][6:9]
        assert many.step(*after).reason == one.step(*after).reason
    assert fell_back > 10


def test_step_many_refuses_a_malformed_run_in_one_line():
    fixture = VirtualFixture([((0, 0, -1), (0, 0, 1))], gain=1, buffer=0.5, period=0.01)
    with pytest.raises(ValueError, match=r"shape \(T, 9\)"):
        fixture.step_many(np.zeros((4, 6)))
    with pytest.raises(ValueError, match="one per row"):
        fixture.step_many(np.zeros((4, 9)), dt=[0.01, 0.01])


@needs_c
def test_a_parameter_changed_between_steps_reaches_the_compiled_step():
    fast = VirtualFixture([((0, 0, -1), (0, 0, 1))], gain=1, buffer=0.5, period=0.01, backend="c")
    slow = VirtualFixture([((0, 0, -1), (0, 0, 1))], gain=1, buffer=0.5, period=0.01, backend="python")
    for fixture in (fast, slow):
        fixture.gain, fixture.period = 40.0, 0.05
    got, want = fast.step((0, 0, 0), (0, 0, -1), (0, 0, 0)), slow.step((0, 0, 0), (0, 0, -1), (0, 0, 0))
    # the plane 1 away, G e |f| = 2: the gain that ends the period on the plane is 1/2 (with the
    # old gain and period the full gain would pass)
    for command in (got, want):
        assert command.ok and 0.5 * (1 - 2.0 ** -19) <= command.k <= 0.5


@needs_c
def test_the_extension_module_and_the_shared_library_step_alike(tmp_path, monkeypatch):
    """The two ways of loading the C (a compiled cffi module, the shared library through libffi)
    give the same reason, gain and memory on random inputs; a module that cannot be built leaves
    the library in charge, and the failure is not retried."""
    import cffi

    monkeypatch.setenv("CERTILOOP_CACHE", str(tmp_path))
    monkeypatch.setattr(native, "_state", {})
    assert native.load(ctrl2.MODEL_HASH) is not None
    folder = next((tmp_path / "native").iterdir())
    module = native._extension(cffi, {}, folder)
    if module is None:
        pytest.skip("no extension module here (no Python headers or setuptools)")
    ffi = cffi.FFI()
    ffi.cdef(native.CDEF)
    ffi.cdef(native.CDEF_CALLS)
    loaded = [native.Native(module.ffi, module.lib), native.Native(ffi, ffi.dlopen(str(folder /
                                                                                      "libsbs_ctrl2_fixture.so")))]
    rng = np.random.default_rng(2)
    for _ in range(100):
        planes, G, D, e, rows = _random_run(rng, 4)
        arrays = [np.array([pl[a] for pl in planes]) for a in (0, 1)]
        cols = [np.ascontiguousarray(x[:, j]) for x in arrays for j in range(3)]
        results = []
        for n in loaded:
            c = n.context()
            c.rx, c.ry, c.rz, c.nx, c.ny, c.nz = (n.doubles(col.ctypes.data) for col in cols)
            c.n, c.G, c.D, c.e, c.position_tolerance = len(planes), G, D, e, 1e-6
            results.append([(n.step_values(c, *row, e), c.k, c.memory.has_previous, list(c.memory.p))
                            for row in rows])
        assert repr(results[0]) == repr(results[1])  # (NaN positions included)
    (folder / "unbuildable").mkdir()
    monkeypatch.setattr(native, "_build_extension", lambda *a: (_ for _ in ()).throw(OSError("no headers")))
    assert native._extension(cffi, {}, folder / "unbuildable") is None
    monkeypatch.setattr(native, "_build_extension", lambda *a: pytest.fail("retried"))
    assert native._extension(cffi, {}, folder / "unbuildable") is None


@needs_c
def test_inputs_of_any_form_numpy_reads_are_stepped_alike():
    """Arrays of shape (3, 1), int arrays, strings of numbers, lists: the compiled step commands
    what it commands for the plain float arrays; what numpy cannot read is refused as before."""
    planes = [((0, 0, -1), (0, 0, 1)), ((0, -2, 0), (0, 1, 0))]
    p, f, fp = np.array([0.0, 0.0, 0.0]), np.array([1.0, -2.0, 3.0]), np.array([0.0, 0.5, 0.0])
    forms = [(p, f, fp), (p[:, None], f[:, None], fp[None, :]), (p.astype(int), f.astype(int), [0, 0.5, 0]),
             (["0", "0", "0"], ("1", "-2", "3"), ["0", "0.5", "0"]), (p.tolist(), f.tolist(), tuple(fp))]
    commands = []
    for form in forms:
        fixture = VirtualFixture(planes, gain=1.0, buffer=0.5, period=0.1, backend="c")
        commands.append(fixture.step(*form))
    assert all(c.ok for c in commands)
    assert len({c.k for c in commands}) == 1 and all(np.array_equal(c.velocity, commands[0].velocity)
                                                     for c in commands)
    fixture = VirtualFixture(planes, gain=1.0, buffer=0.5, period=0.1, backend="c")
    refused = fixture.step(p, ["a", "b", "c"], fp)
    assert not refused.ok and "not numbers" in refused.reason
    assert not fixture.step(p, f[:2], fp).ok
