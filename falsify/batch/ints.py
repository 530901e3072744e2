"""A vectorised simulator for Hoare-triple models over integers and arrays (`cfmpa.builtdr`).

The real-valued batch (`batch.BatchProgram`) keeps one float column per symbol. A model
whose control flow runs on integers (loop counters, array indices) instead runs here, in
batches whose runs share the values of every integer scalar: the integer constants are
drawn once per batch (by the interpreter's own `initial_state`, so they are drawn as a
per-run search draws them), and a batch's integer control flow is then the same for all of
its runs and stays plain Python values. An integer the program havocs is drawn once per
batch too, by the interpreter's own `_holds` where a test first reads it (`k := *; ?0 <= k
< N`: in [0, N-1]), and that decision is logged for every run. Only array contents vary
per run: an array is a dict from an index tuple to a column (values, open mask); a cell
never written is open and gets a value on its first read, exactly as the interpreter
chooses it — read by a test, the drawn flag, then its negation, the first that makes the
test true, backtracking over several cells as `interpreter._holds` does; read as a value,
the drawn flag, or an integer in [-2, 8]. A choice's alternative that blocks has its cell
writes undone on its runs (a journal per attempt). ∀/∃ over integers bounded by uniform
values are enumerated as the interpreter enumerates them, short-circuiting run by run.
Every decision is logged, so that `script(r)` replays run r in the interpreter.

What compiles (everything else raises `Unsupported`, and the model keeps the per-run
search): integer scalars given by the assumptions, assigned from integer scalars, or
havocked and then read first by a test that is a conjunction of comparisons — never
assigned or havocked inside a choice whose runs may take different alternatives (they
would differ per run); arrays of integers or Booleans indexed by integer scalars;
assumptions over integer scalars only; tests over integer scalars and Boolean cells (not
integer cells: the interpreter solves those from the test); loops followed by their exit
test over integer scalars (`for_range`); choices; assignments and havocs of cells; no ODE,
no reals, no index sorts, no outer control loop. A run that blocks inside a loop's body
(the interpreter would leave the loop there, with counters of its own) is dropped, never
reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from certiloop.falsify.choosers import RandomChooser, Recording
from certiloop.falsify.evaluate import Compiler, Table, index, int_bounds
from certiloop.falsify.initial import initial_state
from certiloop.falsify.interpreter import LOOP_BOUND, Interpreter, index_sorts, outer_loop
from certiloop.falsify.store import Rejected
from certiloop.falsify.vectorise import Unsupported
from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Havoc,
    Loop,
    Program,
    Seq,
    Test,
    program_symbols,
)
from certiloop.models.lang.terms import BOOL, INT, Node, free_vars
from certiloop.models.lang.theorem import Theorem

GROUPS = 16  # batches per round of the search, each with its own integer constants
INT_DRAW = (-2, 8)  # interpreter._int_bounds with no bound known: where an open Int cell is drawn
DRAW_ATTEMPTS = 8  # initial states tried per batch before its runs are all rejected
UNIFORM_OPS = {"const", "var", "+", "*", "neg", "cmp", "and", "or", "not", "implies", "iff", "true", "false"}
TERM_OPS = {"const", "var", "select", "+", "*", "neg"}

Cell = tuple[str, tuple]  # (array, index tuple)


@dataclass
class IntBatch:
    """One batch's outcome, shaped like `batch.Batch` for `batch_search`."""

    size: int
    constants: dict[str, Any]  # the integer scalars every run of the batch starts from
    arrays: list[str]
    accepted: np.ndarray
    violated: np.ndarray
    completed: np.ndarray  # ran to the guarantee (not blocked, not dropped)
    events: list[tuple[str, np.ndarray, np.ndarray]] = field(default_factory=list)

    @property
    def worst(self) -> np.ndarray:  # no margins: a violated run is simply violated
        return np.where(self.violated, -1.0, np.nan)

    def initial_state(self, r: int) -> dict[str, Any]:
        """The interpreter's initial state: the constants, every array empty (open)."""
        out: dict[str, Any] = dict(self.constants)
        for name in self.arrays:
            out[name] = Table()
        return out

    def script(self, r: int) -> list[tuple[str, Any]]:
        return [(kind, int(values[r])) for kind, rows, values in self.events if rows[r]]

    def candidates(self) -> list[int]:
        return [int(r) for r in np.flatnonzero(self.violated & self.accepted)]


