"""The interpreter's vectorised flow paths (flows._VectorFlow, flows._last_inside_fast,
watch.ManyMargins) against independent witnesses: the scalar grid of `_last_inside` over
whole states built by `Flow.at`, the scalar domain margin at the chosen duration, the
interpreter's own `margins`, and whole runs with the fast paths switched off."""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import certiloop.falsify.flows as flows
import certiloop.falsify.initial as initial
import certiloop.falsify.interpreter as interpreter
from certiloop.falsify.choosers import RandomChooser, Recording, Scripted
from certiloop.falsify.evaluate import Blocked, Compiler, Table
from certiloop.falsify.flows import Flow, _last_inside, _last_inside_fast, _Undecided
from certiloop.falsify.interpreter import Interpreter, Rejected
from certiloop.falsify.vectorise import Unsupported
from certiloop.falsify.watch import ManyMargins
from certiloop.models import library
from certiloop.models.lang.programs import loop, ode
from certiloop.models.lang.terms import INT, And, Family, IndexSort, Reals, Var, select
from certiloop.models.lang.theorem import Theorem

h, v, g, p, f, fp, t, e, k = Reals("h v g p f fp t e k")
FLOWS = {
    "fall": ode({h: v, v: -g}, h >= 0),
    "ctrl2-like": ode({p: 2 * f * k, f: fp, t: 1}, And(t <= e, p >= -1)),
    "speed-bound": ode({p: v, v: fp}, And(v >= 0, v <= 3, t <= e)),
}
HORIZON = 10.0
small = st.floats(-5, 5, allow_nan=False, allow_subnormal=False)
edge_or_small = st.one_of(st.just(0.0), small)


def _witness(flow: Flow, state: dict) -> float:
    """The scalar path as it was: the domain's margin on whole states from `Flow.at`."""
    return _last_inside(lambda tau: flow.domain(flow.at(state, tau)), 0.0, HORIZON, depth=0)


def _state(name, data):
    names = sorted({x.payload for x in (*FLOWS[name].variables,)} | {"g", "e", "k", "fp", "t", "v"})
    return {n: data.draw(edge_or_small if n in ("h", "t", "v") else small, label=n) for n in names}


@settings(max_examples=300)
@given(st.sampled_from(sorted(FLOWS)), st.data())
def test_the_vectorised_exit_time_is_the_scalar_grids(name, data):
    flow = Flow(FLOWS[name], Compiler())
    state = _state(name, data)
    assume(flow.domain_holds(state))
    assert flow.vector is not None
    env = flow.vector.env(state)
    witness = _witness(flow, state)
    fast = flow._exit_time(state, HORIZON, env)
    assert fast == pytest.approx(witness, rel=1e-9, abs=1e-12)
    assert 0.0 <= fast <= HORIZON
    # the domain, evaluated by the scalar closures on the whole state, holds where the flow may stop
    assert flow.domain(flow.at(state, fast)) >= -1e-9


@settings(max_examples=200)
@given(st.sampled_from(sorted(FLOWS)), st.data(), st.floats(0, 1))
def test_a_run_never_gets_a_duration_the_scalar_domain_forbids(name, data, share):
    flow = Flow(FLOWS[name], Compiler())
    state = _state(name, data)
    assume(flow.domain_holds(state))
    end, tau, samples = flow.run(state, lambda settle: settle(share), HORIZON)
    assert 0.0 <= tau <= _witness(flow, state) * (1 + 1e-9) + 1e-12
    assert flow.domain(flow.at(state, tau)) >= -1e-9
    assert end == flow.at(state, tau)
    assert [s for _, _, s in samples] == [None] * len(samples)  # no watch: no margins


