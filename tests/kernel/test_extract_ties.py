"""Float-soundness of the scalar extracted controllers and monitors on near ties and at extreme
magnitudes (scheme: certiloop/kernel/decide.py).

The oracle is independent of the generated code: the model's own control step run by the
interpreter in EXACT rational arithmetic on the same float inputs. Tie states are found on the
oracle alone: for one input, two values where the exact model decides differently (another
alternative taken, or no run) are bisected over the floats down to two adjacent floats (a
boundary of some guard, solved for that input), then nudged 0 to 2^16 ulps either way.
"""

import math
import sys
from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from certiloop.falsify.evaluate import Blocked
from certiloop.falsify.interpreter import Interpreter
from certiloop.kernel.extract.modelplex import monitors
from certiloop.models import library
from certiloop.models.lang.terms import INT, REAL, free_vars
from kernel.test_extract import Known, module, step_theorem
from kernel.test_extract_coverage import EXTRACTS


def _source(name: str) -> str:
    from certiloop.kernel.extract import extract

    return extract(library.get(name))


def _sorts(name: str) -> dict:
    t = library.get(name)
    symbols = {**free_vars(t.assumptions), **t.program.symbols(), **free_vars(t.guarantee)}
    return {v: n.sort for v, n in symbols.items()}


def _real_inputs(name: str) -> list[str]:
    sorts = _sorts(name)
    return [v for v in module(name)["INPUTS"] if sorts.get(v) == REAL]


# scalar controllers with a real input (a step over a family of boundaries: tests/kernel/test_float_sound.py)
SCALAR = [n for n in EXTRACTS if "_step" in module(n) and not module(n)["FAMILIES"] and _real_inputs(n)]
# steps that pin a value by a quadratic equation: the exact interpreter takes no irrational root
ROOTS = {n for n in SCALAR if "_R.sqrt(" in _source(n)}
_STEPS: dict = {}


def _step(name: str):
    if name not in _STEPS:
        _STEPS[name] = step_theorem(name)
    return _STEPS[name]


class Prescribed(Known):
    """Takes the given alternative at each choice (then the first), state values for `x := *`."""

    def __init__(self, values: dict, picks: list[int]) -> None:
        super().__init__(values)
        self.picks, self.log = picks, []

    def pick_label(self, labels):
        k = len(self.log)
        at = self.picks[k] if k < len(self.picks) else 0
        self.log.append((labels, at))
        return at


def oracle(name: str, state: dict):
    """(decision, final state) of the exact model: decision = the labels of the first run in the
    model's order (a depth-first search over every choice's alternatives: the interpreter alone
    commits to the first alternative whose own tests pass), or "no run"; None where the
    interpreter cannot run a state exactly (a quadratic root it does not solve)."""
    exact = {k: Fraction(v) if isinstance(v, float) else v for k, v in state.items()}

    def search(prefix: list[int]):
        chooser = Prescribed(exact, prefix)
        try:
            run = Interpreter(_step(name), exact=True).run(chooser, dict(exact), checked=True)
        except Blocked:
            run = None
        except Exception:  # noqa: BLE001 - not this test's subject: the oracle cannot run the state
            raise _NoOracle from None
        if run is not None:
            taken = [label for c in run.checkpoints for label in c.choices]
            if taken == [labels[at] for labels, at in chooser.log]:
                return tuple(taken), run.final
        if len(chooser.log) <= len(prefix):
            return None
        if len(prefix) > 12:
            raise _NoOracle
        labels, _ = chooser.log[len(prefix)]
        for at in range(len(labels)):
            found = search(prefix + [at])
            if found is not None:
                return found
        return None

    try:
        found = search([])
    except _NoOracle:
        return None, None
    return found if found is not None else ("no run", None)


class _NoOracle(Exception):
    pass


def _float_at(bits: int) -> float:
    """The float of an ordered 64-bit index (negative floats below positive ones)."""
    import struct

    if bits >= 0:
        return struct.unpack("<d", struct.pack("<q", bits))[0]
    return -struct.unpack("<d", struct.pack("<q", -bits))[0]


def _index(x: float) -> int:
    import struct

    b = struct.unpack("<q", struct.pack("<d", abs(x)))[0]
    return b if math.copysign(1.0, x) > 0 else -b


