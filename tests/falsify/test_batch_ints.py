"""The integer batch (`falsify/batch/ints.py`): Hoare triples over integer constants and
arrays run vectorised. Every completed batch run is checked against an independent witness
(the tree-walking interpreter replaying its initial state and decisions), the mutants are
found and confirmed, the proved triples give nothing, and what leaves the fragment says why."""

import re

import numpy as np
import pytest

from certiloop.falsify.batch.ints import IntBatchProgram
from certiloop.falsify.batch.phase import batch_search, confirm_candidate
from certiloop.falsify.batch.program import compiled
from certiloop.falsify.choosers import Scripted
from certiloop.falsify.interpreter import Interpreter
from certiloop.falsify.vectorise import Unsupported
from certiloop.models import library
from certiloop.models.lang.conveniences import for_range, if_
from certiloop.models.lang.programs import assign, branch, choice, havoc, seq, test
from certiloop.models.lang.terms import BOOL, INT, And, Array, ForAll, Implies, Ints, Not, Or
from certiloop.models.lang.theorem import Theorem

BUILTDR = ["cfmpa.builtdr", "cfmpa.builtdr_skips_last_row", "cfmpa.builtdr_inclusive"]
COMPILED = BUILTDR + ["cfmpa.property8", "cfmpa.property8_converse"]
REFUTED = [name for name in COMPILED if library.get(name).expected == "refuted"]
PROVED = [name for name in COMPILED if library.get(name).expected == "proved"]

n, i, y = Ints("n i y")
A = Array("A", INT, INT)
b = Array("b", INT, BOOL)
c = Array("c", INT, BOOL)


def _counter(name: str = "t.counter") -> Theorem:
    """A small triple that reads unwritten Int cells (drawn in [-2, 8]), Boolean cells both in
    a test and as a value, and havocs a cell: A[i] := A[i] + 1 where b[i], else 0. Refuted:
    a drawn A[i] of 8 becomes 9."""
    body = if_(b[i], assign(A[i], A[i] + 1), assign(A[i], 0), labels=("bump", "reset"))
    program = seq(havoc(A[0]), for_range(i, 0, n, body, ForAll(y, Implies(And(0 <= y, y < i), A[y] <= 8))))
    guarantee = ForAll(y, Implies(And(0 <= y, y < n), A[y] <= 8))
    return Theorem(name, n >= 0, program, guarantee, expected="refuted", constants=(n,))


def _tries() -> Theorem:
    """Tests over two Boolean cells that can fail after trying both values (the interpreter
    backtracks, the batch must undo the attempt and log the same flags): refuted, A[y] = 2
    where b[y] is false."""
    body = choice(branch("both", test(And(b[i], Not(b[i]))), assign(A[i], 1)),
                  branch("c", test(Or(c[i], b[i])), assign(A[i], 2)),
                  branch("else", assign(A[i], 3)))
    guarantee = ForAll(y, Implies(And(0 <= y, y < n), Or(A[y] == 3, A[y] == 2, A[y] == 1)))
    refuted = ForAll(y, Implies(And(0 <= y, y < n), Implies(A[y] == 2, b[y])))
    program = for_range(i, 0, n, body, True)
    return (Theorem("t.tries", n >= 0, program, guarantee),
            Theorem("t.tries_refuted", n >= 0, program, refuted, expected="refuted"))


def _witness(theorem: Theorem, seeds: range, runs: int = 24) -> tuple[int, int, set]:
    """Replay every completed run of batches of `theorem` in the interpreter (floats), from the
    batch's initial state and script, and check it reaches the same verdict. (replayed,
    violated, the constants seen)."""
    program = compiled(theorem, 3)
    interp = Interpreter(theorem, max_steps=3)
    replayed = violated = 0
    seen = set()
    for seed in seeds:
        batch = program.simulate(np.random.default_rng(seed), runs, 1)
        seen.add(tuple(sorted(batch.constants.items())))
        for r in np.flatnonzero(batch.completed):
            script = Scripted(batch.script(int(r)))
            run = interp.run(script, batch.initial_state(int(r)))
            assert (run.violated is not None) == bool(batch.violated[r]), (theorem.name, seed, int(r))
            assert script.at == len(script.script)  # every logged decision was asked for
            replayed += 1
            violated += run.violated is not None
    return replayed, violated, seen


def test_the_builtdr_models_compile():
    for name in BUILTDR:
        assert isinstance(compiled(library.get(name), 3), IntBatchProgram)


@pytest.mark.parametrize("name", COMPILED)
def test_every_batch_run_replays_to_the_same_verdict(name):
    theorem = library.get(name)
    replayed, violated, seen = _witness(theorem, range(40))
    if name in BUILTDR:
        assert replayed >= 40 * 24 * 0.9  # nothing blocks in builtDR: (nearly) every run is checked
    else:
        assert replayed >= 24  # a batch whose grid is empty blocks at its range test
    assert any(all(v >= 1 for _, v in consts) for consts in seen)  # some batches have a non-empty grid
    if theorem.expected == "refuted":
        assert violated > 0
    else:
        assert violated == 0


def test_open_cells_and_havocs_replay_too():
    replayed, violated, _ = _witness(_counter(), range(30), runs=40)
    assert replayed > 500 and violated > 0