def test_the_fast_grid_defers_to_the_scalar_margin_where_they_disagree():
    g_scalar = lambda tau: 1.0 - tau  # noqa: E731 - leaves at 1
    lying = lambda times: np.where(times > 0.5, -1.0, 1.0)  # says it leaves at 0.5  # noqa: E731
    with pytest.raises(_Undecided):
        _last_inside_fast(lying, g_scalar, 0.0, 2.0, depth=0)
    with pytest.raises(_Undecided):
        _last_inside_fast(lambda times: np.full(times.shape, np.nan), g_scalar, 0.0, 2.0, depth=0)
    # near 0 the scalar margin decides: grid values of -1e-12 next to the exit are not trusted
    near = lambda times: np.where(np.abs(times - 1.0) < 0.02, -1e-12, 1.0 - times)  # noqa: E731
    assert _last_inside_fast(near, g_scalar, 0.0, 2.0, 0) == _last_inside(g_scalar, 0.0, 2.0, 0)
    assert _last_inside_fast(near, g_scalar, 0.0, 2.0, 0) == pytest.approx(1.0, abs=1e-12)


def test_a_late_exit_is_located_on_the_vectorised_grid(monkeypatch):
    flow = Flow(FLOWS["fall"], Compiler())
    state = {"h": 40.0, "v": 0.0, "g": 1.0}  # h = 40 - t²/2 leaves h >= 0 at t = sqrt(80): late
    called = []
    margins = flows._VectorFlow.margins

    def spy(self, env, times):
        called.append(times)
        return margins(self, env, times)
    monkeypatch.setattr(flows._VectorFlow, "margins", spy)
    fast = flow._exit_time(state, HORIZON, flow.vector.env(state))
    assert len(called) == 1 and fast == _witness(flow, state) == pytest.approx(math.sqrt(80), abs=1e-9)


def test_an_undecided_grid_falls_back_to_the_scalar_path(monkeypatch):
    flow = Flow(FLOWS["fall"], Compiler())
    state = {"h": 40.0, "v": 0.0, "g": 1.0}
    monkeypatch.setattr(flows._VectorFlow, "margins", lambda self, env, times: np.full(times.shape, np.nan))
    fast = flow._exit_time(state, HORIZON, flow.vector.env(state))
    assert fast == _witness(flow, state) == pytest.approx(math.sqrt(80))


def test_unsupported_constructs_keep_the_scalar_path(monkeypatch):
    B = IndexSort("B")
    rx, i = Family("rx", B), Var("i", B)
    x, = Reals("x")
    flow = Flow(ode({x: 1}, x <= select(rx, i)), Compiler())  # a family cell in the domain
    assert flow.vector is None
    state = {"x": 0.0, "i": 0, "rx": Table({(0,): 3.0})}
    calls = []
    monkeypatch.setattr(flows, "_last_inside_fast", lambda *a, **kw: calls.append(a))
    end, tau, _ = flow.run(state, lambda settle: settle(1.0), HORIZON)
    assert calls == [] and tau == pytest.approx(3.0) and end["x"] == pytest.approx(3.0)
    monkeypatch.undo()
    # a guarantee the vectorised watch does not compile (an integer): the interpreter's own watch
    n = Var("n", INT)
    with pytest.raises(Unsupported):
        ManyMargins(And(h >= 0, n >= 0))
    th = Theorem("t.fall_int", And(h == 2, v == 0, g == 1, n == 1), loop(FLOWS["fall"]), And(h >= 0, n >= 0),
                 expected="proved")
    interp = Interpreter(th, max_steps=1)
    run = interp.run(RandomChooser(1))
    assert interp._many_margins() is None
    assert run.samples and all(set(m) == {"h >= 0", "n >= 0"} for _, m, _ in run.samples)


WATCHED = ["sbs.ctrl2", "sbs.ctrl2_dynamic", "sbs.predictive", "textbook.train", "textbook.bouncing_ball"]


@pytest.mark.parametrize("name", WATCHED)
def test_the_vectorised_watch_gives_the_interpreters_margins(name):
    th = library.get(name)
    interp = Interpreter(th)
    many = interp._many_margins()
    assert many is not None
    compared = 0
    for seed in range(25):
        try:
            run = interp.run(RandomChooser(seed))
        except (Rejected, Blocked, ArithmeticError):
            continue
        for ode_, before, tau, _after in run.closed_form_flows:
            flow = interp._flows[id(ode_)]
            times = np.linspace(0.0, float(tau), flows.WATCH_SAMPLES)
            env = flow.vector.env(before)
            labels, table = many(before, times, flow.vector.values(env, times))
            for col, tau_k in enumerate(times):
                witness = interp.margins(flow.at(before, float(tau_k)))  # the scalar closures
                assert labels == list(witness)
                for row, label in enumerate(labels):
                    assert table[row, col] == pytest.approx(witness[label], rel=1e-9, abs=1e-9)
                compared += 1
    assert compared > 50