def boundary(name: str, state: dict, var: str, lo: float, hi: float):
    """Adjacent floats a < b of `var` between lo and hi where the exact model's decision
    changes, or None."""
    return edge(lambda x: oracle(name, {**state, var: x})[0], lo, hi)


def edge(decide, lo: float, hi: float) -> float | None:
    """Adjacent floats a < b between lo and hi where decide(x) changes, by bisection over the
    floats: a (or None where an end or a midpoint has no decision)."""
    d_lo, d_hi = decide(lo), decide(hi)
    if d_lo is None or d_hi is None or d_lo == d_hi:
        return None
    i, j = _index(lo), _index(hi)
    while j - i > 1:
        mid = (i + j) // 2
        d = decide(_float_at(mid))
        if d is None:
            return None
        if d == d_lo:
            i = mid
        else:
            j = mid
    return _float_at(i)


def check_state(name: str, state: dict) -> str:
    """The generated controller against the exact model on one state: the same decision (a
    run or none), real outputs the largest float <= the model's values, the rest equal."""
    decision, final = oracle(name, state)
    if decision is None:
        return "skipped"
    ns = module(name)
    *values, enabled = ns["controller"](*[state[v] for v in ns["INPUTS"]])
    if decision == "no run" and name in ROOTS:
        return "skipped"  # the oracle's run needs an irrational root it cannot pin: no run for it
    if decision == "no run":
        assert enabled is False, f"{name}: the exact model has no run from {state}; the code runs"
        return "no run"
    outputs = _outputs(name, len(values))
    huge = Fraction(sys.float_info.max)
    if any(o in final and _sorts(name).get(o) == REAL and abs(Fraction(final[o])) > huge for o in outputs):
        assert enabled is False, f"{name}: a real output beyond the float range from {state}: no run"
        return "beyond the float range"
    rates = [o for o in outputs if o not in final]  # x_dot of a switched plant's mode: not in the run
    big = max((abs(Fraction(v)) for v in state.values() if isinstance(v, float)), default=Fraction(0))
    if rates and not enabled and big * big > huge:
        # a rate is a product of inputs (G * fy): one beyond the float range is no run, as for any
        # real output; this only accepts "no run" where two inputs' product can leave the range
        return "beyond the float range"
    assert enabled is True, f"{name}: the exact model runs from {state} ({decision}); the code says none"
    for out, got in zip(outputs, values):
        if out not in final:  # a rate x_dot of a switched plant's mode: the decision is checked
            continue
        want = final[out]
        if _sorts(name)[out] == REAL:
            want = Fraction(want)
            assert Fraction(got) <= want < Fraction(math.nextafter(got, math.inf)), \
                f"{name}: {out} = {got!r} from {state}; the exact model gives {want} ({float(want)!r})"
        else:
            assert got == want, f"{name}: {out} = {got!r} from {state}; the exact model gives {want}"
    return "run"


def _outputs(name: str, n: int) -> list[str]:
    doc = module(name)["controller"].__doc__
    inside = doc.split("Returns (", 1)[1].split(")", 1)[0]
    names = [w.strip() for w in inside.split(",")][:-1]
    assert len(names) == n
    return names


def _value(sort, x: float):
    return x if sort == REAL else (int(x) if sort == INT else x > 0)


@st.composite
def tie_states(draw, name: str, magnitude: int = 0):
    """A state of `name`'s inputs within 2^16 ulps of a boundary of the exact model's decision
    in one real input (the others drawn at scale 10^magnitude)."""
    sorts = _sorts(name)
    inputs = module(name)["INPUTS"]
    scale = 10.0 ** magnitude
    state = {v: _value(sorts[v], draw(st.sampled_from([0.0, 1.0, 2.0, 0.5, 3.0, -1.0]))
                        * draw(st.floats(0.1, 10.0)) * (scale if sorts[v] == REAL else 1.0))
             for v in inputs}
    var = draw(st.sampled_from(_real_inputs(name)))
    for lo, hi in [(-scale * 100, scale * 100), (0.0, scale * 100), (-scale * 100, 0.0), (-1e300, 1e300)]:
        edge = boundary(name, state, var, lo, hi)
        if edge is not None:
            break
    else:
        return state  # no boundary along this input: the state itself
    ulps = draw(st.sampled_from([0, 1, 2, 3, 17, 256, 4096, 2 ** 16]))
    sign = draw(st.sampled_from([-1, 1]))
    x = _float_at(_index(edge) + sign * ulps)
    return {**state, var: x if math.isfinite(x) else edge}


