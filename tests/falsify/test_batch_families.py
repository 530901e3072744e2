"""The batch simulator on models with families over an index sort (sbs.ctrl2's boundaries):
every batch run replays in the interpreter to the same decisions, states and verdict; each
construct (family cells, foreach, ∀/∃ over the index sort, Boolean families chosen element
by element, the index chosen cyclically) on a small model of its own; mutants of ctrl2 are
refuted in the batch phase, and only after the interpreter replayed the run."""

import numpy as np
import pytest

from certiloop.falsify.batch.phase import BATCH_SIZE, _grow, _split, batch_search
from certiloop.falsify.batch.program import BatchProgram, compiled
from certiloop.falsify.choosers import Diverged, RandomChooser, Scripted
from certiloop.falsify.evaluate import Blocked, Compiler, Table
from certiloop.falsify.interpreter import Interpreter
from certiloop.falsify.search import Options, falsify
from certiloop.falsify.vectorise import Unsupported, VCompiler
from certiloop.models import library
from certiloop.models.lang.conveniences import foreach
from certiloop.models.lang.programs import assign, havoc, seq
from certiloop.models.lang.programs import test as check
from certiloop.models.lang.terms import BOOL, INT, TRUE, And, Exists, Family, ForAll, IndexSort, Or, Real, Var
from certiloop.models.lang.theorem import Theorem

B = IndexSort("B")
x, done, flag = Family("x", B), Family("done", B, BOOL), Family("flag", B, BOOL)
i, j = Var("i", B), Var("j", B)
s, y = Real("s"), Real("y")


def _replay_all(theorem: Theorem, elements: int, runs: int = 40, seed: int = 0):
    """The batch, and the interpreter's run of every completed batch run's initial state and
    script (None where the replay went another way)."""
    batch = compiled(theorem, 3).simulate(np.random.default_rng(seed), runs, elements)
    interp = Interpreter(theorem, max_steps=3)
    out = []
    for r in map(int, np.flatnonzero(batch.completed)):
        try:
            out.append((r, interp.run(Scripted(batch.script(r)), batch.initial_state(r))))
        except (Diverged, Blocked):
            out.append((r, None))
    return batch, out


def _agree(batch, r: int, run) -> int:
    """Same verdict, same final values (symbols and family cells); how many were compared."""
    assert (run.violated is not None) == bool(batch.violated[r])
    compared = 0
    for name, value in run.final.items():
        mine = batch.final.get(name)
        if mine is None:
            continue
        cells = value.cells.items() if isinstance(value, Table) else [((None,), value)]
        for (k,), v in cells:
            got = mine[r] if k is None else mine[r, k]
            if isinstance(v, (bool, float)) and not np.isnan(got):
                assert got == pytest.approx(float(v), rel=1e-9, abs=1e-9), (name, k)
                compared += 1
    return compared


@pytest.mark.parametrize("name,elements", [("sbs.ctrl2_2d", 1), ("sbs.ctrl2", 3), ("sbs.ctrl2", 8),
                                           ("sbs.ctrl2_dynamic", 4), ("sbs.ctrl2_last_wins", 2),
                                           ("sbs.ctrl2_dynamic_join_anywhere", 5),
                                           ("raven.deviation_stop_3d", 3)])
def test_family_runs_agree_with_the_interpreter(name, elements):
    batch, replays = _replay_all(library.get(name), elements)
    assert len(replays) >= 20, "too few runs got through the assumptions and tests"
    assert all(run is not None for _, run in replays), "the interpreter took another path"
    for r, run in replays:
        assert _agree(batch, r, run) > elements  # family cells compared, not only scalars


def _theorem(name, assumptions, program, guarantee) -> Theorem:
    return Theorem(name, assumptions, program, guarantee, expected="refuted")


def test_foreach_visits_every_element_once():
    """`foreach` over the family: s sums x over the elements, whatever order the batch drew;
    the script has one flag per element (done := *; ?∀j ¬done(j)) and one index per step."""
    body = assign(s, s + x(i))
    program = seq(assign(s, 0), foreach(i, done, body, TRUE))
    theorem = _theorem("t.sum", ForAll(j, x(j) >= -1), program, s <= 5)
    batch, replays = _replay_all(theorem, 4, runs=60)
    assert len(replays) >= 40
    for r, run in replays:
        assert batch.final["s"][r] == pytest.approx(batch.initial["x"][r].sum())
        assert [k for k, _ in batch.script(r)] == ["integer"] * 8
        assert _agree(batch, r, run)
    assert 0 < batch.violated.sum() < batch.completed.sum()


def test_quantifiers_over_the_index_sort_match_the_interpreter():
    """∀/∃ over the index sort, compiled once for the batch, against the interpreter's own
    closures on the same states, run by run."""
    vc, c = VCompiler(), Compiler()
    vc.size = 3
    rng = np.random.default_rng(4)
    xs, ys = rng.uniform(-1, 1, (50, 3)), rng.uniform(-1, 1, 50)
    formulas = [ForAll(j, x(j) <= y), Exists(j, x(j) > y), Or(ForAll(j, x(j) >= 0), y > 0.5),
                And(ForAll(j, x(j) > -0.9), Exists(j, x(j) * y >= 0))]
    for f in formulas:
        got = np.broadcast_to(vc(f)({"x": xs, "y": ys}), (50,))
        for r in range(50):
            state = {"x": Table({(k,): float(v) for k, v in enumerate(xs[r])}), "y": float(ys[r]),
                     "#universe:B": range(3)}
            assert bool(got[r]) == bool(c(f)(state)), (f, r)


