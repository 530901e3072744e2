"""Float-soundness of the controller monitor of a step over a family of boundaries (sbs.ctrl2,
ctrl2_2d, ctrl2_dynamic; certiloop/kernel/extract/modelplex_family.py) on near ties and at
magnitudes up to 1e300.

The oracle is independent of the monitor's code: every run of the model's control step, run by
the interpreter in EXACT rationals on the same float inputs (one boundary: the whole step's
runs are few enough to enumerate). A command is the model's iff some run ends with k within
tol in the reals, or k is the float the extracted controller returns for that run's k (the
largest float at most it), and, for ctrl2_dynamic, with the active set the run leaves. The
monitor must give exactly that answer: True where no run ends on the command would accept an
unsafe command; False where one does would be a needless fallback (ctrl2's guards have no
irrational roots, so the exact pass always decides).

Tie states are found on the exact model alone (as in tests/kernel/test_extract_ties.py): along
one input, two values where its first-enabled run takes other alternatives (or blocks elsewhere)
are bisected over the floats down to adjacent floats (a boundary of some guard), then nudged 0 to
2^16 ulps. The commands sit on the ties of the monitor's own comparisons: each run's k rounded
down, moved by 0 to 2^16 ulps, with tol 0 and tol within an ulp of the distance to k.

States near 1e301 where the plain-float64 monitor accepted k = 1 against a model that allows
only k = 0 (or a k a hair below 1) are kept as regressions; the filter's own `close` decision on
an inexact value is checked against the exact pass.
"""

import math
import sys
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from certiloop.falsify.choosers import FirstEnabled
from certiloop.falsify.evaluate import Blocked, Table
from certiloop.falsify.interpreter import Interpreter
from certiloop.kernel.extract.modelplex import monitors
from certiloop.models import library
from kernel.test_extract import step_theorem
from kernel.test_extract_ties import _float_at, _index, edge
from kernel.test_monitors import all_finals

DIMS = {"sbs.ctrl2": "xyz", "sbs.ctrl2_2d": "xy", "sbs.ctrl2_dynamic": "xyz"}
NAMES = list(DIMS)
MAX = Fraction(sys.float_info.max)
ULPS = (0, 1, 2, 3, 256, 2 ** 16)
_MONITORS: dict = {}
_STEPS: dict = {}


def monitor(name: str):
    if name not in _MONITORS:
        ns: dict = {}
        exec(compile(monitors(library.get(name)), f"<monitors {name}>", "exec"), ns)
        _MONITORS[name] = ns["controller_monitor"]
    return _MONITORS[name]


def _step(name: str):
    if name not in _STEPS:  # ctrl2_dynamic: the requested active set is given in the state
        _STEPS[name] = step_theorem(name, drop=("active_next",) if name == "sbs.ctrl2_dynamic" else ())
    return _STEPS[name]


def interpreter_state(values: dict) -> dict:
    """The interpreter's form: exact rationals, families as Tables over one boundary."""
    out: dict = {"#universe:B": range(1)}
    for k, v in values.items():
        if isinstance(v, np.ndarray):
            out[k] = Table({(0,): bool(v[0]) if v.dtype == bool else Fraction(float(v[0]))})
        else:
            out[k] = Fraction(v)
    return out


def decision(name: str, values: dict):
    """The alternatives the exact model's first-enabled run takes (or where it blocks): a
    function of the state that changes exactly where some guard on that run does."""
    try:
        run = Interpreter(_step(name), exact=True).run(FirstEnabled(), interpreter_state(values),
                                                       checked=True)
    except Blocked:
        return "blocked"
    return tuple(label for c in run.checkpoints for label in c.choices)


def runs(name: str, values: dict) -> list[tuple[Fraction, object]]:
    """(k, active set) of every run of the exact model's step."""
    out = []
    for final in all_finals(_step(name), interpreter_state(values), {}):
        active = bool(final["active"].read((0,))) if "active" in final else None
        out.append((Fraction(final["k"]), active))
    return out


def admitted(model_runs, k: float, tol: float, active=None) -> bool:
    """Some run ends on the command: k within tol of its k, or the largest float <= its k."""
    c, t = Fraction(k), Fraction(tol)
    for r, act in model_runs:
        if act is not None and act != active:
            continue
        if abs(r - c) <= t:
            return True
        above = Fraction(math.nextafter(k, math.inf)) if k < sys.float_info.max else MAX + 1
        if abs(r) <= MAX and c <= r < above:
            return True
    return False


def floor(q: Fraction) -> float | None:
    if abs(q) > MAX:
        return None
    f = float(q)
    return math.nextafter(f, -math.inf) if Fraction(f) > q else f


def nudge(x: float, ulps: int) -> float:
    y = _float_at(_index(x) + ulps)
    return y if math.isfinite(y) else x


