"""The interpreter and the falsifier: runs, counterexamples found and re-checked, nothing
found for proved designs, prover counterexamples replayed independently."""

import json
import math
import os

import pytest

from certiloop.falsify.choosers import RandomChooser, Recording, Scripted
from certiloop.falsify.interpreter import Interpreter, Rejected
from certiloop.falsify.replay import replay_refutation
from certiloop.falsify.search import Options, falsify
from certiloop.models import library
from certiloop.models.lang.programs import assign, havoc, loop, ode, seq
from certiloop.models.lang.programs import test as check
from certiloop.models.lang.terms import And, Reals
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.engine import Budget
from certiloop.proofs.refute.unroll import refute

REFUTED = [n for n in library.names() if library.get(n).expected == "refuted"]
PROVED_SBS = ["sbs.ctrl1", "sbs.predictive", "sbs.ctrl2_2d", "sbs.ctrl2"]


def _search(name, shrink=False, **kw):
    """Shrinking (up to 15 s a model) only where a test looks at the shrunk run."""
    return falsify(library.get(name), Options(seed=0, database=None, shrink=shrink, **kw))


# ------------------------------------------------------------------ interpreter


def test_open_values_are_solved_from_the_test_that_pins_them():
    x, y, G = Reals("x y G")
    th = Theorem("t.div", And(G > 0, x == 0), seq(havoc(y), check(y * G == 1), assign(x, y * G)),
                 x == 1, expected="proved")
    run = Interpreter(th).run(RandomChooser(1))
    last = run.checkpoints[-1].state
    assert run.violated is None and last["x"] == pytest.approx(1)
    assert last["y"] == pytest.approx(1 / last["G"])


def test_open_reals_are_drawn_within_the_bounds_their_test_sets():
    """`u := *; ?(-w/2 <= u & u <= w/2)`: u is drawn where the test lets it be (w known),
    so no run blocks there; the test still decides (a violation needs u within 1/1000 of
    w/2, which a draw from [-10, 10] would almost never hit)."""
    u, w, x = Reals("u w x")
    th = Theorem("t.range", And(w > 0, w <= 1, x == 0),
                 seq(havoc(u), check(And(-w / 2 <= u, u <= w / 2)), assign(x, u)),
                 x < w / 2 - 0.001, expected="refuted")
    interp = Interpreter(th)
    started = 0
    for seed in range(60):
        try:
            run = interp.run(RandomChooser(seed))  # a blocked test raises Blocked, not this
        except Rejected:  # the drawn start state missed the assumptions
            continue
        started += 1
        last = run.checkpoints[-1].state
        assert -last["w"] / 2 <= last["u"] <= last["w"] / 2
    assert started >= 30
    found = falsify(th, Options(seed=0, database=None, shrink=False, batch_runs=0, max_examples=200))
    assert found.found and found.check == "replayed in exact rational arithmetic"
    state = found.run.checkpoints[-1].state
    assert state["x"] >= state["w"] / 2 - 0.001  # checked here, independently of the search


def test_flows_follow_the_exact_solution_and_stop_at_the_domain_edge():
    h, v, g = Reals("h v g")
    fall = ode({h: v, v: -g}, h >= 0)
    th = Theorem("t.fall", And(h == 2, v == 0, g == 1), loop(fall), h >= 0, expected="proved")
    interp = Interpreter(th, max_steps=1)
    for seed in range(20):
        run = interp.run(RandomChooser(seed))
        end = run.checkpoints[-1]
        # h(t) = 2 - t²/2 leaves h >= 0 at t = 2
        assert 0 <= end.time <= 2 + 1e-9
        assert end.state["h"] == pytest.approx(2 - end.time**2 / 2, abs=1e-7)  # the trace keeps 9 digits


def test_non_polynomial_flows_are_integrated_with_events():
    x, = Reals("x")
    th = Theorem("t.decay", x == 1, loop(ode({x: -x}, x >= 0.5)), x >= 0.5, expected="proved")
    interp = Interpreter(th, max_steps=1)
    times = [interp.run(RandomChooser(s)).checkpoints[-1] for s in range(10)]
    for c in times:
        assert c.state["x"] == pytest.approx(math.exp(-c.time), rel=1e-5)
        assert c.time <= math.log(2) + 1e-6