@pytest.mark.parametrize("name", SCALAR)
@settings(max_examples=15, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_controller_decides_as_the_exact_model_on_ties(name, data):
    check_state(name, data.draw(tie_states(name)))


@pytest.mark.parametrize("name", SCALAR)
@settings(max_examples=8, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_controller_decides_as_the_exact_model_at_extreme_magnitudes(name, data):
    magnitude = data.draw(st.sampled_from([-300, -150, -20, 20, 150, 300]))
    check_state(name, data.draw(tie_states(name, magnitude)))


def test_train_near_tie_from_the_issue_brakes():
    """p=0.1, v=0.1, A, b=2, m, eps=1: the exact brake guard holds; the float64 guard said
    accelerate."""
    state = {"m": 0.9619708197566097, "p": 0.1, "vt": 0.1, "b": 2.0, "A": 0.9610393686260432, "eps": 1.0}
    assert oracle("textbook.train", state)[1]["a"] == -2
    assert check_state("textbook.train", state) == "run"
    assert module("textbook.train")["controller"](*state.values())[0] == -2.0


_MONITORS: dict = {}


def monitor(name: str) -> dict:
    if name not in _MONITORS:
        ns: dict = {}
        exec(compile(monitors(library.get(name)), f"<monitors {name}>", "exec"), ns)
        _MONITORS[name] = ns
    return _MONITORS[name]


def _train_brakes(state: dict) -> bool:
    """The train model's brake guard, by hand in the reals."""
    F = Fraction
    m, p, v, b, A, eps = (F(state[k]) for k in ("m", "p", "vt", "b", "A", "eps"))
    return m - p <= v * v / (2 * b) + (A / b + 1) * (A / 2 * eps * eps + eps * v)


def test_train_monitor_rejects_acceleration_in_the_brake_zone_at_large_magnitudes():
    state = {"m": 1.7293822724795268e16, "p": 0.1, "vt": 1.0, "b": 3.0, "A": 2.0 ** 30, "eps": 0.3}
    assert _train_brakes(state)
    assert monitor("textbook.train")["controller_monitor"](state, {"a": 2.0 ** 30}) is False
    assert monitor("textbook.train")["controller_monitor"](state, {"a": -3.0}) is True


@settings(max_examples=40, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_train_monitor_on_ties_accepts_exactly_the_model_command(data):
    magnitude = data.draw(st.sampled_from([0, 0, 5, 16, 100, 300]))
    state = data.draw(tie_states("textbook.train", magnitude))
    if not all(math.isfinite(v) for v in state.values()):
        return
    ok = monitor("textbook.train")["controller_monitor"]
    b, A = Fraction(state["b"]), Fraction(state["A"])
    if b == 0:
        return  # the guard divides by b: the model has no run there either way
    brakes = _train_brakes(state)
    # accelerate is taken only where brake is not (its guard is the negation): a = A iff not brakes
    assert ok(state, {"a": state["A"]}) is (not brakes or A == -b), state
    assert ok(state, {"a": -state["b"]}) is (brakes or A == -b), state


@pytest.mark.parametrize("name", SCALAR)
@settings(max_examples=6, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_monitor_accepts_the_controllers_command_on_ties(name, data):
    try:
        ns = monitor(name)
    except Exception:  # noqa: BLE001 - a model without a monitor (tests/kernel/test_monitors.py lists them)
        pytest.skip("no monitor")
    state = data.draw(tie_states(name))
    ctrl = module(name)
    *values, enabled = ctrl["controller"](*[state[v] for v in ctrl["INPUTS"]])
    if enabled and set(ns["COMMAND"]) == set(_outputs(name, len(values))):
        command = dict(zip(_outputs(name, len(values)), values))
        assert ns["controller_monitor"](state, command) is True, (name, state, command)
