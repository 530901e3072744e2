"""What the batch keeps per state (`State.memo`: truths, known masks, open masks, a cell's
columns) holds only while the symbols it was derived from are not written: every write
(put, set, merge, a direct write followed by `changed`) makes it stale, a write to another
symbol does not; a trial merges back exactly the symbols it wrote; truths combined from
kept parts equal the closures'; solving an equation with a side that does not read the value
gives the same solution."""

import numpy as np
import pytest

from certiloop.falsify.batch.open_values import solve_affine
from certiloop.falsify.batch.program import BatchProgram
from certiloop.falsify.batch.state import State
from certiloop.falsify.vectorise import VCompiler
from certiloop.models.lang.programs import assign
from certiloop.models.lang.terms import And, Exists, Family, ForAll, IndexSort, Or, Real, Var
from certiloop.models.lang.theorem import Theorem

B = IndexSort("B")
x = Family("x", B)
i, j = Var("i", B), Var("j", B)
s, y = Real("s"), Real("y")
N, M = 6, 3


def _program() -> BatchProgram:
    theorem = Theorem("t.memo", And(s >= 0, ForAll(j, x(j) >= -1)), assign(y, s + x(i)), s >= 0,
                      expected="proved")
    program = BatchProgram(theorem, 3)
    program.vc.size, program.n = M, N
    program.failed = np.zeros(N, bool)
    return program


def _state(seed: int = 0) -> State:
    rng = np.random.default_rng(seed)
    return State({"s": rng.uniform(-1, 1, N), "y": rng.uniform(-1, 1, N), "x": rng.uniform(-1, 1, (N, M)),
                  "i": rng.integers(0, M, N).astype(float)},
                 {"s": np.zeros(N, bool), "y": np.zeros(N, bool), "x": np.zeros((N, M), bool),
                  "i": np.zeros(N, bool)}, np.zeros(N))


def _closure(program: BatchProgram, f, S: State, bind=None) -> np.ndarray:
    env = {**S.vals, **bind} if bind else S.vals
    return np.broadcast_to(np.asarray(program.vc(f)(env), bool), (S.n,))


ALL = np.ones(N, bool)


# Nodes are cached by identity (a theorem keeps its nodes alive): the tests keep theirs too.
S_POS, Y_POS, CELL_POS = s >= 0, y >= 0, x(i) >= 0


def test_a_kept_truth_is_read_only_and_stale_after_a_put_of_a_symbol_it_reads():
    p, S = _program(), _state()
    f = S_POS
    first = p._truth(f, S)
    assert not first.flags.writeable
    assert p._truth(f, S) is first  # kept
    p._truth(Y_POS, S)
    S.put(("y", None), {}, ALL, -S.vals["y"])  # another symbol: still kept
    assert p._truth(f, S) is first
    S.put(("s", None), {}, ALL, -S.vals["s"])
    assert np.array_equal(p._truth(f, S), ~first | (S.vals["s"] == 0))
    assert np.array_equal(p._truth(f, S), _closure(p, f, S))


@pytest.mark.parametrize("write", ["put_cell", "put_index", "set", "changed", "reopen"])
def test_every_kind_of_write_makes_what_was_kept_stale(write):
    p, S = _program(), _state(1)
    f = CELL_POS
    before = p._truth(f, S).copy()
    known = p._known(f, S).copy()
    open_cells = S.is_open(("x", "i"), {}).copy()
    if write == "put_cell":
        S.put(("x", "i"), {}, ALL, -S.get(("x", "i"), {}))
    elif write == "put_index":
        S.put(("i", None), {}, ALL, (S.vals["i"] + 1) % M)
    elif write == "set":
        S.set("i", ALL, (S.vals["i"] + 1) % M)
    elif write == "changed":
        S.vals["x"] *= -1
        S.changed("x")
    else:
        S.put(("x", "i"), {}, ALL, np.nan, open_=True)
    assert np.array_equal(p._truth(f, S), _closure(p, f, S))
    assert np.array_equal(S.column(("x", "i"), {}), S.vals["i"].astype(np.intp))
    if write == "reopen":
        assert known.all() and not p._known(f, S).any()
        assert not open_cells.any() and S.is_open(("x", "i"), {}).all()
    else:
        assert not np.array_equal(p._truth(f, S), before) or write in ("put_index", "set")
        assert np.array_equal(p._known(f, S), known)