def _inputs(name: str) -> list[str]:
    dims = DIMS[name]
    return [*(f"{v}{x}" for x in dims for v in ("p", "f")), *(f"f{x}p" for x in dims), "G", "D", "e",
            *(f"{v}{x}" for x in dims for v in ("r", "n"))]


@st.composite
def tie_values(draw, name: str, magnitude: int = 0):
    """One boundary's state within 2^16 ulps of a guard of the exact model's first run in one
    input (the other lengths drawn at scale 10^magnitude; the normal at scale 1)."""
    scale = 10.0 ** magnitude
    dims = DIMS[name]

    def real(s: float) -> float:
        return draw(st.sampled_from([0.0, 1.0, 2.0, 0.5, 3.0, -1.0])) * draw(st.floats(0.1, 10.0)) * s

    values: dict = {}
    for x in dims:
        values[f"p{x}"], values[f"f{x}"], values[f"f{x}p"] = real(scale), real(scale), real(scale)
        values[f"r{x}"], values[f"n{x}"] = np.array([real(scale)]), np.array([real(1.0)])
    values["G"], values["D"], values["e"] = (abs(real(1.0)) for _ in range(3))
    if name == "sbs.ctrl2_dynamic":
        values["active"] = np.array([draw(st.booleans())])
        values["active_next"] = np.array([draw(st.booleans())])
    var = draw(st.sampled_from(_inputs(name)))

    def at(x: float) -> dict:
        return {**values, var: np.array([x]) if var[0] in "rn" else x}

    for lo, hi in [(-scale * 100, scale * 100), (0.0, scale * 100), (-scale * 100, 0.0), (-1e300, 1e300)]:
        found = edge(lambda x: decision(name, at(x)), lo, hi)
        if found is not None:
            return at(nudge(found, draw(st.sampled_from([-1, 1])) * draw(st.sampled_from(ULPS))))
    return values


def commands(model_runs) -> list[tuple[float, float]]:
    """(k, tol) on the ties of the monitor's comparisons: each run's k (and the k0 = 1 the loop
    starts from) rounded down and moved by 0..2^16 ulps either way, with tol 0 and with tol
    within an ulp of the distance to that k."""
    out = []
    for r in sorted({r for r, _ in model_runs} | {Fraction(1)}):
        base = floor(r)
        if base is None:
            continue
        for ulps in ULPS:
            for sign in (-1, 1):
                k = nudge(base, sign * ulps)
                out.append((k, 0.0))
                gap = floor(abs(r - Fraction(k)))
                if gap:
                    out += [(k, gap), (k, math.nextafter(gap, math.inf)), (k, math.nextafter(gap, 0.0))]
    return out


def check(name: str, values: dict) -> tuple[int, int]:
    """The monitor against the oracle on every command near a run's k: (checked, accepted)."""
    model_runs = runs(name, values)
    state = {k: v for k, v in values.items() if k != "active_next" or name == "sbs.ctrl2_dynamic"}
    checked = accepted = 0
    actives = [None] if name != "sbs.ctrl2_dynamic" else [False, True]
    for k, tol in commands(model_runs):
        for active in actives:
            command = {"k": k} if active is None else {"k": k, "active": np.array([active])}
            got = monitor(name)(state, command, tol)
            want = admitted(model_runs, k, tol, active)
            where = f"{name}: k={k!r} tol={tol!r} from {values}"
            assert got is not True or want, f"{where}: accepted, and no run of the model ends there"
            assert got is True or not want, f"{where}: rejected, and a run of the model ends there"
            checked += 1
            accepted += got
    return checked, accepted