def has_ints(theorem: Theorem) -> bool:
    """The model has integer symbols or arrays over integers (a Hoare triple's counters)."""
    symbols = {**free_vars(theorem.assumptions), **program_symbols(theorem.program),
               **free_vars(theorem.guarantee)}
    return any(s.sort == INT or (s.sort.is_array and INT in s.sort.domain) for s in symbols.values())


class IntBatchProgram:
    """A theorem over integers and arrays compiled for batch simulation (raises Unsupported)."""

    def __init__(self, theorem: Theorem, max_steps: int = 3) -> None:
        self.theorem, self.max_steps = theorem, max_steps
        self.symbols = {**free_vars(theorem.assumptions), **program_symbols(theorem.program),
                        **free_vars(theorem.guarantee)}
        if index_sorts(theorem):
            raise Unsupported("an index sort next to integers")
        self.ints: set[str] = set()
        self.arrays: dict[str, bool] = {}  # array -> Boolean-valued?
        for name, sym in self.symbols.items():
            sort = sym.sort
            if sort == INT:
                self.ints.add(name)
            elif sort.is_array and all(d == INT for d in sort.domain) and sort.range in (INT, BOOL):
                self.arrays[name] = sort.range == BOOL
            else:
                raise Unsupported(f"`{name}` is not an integer scalar or an array of integers or Booleans "
                                  "over integers")
        if outer_loop(theorem.program) is not None:
            raise Unsupported("an outer control loop (the integer batch runs straight-line triples)")
        self._uni: dict[int, bool] = {}
        self.given = set(free_vars(theorem.assumptions))
        if not self._uniform(theorem.assumptions):
            raise Unsupported("the assumptions read more than integer scalars")
        self.c = Compiler(exact=False)  # uniform values as the float interpreter computes them
        self.interp = Interpreter(theorem, max_steps=max_steps)
        self._bounds: dict[int, list] = {}
        known = self._check(theorem.program, set(self.given), False)
        self._check_formula(theorem.guarantee, known, frozenset())

    # ------------------------------------------------------------------ compile-time checks
    def _uniform(self, n: Node) -> bool:
        """n reads integer scalars only (free ones, or variables a ∀/∃ over integers binds: both
        the same for every run of a batch). Cached by identity: the theorem keeps its nodes."""
        got = self._uni.get(id(n))
        if got is None:
            if n.op in ("var", "const"):  # integral constants only: an index is always a whole number
                got = n.sort == INT
            else:
                got = n.op in UNIFORM_OPS and all(self._uniform(a) for a in n.args)
            self._uni[id(n)] = got
        return got

    def _need_uniform(self, n: Node, known: set[str], what: str, opens: bool = False) -> None:
        """n is uniform and reads assigned integers; with `opens`, also havocked ones (`?k` in
        `known`): a test that is a conjunction of comparisons reads all of them if it holds."""
        if not self._uniform(n):
            raise Unsupported(f"{what} `{n}` reads more than integer scalars")
        unset = [v for v in free_vars(n) if v not in known and not (opens and f"?{v}" in known)]
        if unset:
            raise Unsupported(f"{what} `{n}` reads `{unset[0]}` before it is surely assigned")

    def _check(self, p: Program, known: set[str], branching: bool) -> set[str]:
        """Raise Unsupported where p leaves the fragment; the integer scalars surely assigned after p."""
        if isinstance(p, Assign):
            t = p.target
            if t.op == "var":
                if t.payload not in self.ints:
                    raise Unsupported(f"assignment to `{t}`")
                if branching:
                    raise Unsupported(f"`{t}` assigned inside a choice: integers would differ per run")
                self._need_uniform(p.value, known, "the value")
                return known | {t.payload}
            self._check_cell(t, known)
            self._check_term(p.value, known, frozenset())
            return known
        if isinstance(p, Havoc):
            t = p.target
            if t.op == "var" and t.payload in self.arrays:
                return known
            if t.op == "var":  # drawn once per batch, where a test first reads it (the same for all runs)
                if branching:
                    raise Unsupported(f"havoc of the integer `{t}` inside a choice: it would differ per run")
                return (known - {t.payload}) | {f"?{t.payload}"}
            self._check_cell(t, known)
            return known
        if isinstance(p, Test):
            if not self._uniform(p.cond):
                self._check_cells_test(p.cond, known)
                return known
            # an open integer is read by a test outside any branching choice, which reads all of
            # them when it holds (a conjunction of comparisons): drawn once for every run
            opens = not branching and all(a.op == "cmp" for a in _conjuncts(p.cond))
            self._need_uniform(p.cond, known, "the test", opens)
            return known | {v for v in free_vars(p.cond) if f"?{v}" in known}
        if isinstance(p, Seq):
            for k, q in enumerate(p.parts):
                if isinstance(q, Loop):
                    after = p.parts[k + 1] if k + 1 < len(p.parts) else None
                    if not isinstance(after, Test) or not self._uniform(after.cond):
                        raise Unsupported("a loop not followed by an exit test over integer scalars")
                    # what every iteration may rely on: the body checked from its own end again
                    entry = known & self._check(q.body, set(known), branching)
                    entry &= self._check(q.body, set(entry), branching)
                    self._need_uniform(after.cond, entry, "the exit test")
                    known = entry
                else:
                    known = self._check(q, known, branching)
            return known
        if isinstance(p, Choice):
            many = len(p.alternatives) > 1
            outs = [self._check(q, set(known), branching or many) for q in p.alternatives]
            return set.intersection(*outs) if outs else known
        if isinstance(p, Loop):
            raise Unsupported("a loop without an exit test")
        if isinstance(p, ODE):
            raise Unsupported("an ODE")
        raise Unsupported(f"statement {p!r}")

    def _check_cells_test(self, f: Node, known: set[str]) -> None:
        """A test over Boolean cells (tried value by value, as the interpreter does) and
        assigned integers."""
        if self._uniform(f):
            self._need_uniform(f, known, "the test")
        elif f.op in ("and", "or", "not", "implies", "iff"):
            for a in f.args:
                self._check_cells_test(a, known)
        elif f.op == "select" and self.arrays.get(f.args[0].payload):
            self._check_cell(f, known)
        else:
            raise Unsupported(f"the test `{f}` reads more than integer scalars and Boolean cells")

    def _check_cell(self, n: Node, known: set[str], bound: frozenset = frozenset()) -> None:
        root = n.args[0]
        if n.op != "select" or root.op != "var" or root.payload not in self.arrays:
            raise Unsupported(f"`{n}` is not a cell of an array")
        for i in n.args[1:]:
            if not self._uniform(i):
                raise Unsupported(f"the index `{i}` of `{n}` reads more than integer scalars: "
                                  "it would differ per run")
            unset = [v for v in free_vars(i) if v not in known and v not in bound]
            if unset:
                raise Unsupported(f"the index `{i}` reads `{unset[0]}` before it is surely assigned")

    def _check_term(self, n: Node, known: set[str], bound: frozenset) -> None:
        if n.op == "select":
            self._check_cell(n, known, bound)
        elif n.op not in TERM_OPS:
            raise Unsupported(f"`{n.op}` in `{n}`")
        elif n.op == "var" and n.payload not in known and n.payload not in bound:
            raise Unsupported(f"`{n}` is read before it is surely assigned")
        else:
            for a in n.args:
                self._check_term(a, known, bound)

    def _check_formula(self, f: Node, known: set[str], bound: frozenset) -> None:
        """A formula evaluated run by run (the guarantee): cells at uniform indices, ∀/∃ over
        integers whose guard bounds them by uniform values; integers surely assigned."""
        unset = [v for v in free_vars(f) if v in self.ints and v not in known and v not in bound]
        if unset:
            raise Unsupported(f"`{unset[0]}` is read before it is surely assigned")
        if self._uniform(f):
            return
        op = f.op
        if op in ("and", "or", "not", "implies", "iff"):
            for a in f.args:
                self._check_formula(a, known, bound)
        elif op == "cmp":
            if not f.args[0].sort.is_numeric:
                raise Unsupported(f"comparison of non-numbers `{f}`")
            for a in f.args:
                self._check_term(a, known, bound)
        elif op == "select":
            self._check_cell(f, known, bound)
        elif op in ("forall", "exists"):
            body = f.args[0]
            names = frozenset(v.payload for v in f.payload)
            if any(v.sort != INT for v in f.payload):
                raise Unsupported(f"a quantifier over a non-integer in `{f}`")
            guard = body.args[0] if body.op in ("implies", "and") else body
            if not self._uniform(guard):
                raise Unsupported(f"the guard of `{f}` reads more than integers")
            pools = []
            for v in f.payload:
                lo, hi = int_bounds(v.payload, body, self.c)
                if lo is None or hi is None:
                    raise Unsupported(f"the guard of `{f}` does not bound `{v.payload}`")
                pools.append((lo, hi))
            self._bounds[id(f)] = pools
            self._check_formula(body, known, bound | names)
        else:
            raise Unsupported(f"`{op}` in `{f}`")

    # ------------------------------------------------------------------ a batch
    def sizes(self, families: tuple[int, int]) -> list[int]:
        """Group slots for `batch_search`'s split: each batch draws its own constants."""
        return list(range(1, GROUPS + 1))

    def simulate(self, rng: np.random.Generator, n: int, elements: int = 0) -> IntBatch:
        """n runs sharing one draw of the integer constants (`elements` is only a group slot)."""
        self.rng, self.n = rng, n
        self.events: list[tuple[str, np.ndarray, np.ndarray]] = []
        self.cells: dict[Cell, list[np.ndarray]] = {}
        self.journals: list[dict[Cell, tuple[np.ndarray, np.ndarray]]] = []
        self.dropped = np.zeros(n, bool)
        constants = self._constants()
        accepted = np.full(n, constants is not None)
        batch = IntBatch(n, constants or {}, list(self.arrays), accepted, np.zeros(n, bool),
                         np.zeros(n, bool), self.events)
        if constants is None:
            return batch
        self.env: dict[str, Any] = dict(constants)
        # integers a test reads open are drawn by the interpreter itself, once for the batch
        self.uniform = self.interp.chooser = Recording(RandomChooser(int(self.rng.integers(0, 2**63 - 1))))
        done = self._exec(self.theorem.program, accepted.copy()) & ~self.dropped
        batch.completed = done
        if done.any():  # (with no run left, integers a blocked test left open are not read)
            batch.violated = done & ~np.asarray(self._formula(self.theorem.guarantee, done, {}), bool)
        return batch

    def _constants(self) -> dict[str, Any] | None:
        """The batch's integer constants, drawn by the interpreter's initial_state."""
        seed = int(self.rng.integers(0, 2**63 - 1))
        chooser = self.interp.chooser = RandomChooser(seed)  # initial_state asks the interpreter's chooser
        for _ in range(DRAW_ATTEMPTS):
            try:
                s = initial_state(self.interp, chooser)
            except Rejected:
                continue
            out = {}
            for name in self.given:
                v = s.get(name)
                if v is None or isinstance(v, bool) or float(v) != int(v):
                    break
                out[name] = int(v)
            else:
                return out
        return None

    def _log(self, rows: np.ndarray, values: np.ndarray) -> None:
        self.events.append(("integer", rows.copy(), values.astype(np.int8)))

    # ------------------------------------------------------------------ cells
    def _key(self, n: Node, bind: dict[str, Any]) -> Cell:
        env = {**self.env, **bind} if bind else self.env
        return n.args[0].payload, tuple(index(self.c(i)(env)) for i in n.args[1:])

    def _cell(self, key: Cell) -> list[np.ndarray]:
        got = self.cells.get(key)
        if got is None:  # never written: open in every run
            got = self.cells[key] = [np.full(self.n, np.nan), np.ones(self.n, bool)]
        return got

    def _write(self, key: Cell, rows: np.ndarray, values, open_: bool = False) -> None:
        cell = self._cell(key)
        if self.journals and key not in self.journals[-1]:  # an attempt may have to undo it
            self.journals[-1][key] = (cell[0].copy(), cell[1].copy())
        cell[0][rows] = np.broadcast_to(np.nan if open_ else values, rows.shape)[rows]
        cell[1][rows] = open_

    def _read(self, n: Node, rows: np.ndarray, bind: dict[str, Any]) -> np.ndarray:
        """A cell read as a value (interpreter._value): open runs get the drawn flag, or an
        integer drawn in [-2, 8] (no test bounds a cell: interpreter._bounds)."""
        key = self._key(n, bind)
        vals, opened = self._cell(key)
        need = rows & opened
        if need.any():
            if self.arrays[key[0]]:
                x = self.rng.integers(0, 2, self.n)
            else:
                x = self.rng.integers(INT_DRAW[0], INT_DRAW[1] + 1, self.n)
            self._log(need, x)
            self._write(key, need, x.astype(float))
        return self.cells[key][0].copy()  # a value, not the cell: a later write must not change it

    # ------------------------------------------------------------------ evaluation
    def _term(self, n: Node, rows: np.ndarray, bind: dict[str, Any]):
        """A term's value per run (open cells chosen on `rows`, left to right)."""
        if self._uniform(n):
            return self.c(n)({**self.env, **bind} if bind else self.env)
        if n.op == "select":
            return self._read(n, rows, bind)
        args = [self._term(a, rows, bind) for a in n.args]
        if n.op == "+":
            out = args[0]
            for a in args[1:]:
                out = out + a
            return out
        if n.op == "*":
            out = args[0]
            for a in args[1:]:
                out = out * a
            return out
        return -args[0]  # neg

    def _formula(self, f: Node, rows: np.ndarray, bind: dict[str, Any]):
        """Truth per run, read as the interpreter reads it: left to right, short-circuiting
        run by run, so that an open cell is chosen exactly where the interpreter reads it."""
        if self._uniform(f):
            return bool(self.c(f)({**self.env, **bind} if bind else self.env))
        op = f.op
        if op == "select":
            return self._read(f, rows, bind) != 0
        if op == "cmp":
            a = self._term(f.args[0], rows, bind)
            b = self._term(f.args[1], rows, bind)
            return _compare(f.payload, a, b)
        if op in ("and", "or"):
            every = op == "and"
            out: Any = every
            cur = rows.copy()
            for a in f.args:
                t = self._formula(a, cur, bind)
                out = np.where(cur, t, out)
                cur &= t if every else ~np.asarray(t, bool)
                if not cur.any():
                    break
            return out
        if op == "not":
            return ~np.asarray(self._formula(f.args[0], rows, bind), bool)
        if op == "implies":
            a = self._formula(f.args[0], rows, bind)
            b = self._formula(f.args[1], rows & a, bind)
            return ~np.asarray(a, bool) | b
        if op == "iff":
            a = self._formula(f.args[0], rows, bind)
            return np.asarray(a, bool) == np.asarray(self._formula(f.args[1], rows, bind), bool)
        return self._quantifier(f, rows, bind)

    def _quantifier(self, f: Node, rows: np.ndarray, bind: dict[str, Any]):
        """∀/∃ over integers (evaluate._enumerate): combinations in order, each run up to the
        first that decides it."""
        every = f.op == "forall"
        names = [v.payload for v in f.payload]
        pools = self._bounds[id(f)]
        out = np.full(self.n, every)
        cur = rows.copy()

        def go(k: int, inner: dict[str, Any]) -> None:
            nonlocal cur
            if not cur.any():
                return
            if k == len(names):
                t = np.asarray(self._formula(f.args[0], cur, inner), bool)
                decided = cur & (t != every)
                out[decided] = not every
                cur &= ~decided
                return
            lo, hi = pools[k]
            env = {**self.env, **inner}
            for x in range(math.ceil(lo(env)), math.floor(hi(env)) + 1):
                go(k + 1, {**inner, names[k]: x})
                if not cur.any():
                    return
        go(0, dict(bind))
        return out

    # ------------------------------------------------------------------ statements
    def _exec(self, p: Program, rows: np.ndarray) -> np.ndarray:
        """Run p on `rows`; the rows that did not block."""
        if not rows.any():
            return rows
        if isinstance(p, Assign):
            return self._assign(p, rows)
        if isinstance(p, Havoc):
            t = p.target
            if t.op == "var" and t.payload in self.ints:  # open until a test reads it (`_test`)
                self.env.pop(t.payload, None)
            elif t.op == "var":  # a whole array: every cell open again
                for key in [k for k in self.cells if k[0] == t.payload]:
                    self._write(key, rows, 0.0, open_=True)
            else:
                self._write(self._key(t, {}), rows, 0.0, open_=True)
            return rows
        if isinstance(p, Test):
            return self._test(p.cond, rows)
        if isinstance(p, Seq):
            cur = rows
            for k, q in enumerate(p.parts):
                if isinstance(q, Loop):
                    cur = self._loop(q, p.parts[k + 1].cond, cur)
                else:
                    cur = self._exec(q, cur)
            return cur
        if isinstance(p, Choice):
            return self._choice(p, rows)
        raise Unsupported(f"statement {p!r}")

    def _assign(self, p: Assign, rows: np.ndarray) -> np.ndarray:
        if p.target.op == "var":  # an integer scalar: uniform, outside any branching choice
            self.env[p.target.payload] = self.c(p.value)(self.env)
            return rows
        value = (self._formula if p.value.sort == BOOL else self._term)(p.value, rows, {})
        self._write(self._key(p.target, {}), rows, np.asarray(value, float))
        return rows

    def _test(self, cond: Node, rows: np.ndarray) -> np.ndarray:
        """A test. Over integers: the interpreter's own `_holds` on the batch's integers (an
        open one drawn as it draws it; the decisions logged for every run). Over Boolean cells:
        tried value by value (`_holds`); one cell (`?a[k]`, `?¬a[k]`) directly: the drawn flag,
        then its negation, the first that makes the test true is kept."""
        if self._uniform(cond):
            mark = len(self.uniform.script)
            holds = self.interp._holds(self.c(cond), self.env, cond)
            for kind, value in self.uniform.script[mark:]:
                self.events.append((kind, rows.copy(), np.full(self.n, value, np.int64)))
            return rows if holds else np.zeros(self.n, bool)
        cell = _literal(cond)
        if cell is None:
            return self._holds(cond, rows)
        want = 1.0 if cond.op == "select" else 0.0
        key = self._key(cell, {})
        vals, opened = self._cell(key)
        need = rows & opened
        if need.any():  # either value may be tried: the test's own value is the one that holds
            self._log(need, self.rng.integers(0, 2, self.n))
            self._write(key, need, want)
        return rows & (self.cells[key][0] == want)

    def _holds(self, cond: Node, rows: np.ndarray) -> np.ndarray:
        """interpreter._holds, vectorised: evaluate; where a run reads an open cell, draw a flag
        and try it, then its negation, each by evaluating again (a value that fails is removed)."""
        need: dict[Cell, np.ndarray] = {}
        stopped = np.zeros(self.n, bool)
        truth = self._probe(cond, rows, need, stopped)
        out = rows & ~stopped & np.asarray(truth, bool)
        for key, hit in need.items():
            first = self.rng.integers(0, 2, self.n)
            self._log(hit, first)
            pending = hit.copy()
            for value in (first, 1 - first):
                self._write(key, pending, value.astype(float))
                ok = self._holds(cond, pending)
                out |= ok
                pending &= ~ok
                self._write(key, pending, 0.0, open_=True)
                if not pending.any():
                    break
        return out

    def _probe(self, f: Node, live: np.ndarray, need: dict[Cell, np.ndarray], stopped: np.ndarray):
        """f's truth as evaluate.Compiler's closures compute it (left to right, short-circuit);
        a run that reads an open cell stops there (NeedValue): `stopped`, and `need[cell]`."""
        if self._uniform(f):
            return bool(self.c(f)(self.env))
        op = f.op
        if op == "select":
            key = self._key(f, {})
            vals, opened = self._cell(key)
            hit = live & ~stopped & opened
            if hit.any():
                need[key] = need.get(key, np.zeros(self.n, bool)) | hit
                stopped |= hit
            return vals == 1
        if op in ("and", "or"):
            every = op == "and"
            out: Any = every
            cur = live & ~stopped
            for a in f.args:
                t = self._probe(a, cur, need, stopped)
                cur &= ~stopped
                out = np.where(cur, t, out)
                cur &= t if every else ~np.asarray(t, bool)
            return out
        if op == "not":
            return ~np.asarray(self._probe(f.args[0], live, need, stopped), bool)
        if op == "implies":
            a = np.asarray(self._probe(f.args[0], live, need, stopped), bool)
            b = self._probe(f.args[1], live & ~stopped & a, need, stopped)
            return ~a | b
        a = np.asarray(self._probe(f.args[0], live, need, stopped), bool)  # iff: both sides read
        return a == np.asarray(self._probe(f.args[1], live & ~stopped, need, stopped), bool)

    def _choice(self, p: Choice, rows: np.ndarray) -> np.ndarray:
        """Each run tries the alternatives from its drawn first one on, cyclically, up to one
        that does not block; a blocked attempt's writes are undone on its runs."""
        n = len(p.alternatives)
        first = np.zeros(self.n, int)
        if n > 1:
            first = self.rng.integers(0, n, self.n)
            self._log(rows, first)
        pending, done = rows.copy(), np.zeros(self.n, bool)
        for t in range(n):
            for a in range(n):
                try_a = pending & ((first + t) % n == a)
                if try_a.any():
                    ok = self._attempt(p.alternatives[a], try_a)
                    done |= ok
                    pending &= ~ok
        return done

    def _attempt(self, p: Program, rows: np.ndarray) -> np.ndarray:
        self.journals.append({})
        ok = self._exec(p, rows) & ~self.dropped
        journal = self.journals.pop()
        undo = rows & ~ok
        for key, (vals, opened) in journal.items():
            cell = self.cells[key]
            cell[0][undo] = vals[undo]
            cell[1][undo] = opened[undo]
            if self.journals:
                self.journals[-1].setdefault(key, (vals, opened))
        return ok

    def _loop(self, p: Loop, exit_test: Node, rows: np.ndarray) -> np.ndarray:
        """A loop with a uniform exit test: the same iterations for every run; a run whose
        body blocks would leave the loop with counters of its own: dropped."""
        active = rows.copy()
        for _ in range(LOOP_BOUND):
            if self.interp._quietly(self.c(exit_test), self.env):
                return active
            ok = self._exec(p.body, active)
            self.dropped |= active & ~ok
            active = ok & ~self.dropped
            if not active.any():
                return active
        return np.zeros(self.n, bool)  # the interpreter blocks after LOOP_BOUND iterations


def _conjuncts(f: Node) -> list[Node]:
    return [a for x in f.args for a in _conjuncts(x)] if f.op == "and" else [f]


def _literal(cond: Node) -> Node | None:
    """The cell of a test `?a[..]` or `?¬a[..]`, else None."""
    if cond.op == "not":
        cond = cond.args[0]
    return cond if cond.op == "select" else None


def _compare(op: str, a, b):
    if op in ("==", "!="):  # evaluate._near: the float interpreter's equality
        close = np.abs(a - b) <= 1e-9 * (1 + np.abs(a) + np.abs(b))
        return close if op == "==" else ~close
    return {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal}[op](a, b)