def test_a_trial_merges_back_exactly_what_it_wrote_and_the_parent_forgets_it():
    p, S = _program(), _state(2)
    kept_s, kept_y = p._truth(S_POS, S), p._truth(Y_POS, S)
    trial = S.copy(["s", "y"])
    assert p._truth(S_POS, trial) is kept_s  # the same values: the same memo
    trial.put(("s", None), {}, ALL, -S.vals["s"])
    trial.vals["y"][:] = 5.0  # written without `changed`: not merged back
    rows = np.arange(N) % 2 == 0
    S.merge(trial, rows, ["s", "y"])
    assert np.array_equal(S.vals["s"], np.where(rows, trial.vals["s"], -trial.vals["s"]))
    assert not (S.vals["y"] == 5.0).any()
    assert p._truth(Y_POS, S) is kept_y
    assert np.array_equal(p._truth(S_POS, S), _closure(p, S_POS, S))
    kept_s = p._truth(S_POS, S)
    S.merge(trial, np.zeros(N, bool), ["s"])  # no rows: nothing taken, nothing stale
    assert p._truth(S_POS, S) is kept_s


FORMULAS = [And(s >= 0, x(i) <= y), Or(s >= 0.5, x(i) > 0, y < 0), ForAll(j, x(j) <= y),
            Exists(j, x(j) > s), And(ForAll(j, x(j) > -0.9), Exists(j, x(j) * y >= 0))]


@pytest.mark.parametrize("k", range(len(FORMULAS)))
def test_truths_combined_from_kept_parts_equal_the_closures(k):
    f = FORMULAS[k]
    for seed in range(5):
        p, S = _program(), _state(seed)
        S.vals["x"][0, 1] = np.nan  # an open cell reads nan
        if f.op in ("and", "or"):
            for a in f.args:
                p._truth(a, S)
        else:
            for e in range(M):
                p._truth(f.args[0], S, {f.payload[0].payload: e})
        assert p._combined(f, S, None) is not None
        assert np.array_equal(p._truth(f, S), _closure(p, f, S))


KNOWN_F = And(S_POS, CELL_POS)


def test_known_and_resolve_skip_what_is_chosen():
    p, S = _program(), _state(3)
    S.put(("s", None), {}, ALL, np.abs(S.vals["s"]))  # s >= 0 holds: x(i) >= 0 is read
    S.put(("x", "i"), {}, np.arange(N) < 2, np.nan, open_=True)
    f = KNOWN_F
    known = p._known(f, S)
    assert np.array_equal(known, np.arange(N) >= 2)
    p.rng, p.events = np.random.default_rng(0), []
    p._resolve(f, S, np.arange(N) >= 2, None)  # every value chosen there: nothing drawn
    assert p.events == [] and S.is_open(("x", "i"), {}).sum() == 2
    p._resolve(f, S, ALL, None)
    assert len(p.events) == 1 and not S.is_open(("x", "i"), {}).any()


def test_a_side_that_does_not_read_the_value_is_solved_alike():
    vc, rng = VCompiler(), np.random.default_rng(4)
    env0 = {"s": rng.uniform(-2, 2, N), "y": rng.uniform(-2, 2, N)}
    env0["y"][0] = np.inf
    for lhs, rhs in [(s * y + 1, y - 3), (s * s, y), (s / y, 2 * y), (y + 1, s)]:
        fixed = ("s" not in str(lhs), "s" not in str(rhs))

        def at(v):
            return {**env0, "s": v}
        with np.errstate(all="ignore"):  # inf - inf: as in a batch, where such runs are dropped
            full = solve_affine(vc(lhs), vc(rhs), at, N)
            assert np.array_equal(solve_affine(vc(lhs), vc(rhs), at, N, fixed), full, equal_nan=True)