def test_a_recorded_run_replays_exactly():
    th = library.get("textbook.water_tank_late_check")
    rec = Recording(RandomChooser(3))
    run = Interpreter(th).run(rec)
    exact = Interpreter(th, exact=True).run(Scripted(rec.script))
    assert len(exact.checkpoints) == len(run.checkpoints)
    assert exact.checkpoints[-1].state["x"] == pytest.approx(run.checkpoints[-1].state["x"])


def test_initial_states_satisfy_the_assumptions_or_are_rejected():
    th = library.get("sbs.ctrl2")
    interp = Interpreter(th, max_steps=1)
    accepted = 0
    for seed in range(30):
        try:
            run = interp.run(RandomChooser(seed))
        except Rejected:
            continue
        accepted += 1
        start = run.checkpoints[0].state
        for j, nx in start["nx"].items():
            n2 = nx**2 + start["ny"][j] ** 2 + start["nz"][j] ** 2
            assert n2 == pytest.approx(1)
    assert accepted >= 20


# ------------------------------------------------------------------ search


# a violating run needs an irrational flow time (the ball lands at t = sqrt(2h/g), where
# `h = 0` must hold exactly to bounce): no exact replay can take it, so falsify can only
# report it as an unconfirmed candidate (the prover refutes it)
FLOAT_ONLY_RUNS = {"textbook.bouncing_ball_superelastic"}


@pytest.mark.parametrize("name", REFUTED)
def test_every_refuted_model_is_falsified(name):
    result = _search(name, max_examples=2000)
    if name in FLOAT_ONLY_RUNS:
        assert not result.found and result.verdict == "unconfirmed candidate", result.check
        assert "not validated" in result.check
        return
    assert result.found, f"{name}: no counterexample in {result.examples} examples"
    assert result.check, "a reported counterexample must have been re-checked"
    assert result.run.checkpoints[-1].margins and min(result.run.checkpoints[-1].margins.values()) < 0


def test_eqn12_counterexample_has_planes_at_an_acute_angle():
    result = _search("sbs.eqn12", max_examples=2000)
    s = result.run.checkpoints[-1].state
    assert s["nix"] * s["njx"] + s["niy"] * s["njy"] < 0


def test_predictive_multi_counterexample_has_planes_facing_each_other():
    result = _search("sbs.predictive_multi", max_examples=2000)
    s = result.run.checkpoints[-1].state
    assert s["nx1"] * s["nx2"] + s["ny1"] * s["ny2"] < 0


def test_immediate_control_crosses_the_buffer_within_one_step():
    result = _search("sbs.immediate", max_examples=2000, shrink=True)
    before, after = result.run.checkpoints[-2], result.run.checkpoints[-1]
    assert before.state["py"] >= 0 > after.state["py"]
    # the trace's state keeps 9 digits; the run's unrounded final state has the exact e
    assert after.step == before.step + 1 and after.time - before.time <= result.run.final["e"] + 1e-12


# 500 runs per proved design by default; the deep run (HYPOTHESIS_PROFILE=deep) tries 5000
PROVED_RUNS = 5000 if os.environ.get("HYPOTHESIS_PROFILE") == "deep" else 500


@pytest.mark.parametrize("name", PROVED_SBS)
def test_proved_designs_have_no_counterexample(name):
    result = _search(name, max_examples=PROVED_RUNS, families=(1, 8))
    assert not result.found, result.run and result.run.violated
    assert result.examples >= PROVED_RUNS


def test_float_noise_at_a_boundary_is_not_a_counterexample():
    # the bouncing ball lands on h = 0 by root finding (h = ±1e-16): never reported
    result = _search("textbook.bouncing_ball", max_examples=500)
    assert not result.found


# ------------------------------------------------------------------ replay of the prover


@pytest.mark.parametrize("name", REFUTED)
def test_prover_counterexamples_replay_in_the_interpreter(name):
    theorem = library.get(name)
    refutation, why = refute(theorem, Budget())
    assert refutation is not None, why
    outcome = replay_refutation(theorem, refutation)
    assert outcome.violated, outcome.message


def test_a_tampered_counterexample_does_not_replay():
    theorem = library.get("textbook.water_tank_late_check")
    refutation, _ = refute(theorem, Budget())
    start = refutation.raw_initial
    assert replay_refutation(theorem, refutation).violated
    far = start["lo"] + 10**6 * (1 + abs(start["r"]) * start["eps"])  # no period can fill that much
    refutation.raw_initial = {**start, "x": start["lo"], "hi": far}
    assert not replay_refutation(theorem, refutation).violated


# ------------------------------------------------------------------ CLI