def test_integers_havocked_in_a_loop_replay():
    """k := * in every iteration, drawn where the range test reads it (the same for a batch)."""
    k = Ints("k")[0]
    body = seq(havoc(k), test(And(0 <= k, k < n)), assign(A[k], i))
    theorem = Theorem("t.rehavoc", n >= 0, for_range(i, 0, n, body, True),
                      ForAll(y, Implies(And(0 <= y, y < n), A[y] <= n - 2)), expected="refuted")
    replayed, violated, _ = _witness(theorem, range(40), runs=16)
    assert replayed > 40 and violated > 0


def test_failed_tries_are_undone_and_replay():
    safe, unsafe = _tries()
    assert _witness(safe, range(30), runs=40)[1] == 0
    replayed, violated, _ = _witness(unsafe, range(30), runs=40)
    assert replayed > 500 and violated > 0
    assert batch_search(unsafe, 4096, 0, 3, (1, 8)).check
    assert batch_search(safe, 4096, 0, 3, (1, 8)).run is None


@pytest.mark.parametrize("name", REFUTED)
def test_refuted_models_are_found_and_confirmed(name):
    theorem = library.get(name)
    got = batch_search(theorem, 4096, 0, 3, (1, 8))
    assert got.run is not None and got.run.violated and got.check == "replayed in exact rational arithmetic"
    # the reported run is the interpreter's: replaying it again gives the same violation
    again = Interpreter(theorem, max_steps=3).run(Scripted(got.script), dict(got.initial))
    assert again.violated is not None


def test_a_small_triple_with_drawn_cells_is_found():
    got = batch_search(_counter(), 4096, 1, 3, (1, 8))
    assert got.run is not None and got.check


@pytest.mark.parametrize("name", PROVED)
def test_proved_models_give_nothing(name):
    theorem = library.get(name)
    for seed in range(3):
        got = batch_search(theorem, 4096, seed, 3, (1, 8))
        assert got.run is None and got.runs == 4096 and not got.unsupported


def test_the_same_seed_gives_the_same_search():
    theorem = library.get("cfmpa.builtdr_skips_last_row")
    a, b_ = (batch_search(theorem, 4096, 3, 3, (1, 8)) for _ in range(2))
    assert a.run is not None
    assert (a.runs, _plain(a.initial), a.script, a.check) == \
        (b_.runs, _plain(b_.initial), b_.script, b_.check)


def _plain(state: dict) -> dict:
    return {k: getattr(v, "cells", v) for k, v in state.items()}


def _variant(program, guarantee=None, assumptions=None) -> Theorem:
    return Theorem("t.variant", assumptions if assumptions is not None else n >= 0, program,
                   guarantee if guarantee is not None else ForAll(y, Implies(And(0 <= y, y < n), A[y] <= 9)))


def test_what_the_integer_batch_refuses_says_why():
    """Mutations of a compiled triple that would make integers differ per run, or read what the
    batch cannot choose as the interpreter does: each raises Unsupported (per-run search)."""
    body = if_(b[i], assign(A[i], 1), assign(A[i], 0))
    good = _variant(for_range(i, 0, n, body, True))
    assert isinstance(compiled(good, 3), IntBatchProgram)
    k = Ints("k")[0]
    cases = {
        "havoc of the integer `k` inside a choice": _variant(for_range(i, 0, n, seq(
            choice(branch("a", havoc(k)), branch("b", assign(A[i], 2))), body), True)),
        "reads `k` before": _variant(seq(havoc(k), for_range(i, 0, n, if_(b[i], test(k >= 0), body), True))),
        "test `k >= 0 | n >= 0` reads `k`": _variant(seq(havoc(k), test(Or(k >= 0, n >= 0)),
                                                          assign(A[0], k))),
        "assigned inside a choice": _variant(for_range(i, 0, n, seq(if_(b[i], assign(k, 1), assign(k, 0)),
                                                                    body), True)),
        "would differ per run": _variant(for_range(i, 0, n, assign(A[A[i]], 1), True)),
        "test `A[i] >= 0` reads more": _variant(for_range(i, 0, n, seq(test(A[i] >= 0), body), True)),
        "assumptions read more": _variant(for_range(i, 0, n, body, True), assumptions=And(n >= 0, A[0] == 1)),
        "before it is surely assigned": _variant(seq(for_range(i, 0, n, body, True), assign(A[0], k))),
    }
    for why, theorem in cases.items():
        with pytest.raises(Unsupported, match=re.escape(why)):
            IntBatchProgram(theorem)
        assert why in batch_search(theorem, 64, 0, 3, (1, 8)).unsupported


@pytest.mark.slow
@pytest.mark.parametrize("name", COMPILED)
def test_many_batches_replay_and_every_hit_confirms(name):
    """The witness over 400 batches; each violated run (up to 50) also confirmed by
    confirm_candidate (exact replay), and the proved triples searched over 10 seeds."""
    theorem = library.get(name)
    replayed, violated, _ = _witness(theorem, range(100, 500), runs=16)
    assert replayed > 0 and (violated > 0) == (theorem.expected == "refuted")
    program, hits = compiled(theorem, 3), 0
    for seed in range(200):
        batch = program.simulate(np.random.default_rng(seed), 16, 1)
        for r in batch.candidates()[:2]:
            run, check = confirm_candidate(theorem, batch.initial_state(r), batch.script(r), 3, (1, 8))
            assert run is not None and check == "replayed in exact rational arithmetic"
            hits += 1
        if hits >= 50:
            break
    if theorem.expected == "proved":
        assert all(batch_search(theorem, 4096, seed, 3, (1, 8)).run is None for seed in range(10))
