"""The falsifier's vectorised batch phase: it agrees with the tree-walking interpreter run
by run, a batch hit is reported only once the interpreter replays it to a violation, the
same seed gives the same verdict, and models it cannot compile keep the old search."""

import numpy as np
import pytest

from certiloop.falsify.batch.phase import batch_search, confirm_candidate
from certiloop.falsify.batch.program import Batch, BatchProgram, compiled
from certiloop.falsify.choosers import Diverged, Scripted
from certiloop.falsify.evaluate import Blocked
from certiloop.falsify.flows import exact_view
from certiloop.falsify.interpreter import Interpreter
from certiloop.falsify.search import Options, falsify
from certiloop.falsify.vectorise import Unsupported
from certiloop.models import library
from certiloop.proofs.core.exact import truth

CLOSED_FORM = ["textbook.train", "textbook.bouncing_ball", "textbook.water_tank_late_check",
               "raven.deviation_stop", "sbs.predictive_multi", "rcm.axial_euler_4ms", "sbs.immediate"]


def _replays(name: str, seed: int, runs: int = 120):
    """(run index, the interpreter's run of the same initial state and decisions) for every
    completed run of a batch; None where the interpreter's run went another way."""
    theorem = library.get(name)
    batch = compiled(theorem, 3).simulate(np.random.default_rng(seed), runs)
    interp = Interpreter(theorem, max_steps=3)
    out = []
    for r in np.flatnonzero(batch.completed):
        try:
            out.append((int(r), interp.run(Scripted(batch.script(int(r))), batch.initial_state(int(r)))))
        except (Diverged, Blocked):
            out.append((int(r), None))
    return batch, out


def _agree(batch: Batch, r: int, run, rel: float) -> None:
    assert (run.violated is not None) == bool(batch.violated[r])
    compared = 0
    for name, value in run.final.items():
        mine = batch.final.get(name)
        if isinstance(value, float) and mine is not None and not np.isnan(mine[r]):
            assert mine[r] == pytest.approx(value, rel=rel, abs=rel), name
            compared += 1
    assert compared > 0


@pytest.mark.parametrize("name", CLOSED_FORM)
@pytest.mark.parametrize("seed", [1, 7])
def test_batch_runs_agree_with_the_interpreter(name, seed):
    batch, replays = _replays(name, seed)
    assert len(replays) >= 20, "too few runs got through the assumptions and tests"
    assert all(run is not None for _, run in replays), "the interpreter took another path"
    for r, run in replays:
        _agree(batch, r, run, 1e-9)


def test_flows_without_closed_form_agree_where_the_interpreter_follows_them():
    """sbs.ctrl1's slow zone (py' = G py fy / D) is integrated by RK4 in the batch and by
    scipy in the interpreter: the same path for most runs, the same states to 1e-4."""
    batch, replays = _replays("sbs.ctrl1", 3, runs=200)
    followed = [(r, run) for r, run in replays if run is not None]
    assert len(followed) >= 0.7 * len(replays) and len(followed) >= 20
    for r, run in followed:
        _agree(batch, r, run, 1e-4)


def test_a_candidate_that_does_not_replay_is_never_reported(monkeypatch):
    """Every run of a safe model made a candidate: none replays to a violation."""
    theorem = library.get("textbook.train")

    def everything(self):
        return [int(r) for r in np.flatnonzero(self.completed)]
    monkeypatch.setattr(Batch, "candidates", everything)
    outcome = batch_search(theorem, 600, 0, 3, (1, 8))
    assert outcome.run is None and outcome.runs == 600
    assert not falsify(theorem, Options(max_examples=30, seed=0, database=None, shrink=False,
                                        batch_runs=600)).found


def test_confirmation_rejects_a_tampered_candidate():
    theorem = library.get("textbook.train_no_lookahead")
    batch = compiled(theorem, 3).simulate(np.random.default_rng(0), 400)
    r = batch.candidates()[0]
    initial, script = batch.initial_state(r), batch.script(r)
    run, check = confirm_candidate(theorem, initial, script, 3, (1, 8))
    assert run is not None and "exact" in check
    durations = [(k, 0.0 if k == "duration" else v) for k, v in script]  # the train never moves
    assert confirm_candidate(theorem, initial, durations, 3, (1, 8)) == (None, "")


@pytest.mark.parametrize("name", ["textbook.train_no_lookahead", "rcm.axial_guard_half_margin",
                                  "raven.deviation_small_margin", "sbs.ctrl1_broken"])
def test_batch_counterexamples_violate_the_guarantee_exactly(name):
    """The reported run, replayed exactly from its initial state and script, ends in a state
    where the proof engine's own evaluator (not the interpreter's) finds the guarantee false."""
    theorem = library.get(name)
    result = falsify(theorem, Options(seed=0, database=None, shrink=False))
    assert result.found and result.phase == "batch"
    if "exact" not in result.check:
        return
    from certiloop.falsify.batch.phase import exact_initial

    interp = Interpreter(theorem, exact=True)
    run = interp.run(Scripted(result.script), exact_initial(theorem, result.initial, interp.c))
    assert run.violated is not None
    assert truth(theorem.guarantee, exact_view(run.final)) is False


def test_the_same_seed_gives_the_same_search():
    theorem = library.get("raven.deviation_haptic_only")
    a, b = (batch_search(theorem, 2000, 5, 3, (1, 8)) for _ in range(2))
    assert a.run is not None
    assert (a.runs, a.initial, a.script, a.check) == (b.runs, b.initial, b.script, b.check)
    c = batch_search(theorem, 2000, 6, 3, (1, 8))
    assert (c.runs, c.initial) != (a.runs, a.initial)
    opts = Options(seed=5, database=None, shrink=False)
    first, second = (falsify(theorem, opts).to_json() for _ in range(2))
    first.pop("seconds"), second.pop("seconds")
    assert first == second


def test_models_outside_the_fragment_keep_the_hypothesis_search():
    theorem = library.get("cfmpa.early_arrival")  # its assumptions read arrays: no batch of either kind
    with pytest.raises(Unsupported):
        BatchProgram(theorem)
    assert batch_search(theorem, 1000, 0, 3, (1, 8)).unsupported
    plain = falsify(theorem, Options(max_examples=200, seed=0, database=None, shrink=False, batch_runs=0))
    batched = falsify(theorem, Options(max_examples=200, seed=0, database=None, shrink=False))
    assert batched.phase == "hypothesis"
    assert (plain.found, plain.examples, plain.script) == (batched.found, batched.examples, batched.script)


def test_safe_models_give_no_batch_counterexample():
    for name in ["textbook.train", "textbook.bouncing_ball", "raven.deviation_stop", "sbs.predictive"]:
        outcome = batch_search(library.get(name), 4096, 0, 3, (1, 8))
        assert outcome.run is None and outcome.started > 1000, name