def test_cli_falsify_json_plot_and_exit_codes(tmp_path):
    from certiloop.cli import main

    out_json, out_png = tmp_path / "f.json", tmp_path / "f.png"
    code = main(["falsify", "textbook.water_tank_late_check", "--max-examples", "200",
                 "--json", str(out_json), "--plot", str(out_png), "--database", str(tmp_path / "db")])
    assert code == 1
    data = json.loads(out_json.read_text())
    assert data["model"] == "textbook.water_tank_late_check" and data["verdict"] == "refuted"
    assert data["counterexample"]["trace"] and data["counterexample"]["violated"]
    assert out_png.read_bytes()[:4] == b"\x89PNG"
    assert main(["falsify", "textbook.water_tank", "--max-examples", "50", "--database", "none"]) == 0


@pytest.mark.parametrize("argv", [["falsify", "sbs.nope"], ["falsify", "sbs.ctrl1", "--max-examples", "0"],
                                  ["falsify", "sbs.ctrl1", "--plot", "x.pdf"]])
def test_cli_falsify_bad_input_exits_2(argv, capsys):
    from certiloop.cli import main

    assert main(argv) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_the_search_does_not_depend_on_what_the_process_imported(tmp_path, monkeypatch):
    """Hypothesis draws now and then a constant harvested from every local module imported
    so far; the falsifier pins that pool to the model's own numbers, so importing a module
    full of numbers between two searches changes nothing (it once made `gate m` fail where
    the whole gate passed)."""
    theorem = library.get("textbook.bouncing_ball_superelastic")
    opts = Options(max_examples=300, seed=3, database=None, shrink=False)
    before = falsify(theorem, opts)
    numbers = ", ".join(f"{k}.{k % 7}5" for k in range(400))
    (tmp_path / "numbers_galore.py").write_text(f"VALUES = [{numbers}, -3, 7, 1e9, 0.5]\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import numbers_galore  # noqa: F401  (imported for its constants)

    after = falsify(theorem, opts)
    assert (after.found, after.examples) == (before.found, before.examples)
    assert after.script == before.script


def test_after_a_clean_batch_phase_hypothesis_runs_the_smaller_budget():
    """The gate's budget for a safe model: once the batch phase swept its runs and found
    nothing, hypothesis runs `after_batch_examples`; without a batch phase, all of them."""
    train = library.get("textbook.train")
    opts = dict(max_examples=60, seed=0, database=None, shrink=False)
    full = falsify(train, Options(batch_runs=256, **opts))
    cut = falsify(train, Options(batch_runs=256, after_batch_examples=7, **opts))
    assert not full.found and not cut.found
    # examples count every run tried, rejected ones too (hypothesis counts only valid ones)
    assert full.examples - 256 >= 60 > cut.examples - 256 > 0
    unswept = falsify(train, Options(batch_runs=0, after_batch_examples=7, **opts))
    assert not unswept.found and unswept.examples >= 60


def test_the_gate_keeps_the_full_budget_for_mutants(monkeypatch):
    from certiloop.api import gate_run as gate

    seen = {}
    monkeypatch.setattr("certiloop.falsify.search.falsify", lambda th, o: seen.setdefault(th.name, o))
    opts = gate.GateOptions(falsify_examples=300)
    gate.falsify_task(library.get("textbook.train"), opts)
    gate.falsify_task(library.get("textbook.train_no_lookahead"), opts)
    safe = seen["textbook.train"]
    assert safe.after_batch_examples == 100 and safe.batch_first == safe.batch_runs  # one round
    mutant = seen["textbook.train_no_lookahead"]
    assert mutant.after_batch_examples is None and mutant.max_examples == 300 * gate.REFUTED_FACTOR
    assert mutant.batch_first is None  # small rounds first: an easy counterexample at once


@pytest.mark.parametrize("first, rounds", [(256, [256, 1024, 2816]), (4096, [4096])])
def test_the_batch_phase_grows_its_rounds_from_the_first(monkeypatch, first, rounds):
    """All the runs either way; a search expected to find nothing draws them in one round."""
    from certiloop.falsify.batch import phase as bs
    drawn = []
    monkeypatch.setattr(bs, "_split", lambda runs, sizes: drawn.append(runs) or [(sizes[0], runs)])
    outcome = bs.batch_search(library.get("textbook.train"), 4096, 0, 3, (1, 8), first=first)
    assert drawn == rounds and outcome.runs == 4096 and outcome.run is None