@pytest.mark.parametrize("name", NAMES)
@settings(max_examples=6, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_family_monitor_decides_as_the_exact_model_on_ties(name, data):
    check(name, data.draw(tie_values(name)))


@pytest.mark.parametrize("name", NAMES)
@settings(max_examples=4, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_family_monitor_decides_as_the_exact_model_at_extreme_magnitudes(name, data):
    magnitude = data.draw(st.sampled_from([-300, -150, -20, 20, 150, 300]))
    check(name, data.draw(tie_values(name, magnitude)))


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
@settings(max_examples=60, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_family_monitor_on_many_ties(name, data):
    magnitude = data.draw(st.sampled_from([0, 0, 0, -300, -20, 20, 300]))
    check(name, data.draw(tie_values(name, magnitude)))


def test_non_finite_inputs_and_commands_are_no_run():
    values = {"px": 0.0, "py": 0.0, "pz": 0.0, "fx": 0.0, "fy": 0.0, "fz": 0.0, "fxp": 0.0, "fyp": 0.0,
              "fzp": 0.0, "G": 1.0, "D": 1.0, "e": 1.0, "rx": np.array([0.0]), "ry": np.array([0.0]),
              "rz": np.array([-2.0]), "nx": np.array([0.0]), "ny": np.array([0.0]), "nz": np.array([1.0])}
    ok = monitor("sbs.ctrl2")
    assert admitted(runs("sbs.ctrl2", values), 1.0, 0.0) and ok(values, {"k": 1.0}) is True
    for bad in (math.nan, math.inf, -math.inf):
        assert ok(values, {"k": bad}) is False
        assert ok(values, {"k": 1.0}, bad) is False
        assert ok({**values, "px": bad}, {"k": 1.0}) is False
        assert ok({**values, "nz": np.array([bad])}, {"k": 1.0}) is False


def test_full_gain_at_large_magnitudes_is_rejected_where_the_model_stops():
    """Lengths near 1e301: the model's only k is 0 (exactly); float64 products overflow, and
    the monitor that decided in plain floats accepted k = 1."""
    values = {"px": 1.414650091665298e+301, "fx": 4e+300, "fxp": -1e+301,
              "rx": np.array([8.550660364896423e+300]), "nx": np.array([9.221010895909119]),
              "py": 1.205990796042964e+301, "fy": 0.0,
              "fyp": 1.4138484239125205e+301, "ry": np.array([2.3099321093262846e+301]),
              "ny": np.array([11.276875412961228]), "pz": 1.8738941171745187e+301,
              "fz": 4.534742140562189e+300,
              "fzp": 4.506389243566036e+300, "rz": np.array([4.028860514349503e+300]),
              "nz": np.array([4.955158406626682]), "G": 9.563824109755195, "D": 0.13029854478415503,
              "e": 3.1660614433271586}
    assert {r for r, _ in runs("sbs.ctrl2", values)} == {0}
    assert monitor("sbs.ctrl2")(values, {"k": 1.0}) is False
    assert monitor("sbs.ctrl2")(values, {"k": 0.0}) is True
    check("sbs.ctrl2", values)


def test_a_gain_a_hair_below_one_rejects_one():
    """The model's only k is a hair below 1 (the boundary's kt, exactly); float64 rounds kt to
    1 and the monitor that decided in plain floats accepted k = 1. The largest float below the
    model's k is accepted."""
    values = {"px": 0.0, "fx": 0.0, "fxp": 0.0, "rx": np.array([1.7540780153417803e+301]),
              "nx": np.array([-1643.1141979959466]), "py": -4.0365728752001745e+300,
              "fy": 7.58872047015777e+300,
              "fyp": 3.455646645687812e+300, "ry": np.array([6.917924129600285e+299]),
              "ny": np.array([-2.840565754777592]), "pz": 5e+298, "fz": 1.1187904138361725e+301, "fzp": 0.0,
              "rz": np.array([-2.0755889122771163e+300]), "nz": np.array([1.1480740991224743]), "G": 10.0,
              "D": 0.0, "e": 23.36835820337647}
    (r, _), = set(runs("sbs.ctrl2", values))
    assert r < 1 and floor(r) == math.nextafter(1.0, 0.0)
    assert monitor("sbs.ctrl2")(values, {"k": 1.0}) is False
    assert monitor("sbs.ctrl2")(values, {"k": floor(r)}) is True


@settings(max_examples=300, suppress_health_check=list(HealthCheck))
@given(num=st.integers(-2 ** 80, 2 ** 80), den=st.integers(1, 2 ** 70), slack=st.integers(0, 3),
       ulps=st.sampled_from([0, 1, 2, 3, 256]), sign=st.sampled_from([-1, 1]),
       tol_at=st.sampled_from(range(5)))
def test_the_filter_decides_a_command_within_tol_as_the_exact_pass(num, den, slack, ulps, sign, tol_at):
    """kit.close (the monitors' `|value - command| <= tol`, or command the float the controller
    returns for value) on a value known to the filter only within an error bound: where the
    filter answers, the exact pass gives the same answer on the real value."""
    from certiloop.kernel import decide

    x = Fraction(num, den)
    v = float(x)
    err = abs(Fraction(v) - x)
    e = float(err) * (1 + slack) or (0.0 if err == 0 else 5e-324)
    while Fraction(e) < err:
        e = math.nextafter(e, math.inf)
    k = nudge(floor(x), sign * ulps)
    gap = floor(abs(x - Fraction(k))) or 0.0
    tol = [0.0, gap, math.nextafter(gap, math.inf), math.nextafter(gap, 0.0), 1e-3][tol_at]
    try:
        got = decide.FLOAT.close(decide.Bounded(v, e), decide.Bounded(k), decide.Bounded(tol))
    except decide.Undecided:
        return
    assert got is decide.EXACT.close(x, Fraction(k), Fraction(tol)), (x, v, e, k, tol)