@pytest.mark.parametrize("name", ["sbs.ctrl2", "sbs.ctrl2_dynamic", "sbs.ctrl1", "textbook.train",
                                  "textbook.bouncing_ball"])
def test_runs_are_the_same_with_and_without_the_fast_paths(name, monkeypatch):
    th = library.get(name)

    def runs():
        interp, out = Interpreter(th), []
        for seed in range(30):
            rec = Recording(RandomChooser(seed))
            try:
                run = interp.run(rec)
            except (Rejected, Blocked, ArithmeticError) as exc:
                out.append(type(exc).__name__)
                continue
            out.append((rec.script, [(c.time, c.margins, c.state) for c in run.checkpoints],
                        [(tau, sorted(m)) for tau, m, _ in run.samples],
                        [[m[k] for k in sorted(m)] for _, m, _ in run.samples]))
        return out

    fast = runs()
    monkeypatch.setattr(Flow, "vector", property(lambda self: None))
    monkeypatch.setattr(Interpreter, "_many_margins", lambda self: None)
    monkeypatch.setattr(initial, "_bound_indices", lambda atom, env: False)  # nothing remembered
    slow = runs()
    assert sum(isinstance(x, tuple) for x in fast) >= 10
    for a, b in zip(fast, slow, strict=True):
        if not isinstance(a, tuple):
            assert a == b
            continue
        assert a[:3] == b[:3]  # the same decisions, durations, checkpoints and sample labels
        for x, y in zip(a[3], b[3]):  # sample margins (plots): equal up to rounding
            assert x == pytest.approx(y, rel=1e-9, abs=1e-9)


def test_the_compiler_remembers_nodes_by_identity_within_a_bound(monkeypatch):
    import certiloop.falsify.evaluate as evaluate

    c = Compiler()
    a, b = h + v, h + v  # equal keys, distinct objects
    assert c(a) is c(b) is c(a)
    monkeypatch.setattr(evaluate, "BY_ID_LIMIT", 2)
    for x in range(5):
        c(h * x)
    assert len(c._by_id) <= 2
    assert c(h * 3)({"h": 2.0}) == 6.0
    assert math.isfinite(c(a)({"h": 1.0, "v": 2.0}))


@pytest.mark.parametrize("name", ["sbs.ctrl2", "sbs.ctrl2_dynamic", "textbook.train"])
def test_interpreters_of_one_theorem_share_its_model_and_replay_alike(name, monkeypatch):
    th = library.get(name)
    first, second = Interpreter(th, exact=True), Interpreter(th, exact=True)
    assert first.c is second.c and first._flows is second._flows and Interpreter(th).c is not first.c
    scripts = []
    floats = Interpreter(th)
    for seed in range(20):
        rec = Recording(RandomChooser(seed))
        try:
            floats.run(rec)
        except (Rejected, Blocked, ArithmeticError):
            continue
        scripts.append(rec.script)
    assert len(scripts) >= 5

    def replays():
        out = []
        for script in scripts:  # a new exact interpreter per replay, as the search's confirm does
            try:
                run = Interpreter(th, exact=True).run(Scripted(script))
                out.append([(c.time, c.state, c.margins) for c in run.checkpoints])
            except Exception as exc:  # noqa: BLE001 - compared below, whatever it is
                out.append(type(exc).__name__)
        return out

    shared = replays()
    cached = interpreter._model

    def fresh(t, exact):  # every interpreter computes its own closures, parts, symbols and flows
        interpreter._MODELS.clear()
        return cached(t, exact)
    monkeypatch.setattr(interpreter, "_model", fresh)
    monkeypatch.setattr(initial, "_bound_indices", lambda atom, env: False)
    assert replays() == shared