def test_exists_in_a_test_blocks_exactly_the_runs_without_a_witness():
    program = seq(check(Exists(j, x(j) > 5)), assign(s, 1))
    theorem = _theorem("t.exists", ForAll(j, x(j) >= -10), program, s <= 0)
    batch = compiled(theorem, 3).simulate(np.random.default_rng(2), 200, 3)
    witness = (batch.initial["x"] > 5).any(axis=1)
    assert np.array_equal(batch.completed, batch.accepted & witness)
    assert np.array_equal(batch.violated, batch.completed)  # s = 1 after the test


def test_an_element_is_chosen_from_the_drawn_one_on_cyclically():
    """`i := *; ?x(i) > 0`: the first element with x > 0 from the drawn start on, as
    interpreter.candidates orders them; no such element: the run blocks."""
    program = seq(havoc(i), check(x(i) > 0), assign(s, x(i)))
    theorem = _theorem("t.pick", ForAll(j, x(j) >= -10), program, s <= 9)
    batch, replays = _replay_all(theorem, 5, runs=100)
    xs = batch.initial["x"]
    assert np.array_equal(batch.completed, batch.accepted & (xs > 0).any(axis=1))
    for r, run in replays:
        first = batch.script(r)[0][1]
        picked = next((first + k) % 5 for k in range(5) if xs[r, (first + k) % 5] > 0)
        assert batch.final["i"][r] == picked and batch.final["s"][r] == xs[r, picked]
        assert _agree(batch, r, run)


def test_booleans_chosen_element_by_element_and_backtracking_runs_dropped():
    """`flag := *; ?(∀j flag(j)) ∧ y > 0`: each flag(j) is tried drawn value first; where
    y <= 0 the test fails after the flags were accepted, and the interpreter would go back
    over them: the batch drops such runs (never completed, never reported)."""
    program = seq(havoc(flag), check(And(ForAll(j, flag(j)), y > 0)), assign(s, y))
    theorem = _theorem("t.flags", y >= -10, program, s <= 5)
    batch, replays = _replay_all(theorem, 3, runs=120)
    ys = batch.initial["y"]
    assert not (batch.completed & (ys <= 0)).any()
    assert np.array_equal(batch.completed, batch.accepted & (ys > 0))
    for r, run in replays:
        assert run is not None and _agree(batch, r, run)
        assert (batch.final["flag"][r] == 1).all()


def test_what_does_not_compile_says_why():
    C = IndexSort("C")
    k = Var("k", C)
    cases = {
        "not a family of reals or Booleans": ForAll(j, Family("c", B, INT)(j) >= 0),
        "more than one index sort": And(ForAll(j, x(j) >= 0), ForAll(k, Family("z", C)(k) >= 0)),
        "a quantifier over": ForAll(Real("t_"), Real("t_") * 0 <= 1),
    }
    for why, assumptions in cases.items():
        theorem = Theorem("t.no", assumptions, assign(s, 1), s >= 0)
        with pytest.raises(Unsupported, match=why):
            BatchProgram(theorem)
        assert why in batch_search(theorem, 100, 0, 3, (1, 8)).unsupported


def test_one_batch_per_family_size():
    assert _split(256, list(range(1, 9))) == [(m, 32) for m in range(1, 9)]
    assert _split(10, [1, 2, 3]) == [(1, 4), (2, 3), (3, 3)]
    assert _split(2, [1, 2, 3]) == [(1, 1), (2, 1)]
    assert _grow(256, 1) == 1024 and _grow(1024, 1) == _grow(4096, 1) == BATCH_SIZE
    assert _grow(256, 8) == 4096 and _grow(4096, 8) == 8 * BATCH_SIZE
    program = compiled(library.get("sbs.ctrl2"), 3)
    assert program.sizes((1, 8)) == list(range(1, 9)) and program.sizes((0, 2)) == [1, 2]
    assert compiled(library.get("textbook.train"), 3).sizes((1, 8)) == [0]
    batch = program.simulate(np.random.default_rng(0), 20, 3)
    start = batch.initial_state(int(np.flatnonzero(batch.accepted)[0]))
    assert start["#universe:B"] == range(3) and set(start["nx"].cells) == {(0,), (1,), (2,)}
    assert start["xtr"].cells == {}  # a family the assumptions leave open
    Interpreter(library.get("sbs.ctrl2")).run(RandomChooser(0), start)  # the interpreter takes it


MUTANTS = ["sbs.ctrl2_wrong_k", "sbs.ctrl2_last_wins", "sbs.ctrl2_dynamic_join_anywhere"]


@pytest.mark.parametrize("name", MUTANTS)
def test_ctrl2_mutants_are_refuted_in_the_batch_phase(name):
    """The reported run is the interpreter's replay of a batch run, violated beyond the
    float tolerance (unit normals have no exact rational replay); replayed again here."""
    theorem = library.get(name)
    result = falsify(theorem, Options(seed=0, database=None, shrink=False, max_examples=100))
    assert result.found and result.phase == "batch" and result.check
    again = Interpreter(theorem).run(Scripted(result.script), result.initial)
    assert again.violated is not None and min(again.checkpoints[-1].margins.values()) < -1e-6


@pytest.mark.parametrize("name", ["sbs.ctrl2_dynamic", "raven.deviation_stop_3d"])
def test_proved_family_models_give_no_batch_counterexample(name):
    outcome = batch_search(library.get(name), 2048, 0, 3, (1, 8))
    assert not outcome.unsupported and outcome.run is None and outcome.started > 1500, name
