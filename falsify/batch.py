"""A vectorised simulator: many runs of a hybrid program at once, for the falsifier.

`BatchProgram(theorem)` compiles a model once (terms to numpy closures, ODE closed forms
to numpy, flows without one to a fixed-step RK4) and `simulate(rng, n)` advances n runs
together: every statement is executed once for the whole batch, on the rows (runs) a mask
selects. It mirrors the interpreter decision by decision — the order in which a choice's
alternatives are tried (a blocked alternative hands its runs to the next one), open values
drawn or solved from the test that reads them, ODE durations stopped where the guarantee
is worst, the number of control steps — and logs every decision, so that any run of the
batch can be replayed by the interpreter from a script (`script(r)`). A violating run of a
batch is only a candidate: the search reports it after that replay (`batch_search`).

Only the scalar real fragment compiles (no families, arrays, integers, Booleans or
quantifiers): anything else raises `Unsupported` and the model keeps the per-run search.
Runs that hit a non-finite value (1/0, overflow) are dropped, never reported.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from certiloop.falsify.choosers import REAL_RANGE
from certiloop.falsify.interpreter import HORIZON, LOOP_BOUND, OPEN_LOOP_ITERATIONS, _outer_loop
from certiloop.falsify.vectorise import Unsupported, VCompiler, conjuncts, read_order
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
from certiloop.models.lang.terms import REAL, Node, free_vars
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.wp import flow_solution

GRID = np.linspace(0.0, 1.0, 64)  # as flows.GRID: where a flow may leave its domain
WATCH = np.linspace(0.0, 1.0, 33)  # as flows.WATCH_SAMPLES: where the guarantee is watched
RK4_GRID = np.linspace(0.0, 1.0, 17)  # coarser for flows integrated step by step
RK4_WATCH = np.linspace(0.0, 1.0, 17)
BISECTIONS = 30  # to 1e-9 of a grid cell, from inside; the result is then moved 2e-9 inwards
RK4_TOLERANCE = 1e-6  # step doubling: a flow without closed form is followed while RK4 agrees
ESCAPE = 1e9  # as flows.ESCAPE
REPAIR_PASSES = 3  # as initial.REPAIR_PASSES


@dataclass
class State:
    """Every scalar symbol as an array over the batch; `open` marks values not yet chosen."""

    vals: dict[str, np.ndarray]
    open: dict[str, np.ndarray]
    time: np.ndarray

    def copy(self) -> "State":
        return State({k: v.copy() for k, v in self.vals.items()},
                     {k: v.copy() for k, v in self.open.items()}, self.time.copy())

    def merge(self, other: "State", rows: np.ndarray) -> None:
        """Take `other`'s values on `rows` (the runs whose attempt succeeded)."""
        for k, v in other.vals.items():
            self.vals[k][rows] = v[rows]
            self.open[k][rows] = other.open[k][rows]
        self.time[rows] = other.time[rows]

    def take(self, at: np.ndarray) -> "State":
        """The runs `at` as a smaller batch."""
        return State({k: v[at] for k, v in self.vals.items()}, {k: v[at] for k, v in self.open.items()},
                     self.time[at])

    def set(self, name: str, rows: np.ndarray, values) -> None:
        self.vals[name][rows] = np.broadcast_to(values, rows.shape)[rows]
        self.open[name][rows] = False


@dataclass
class Batch:
    """The outcome of one batch: initial states, decisions, and which runs violated."""

    size: int
    symbols: list[str]  # the symbols the initial state gives (the assumptions' symbols)
    initial: dict[str, np.ndarray]
    accepted: np.ndarray  # the drawn state satisfies the assumptions (as floats)
    violated: np.ndarray  # the guarantee failed at a checkpoint
    worst: np.ndarray  # the guarantee's margin where it failed (nan elsewhere)
    events: list[tuple[str, np.ndarray, np.ndarray]] = field(default_factory=list)
    final: dict[str, np.ndarray] = field(default_factory=dict)  # each run's last state (nan: open)
    completed: np.ndarray | None = None  # ran to its end or to a violation (did not block)

    def initial_state(self, r: int) -> dict[str, float]:
        return {name: float(self.initial[name][r]) for name in self.symbols}

    def script(self, r: int) -> list[tuple[str, Any]]:
        """Run r's decisions in the order the interpreter asks for them."""
        out: list[tuple[str, Any]] = []
        for kind, rows, values in self.events:
            if rows[r]:
                v = values[r]
                out.append((kind, int(v) if kind == "integer" else float(v)))
        return out

    def candidates(self) -> list[int]:
        """Violating runs, deepest violation first (ties in run order)."""
        rows = np.flatnonzero(self.violated & self.accepted)
        return [int(r) for r in rows[np.argsort(self.worst[rows], kind="stable")]]


class _Flow:
    def __init__(self, ode: ODE, vc: VCompiler) -> None:
        self.ode = ode
        self.names = [v.payload for v in ode.variables]
        self.rhs_nodes = [f for _, f in ode.eqs]
        self.rhs = [vc(f) for f in self.rhs_nodes]
        self.domain = ode.domain
        self.domain_truth = vc(ode.domain)
        self.domain_margin = vc.margin(ode.domain)
        s, solution = flow_solution(ode)
        self.s_name = s.payload
        self.solution = None if solution is None else {n: vc(x) for n, x in solution.items()}

    def states(self, S: State, times: np.ndarray) -> dict[str, np.ndarray]:
        """The flow's variables at `times` ((runs,) or (runs, k)), from S."""
        if self.solution is not None:
            grid = times.ndim == 2
            env = {k: (v[:, None] if grid else v) for k, v in S.vals.items()}
            env[self.s_name] = times
            return {n: np.broadcast_to(fn(env), times.shape) for n, fn in self.solution.items()}
        return self._rk4(S, times if times.ndim == 2 else times[:, None], squeeze=times.ndim == 1)

    def _rk4(self, S: State, times: np.ndarray, squeeze: bool) -> dict[str, np.ndarray]:
        env = dict(S.vals)
        y = [S.vals[n].copy() for n in self.names]
        out = [np.empty(times.shape) for _ in self.names]
        now = np.zeros(times.shape[0])

        def f(state):
            for n, v in zip(self.names, state):
                env[n] = v
            return [_full(r(env), now.shape) for r in self.rhs]
        def step(y, h):
            k1 = f(y)
            k2 = f([a + h / 2 * b for a, b in zip(y, k1)])
            k3 = f([a + h / 2 * b for a, b in zip(y, k2)])
            k4 = f([a + h * b for a, b in zip(y, k3)])
            return [a + h / 6 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(y, k1, k2, k3, k4)]
        lost = np.zeros(times.shape[0], bool)  # step doubling disagreed: the values are not trusted
        for j in range(times.shape[1]):
            h = times[:, j] - now
            whole = step(y, h)
            y = step(step(y, h / 2), h / 2)
            for a, b in zip(whole, y):
                lost |= ~(np.abs(a - b) <= RK4_TOLERANCE * (1 + np.abs(b)))
            now = times[:, j]
            for o, v in zip(out, y):
                o[:, j] = np.where(lost, np.nan, v)
        if squeeze:
            out = [o[:, 0] for o in out]
        return dict(zip(self.names, out))

    def _margin_at(self, S: State, times: np.ndarray) -> np.ndarray:
        grid = times.ndim == 2
        env = {k: (v[:, None] if grid else v) for k, v in S.vals.items()}
        traj = self.states(S, times)
        env.update(traj)
        m = np.broadcast_to(self.domain_margin(env), times.shape).astype(float)
        bad = ~np.isfinite(m)
        for v in traj.values():  # a value beyond the models' scale: the flow ends there
            bad |= ~np.isfinite(v) | (np.abs(v) >= ESCAPE)
        return np.where(bad, -1.0, m)

    def longest(self, S: State, horizon: float, depth: int) -> np.ndarray:
        """The end of the first stretch from 0 on which the domain holds (flows._last_inside,
        vectorised), for every run of S; strictly inside where the flow leaves the domain,
        so that a replay never finds the duration beyond its own."""
        n = S.time.shape[0]
        at = np.arange(n)
        hi = np.full(n, horizon)
        out = np.full(n, np.nan)
        pending = np.ones(n, bool)
        g0 = self._margin_at(S, np.zeros(n))
        closed = self.solution is not None
        if not closed:  # scipy's event detection ends a flow where the domain's margin reaches 0
            out[g0 <= 0] = 0.0
            pending &= ~(g0 <= 0)
        grid = GRID if closed else RK4_GRID
        for level in range(depth + 1):
            ts = hi[:, None] * grid[None, 1:]
            g = self._margin_at(S, ts)
            neg = g < 0 if closed else g <= 0
            hit = neg.any(axis=1)
            k = neg.argmax(axis=1)
            out[pending & ~hit] = hi[pending & ~hit]
            prev = np.where(k > 0, ts[at, np.maximum(k - 1, 0)], 0.0)
            gprev = np.where(k > 0, g[at, np.maximum(k - 1, 0)], g0)
            cross = pending & hit & (gprev > 0)
            if cross.any():
                out[cross] = self._root(S, prev, ts[at, k])[cross]
            edge = pending & hit & ~(gprev > 0) & (k == 0) & (level < depth)
            rest = pending & hit & ~(gprev > 0) & ~edge
            out[rest] = prev[rest]
            hi = np.where(edge, ts[:, 0], hi)
            pending = edge
            if not pending.any():
                break
        return out

    def _root(self, S: State, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        if self.solution is None:
            return lo  # a grid point inside the domain: a shorter flow is still a run
        start, lo, hi = lo.copy(), lo.copy(), hi.copy()
        for _ in range(BISECTIONS):
            mid = (lo + hi) / 2
            inside = self._margin_at(S, mid) >= 0
            lo = np.where(inside, mid, lo)
            hi = np.where(inside, hi, mid)
        return start + (lo - start) * (1 - 2e-9)


class BatchProgram:
    """A theorem compiled for batch simulation (raises Unsupported)."""

    def __init__(self, theorem: Theorem, max_steps: int = 3, horizon: float = HORIZON) -> None:
        self.theorem, self.max_steps, self.horizon = theorem, max_steps, horizon
        self.symbols = {**free_vars(theorem.assumptions), **program_symbols(theorem.program),
                        **free_vars(theorem.guarantee)}
        for name, sym in self.symbols.items():
            if sym.sort != REAL:
                raise Unsupported(f"`{name}` is not a real scalar")
        self.vc = VCompiler()
        self.top = _outer_loop(theorem.program)
        self.given = list(free_vars(theorem.assumptions))
        self.assumptions = self.vc(theorem.assumptions)
        self.guarantee = self.vc(theorem.guarantee)
        self.parts = [(self.vc.margin(g), read_order(g)) for g in conjuncts(theorem.guarantee)]
        self.flows: dict[int, _Flow] = {}
        self._orders: dict[tuple, list[str]] = {}
        self._prepare(theorem.program)
        self._prepare_formula(theorem.assumptions)

    # ------------------------------------------------------------------ compile
    def _prepare(self, p: Program) -> None:
        if isinstance(p, Assign):
            if p.target.op != "var":
                raise Unsupported(f"assignment to `{p.target}`")
            self.vc(p.value)
        elif isinstance(p, Havoc):
            if p.target.op != "var":
                raise Unsupported(f"nondeterministic assignment to `{p.target}`")
        elif isinstance(p, Test):
            self._prepare_formula(p.cond)
        elif isinstance(p, (Seq, Choice)):
            for q in (p.parts if isinstance(p, Seq) else p.alternatives):
                self._prepare(q)
        elif isinstance(p, Loop):
            self._prepare(p.body)
        elif isinstance(p, ODE):
            self.flows[id(p)] = _Flow(p, self.vc)
            self._prepare_formula(p.domain)
        else:
            raise Unsupported(f"statement {p!r}")

    def _prepare_formula(self, f: Node) -> None:
        self.vc(f)
        self.vc.margin(f)

    def _order(self, n: Node) -> list[str]:
        got = self._orders.get(n.key)
        if got is None:
            got = self._orders[n.key] = read_order(n)
        return got

    # ------------------------------------------------------------------ a batch
    def simulate(self, rng: np.random.Generator, n: int) -> Batch:
        self.rng, self.n = rng, n
        self.events: list[tuple[str, np.ndarray, np.ndarray]] = []
        self.dropped = np.zeros(n, bool)  # a value went non-finite or RK4 lost it: abandoned
        with np.errstate(all="ignore"):  # 1/0 and overflow: such runs are dropped
            S, accepted = self._initial()
            batch = Batch(n, self.given, {k: S.vals[k].copy() for k in self.given}, accepted,
                          np.zeros(n, bool), np.full(n, np.nan), self.events)
            self.out = batch
            p, top = self.theorem.program, self.top
            if top is None:
                ok = self._exec(p, S, accepted)
                self._checkpoint(S, ok)
            else:
                ok = self._exec(p, S, accepted)
            batch.completed = (ok | batch.violated) & ~self.dropped  # others blocked before the loop
            batch.violated &= ~self.dropped
        batch.final = {k: np.where(S.open[k], np.nan, v) for k, v in S.vals.items()}
        return batch

    def _log(self, kind: str, rows: np.ndarray, values: np.ndarray) -> None:
        if rows.any():
            self.events.append((kind, rows.copy(), values))

    # ------------------------------------------------------------------ initial states
    def _initial(self) -> tuple[State, np.ndarray]:
        """Drawn values repaired towards the assumptions (initial.py's method, per run);
        a run starts only if the assumptions hold for it."""
        n, rng = self.n, self.rng
        S = State({k: np.full(n, np.nan) for k in self.symbols}, {k: np.ones(n, bool) for k in self.symbols},
                  np.zeros(n))
        for name in self.given:
            S.set(name, np.ones(n, bool), rng.uniform(-REAL_RANGE, REAL_RANGE, n))
        instances = self._instances(self.theorem.assumptions, np.ones(n, bool))
        counts = Counter(v for atom, _ in instances for v in self._order(atom))
        edged: set[int] = set()
        for _ in range(REPAIR_PASSES):
            for at, (atom, rows) in enumerate(instances):
                self._repair(atom, rows, S, counts, at, edged)
        accepted = np.asarray(np.broadcast_to(self.assumptions(S.vals), (n,)), bool).copy()
        for name in self.given:
            accepted &= np.isfinite(S.vals[name])
        return S, accepted

    def _instances(self, f: Node, rows: np.ndarray) -> list[tuple[Node, np.ndarray]]:
        if f.op == "and":
            return [i for a in f.args for i in self._instances(a, rows)]
        if f.op == "or":
            pick = self.rng.integers(0, len(f.args), self.n)
            return [i for k, a in enumerate(f.args) for i in self._instances(a, rows & (pick == k))]
        return [(f, rows)]

    def _repair(self, atom: Node, rows: np.ndarray, S: State, counts: Counter, at: int, edged: set) -> None:
        if atom.op != "cmp":
            return
        holds = lambda: np.broadcast_to(self.vc(atom)(S.vals), (self.n,))  # noqa: E731
        op = atom.payload
        edge = np.zeros(self.n, bool)
        if op in ("<=", ">=") and at not in edged:
            edged.add(at)
            edge = rows & (self.rng.random(self.n) < 0.5)  # designs break at the edges
        broken = rows & (~holds() | edge)
        if not broken.any():
            return
        strict = op in ("<", ">")
        drawn = np.where(self.rng.random(self.n) < 0.3, 1.0 if strict else 0.0,
                         self.rng.uniform(1e-3 if strict else 0.0, REAL_RANGE, self.n))
        slack = np.where(edge | (op == "=="), 0.0, drawn)
        target = {">=": slack, ">": slack, "<=": -slack, "<": -slack, "==": 0.0 * slack,
                  "!=": 1.0 + 0.0 * slack}[op]
        lhs, rhs = self.vc(atom.args[0]), self.vc(atom.args[1])
        for name in sorted(dict.fromkeys(self._order(atom)), key=lambda v: counts[v]):
            if name not in self.given or not broken.any():
                continue
            x = _solve(lambda env: lhs(env) - rhs(env), lambda env: target, name, S.vals, self.n)
            old = S.vals[name].copy()
            move = broken & np.isfinite(x)
            S.vals[name][move] = x[move]
            fixed = move & holds()
            S.vals[name][move & ~fixed] = old[move & ~fixed]
            broken &= ~fixed
        if op == "==" and broken.any():
            self._scale(atom, broken, S, holds)

    def _scale(self, atom: Node, rows: np.ndarray, S: State, holds) -> None:
        """Meet `h(x) = c` for h homogeneous of degree d by scaling every x by (c/h)^(1/d)
        (initial._scale, vectorised): unit normals."""
        names = [v for v in dict.fromkeys(self._order(atom)) if v in self.given]
        lhs, rhs = self.vc(atom.args[0]), self.vc(atom.args[1])
        want = np.broadcast_to(rhs(S.vals), (self.n,))
        have = np.broadcast_to(lhs(S.vals), (self.n,))
        env = dict(S.vals)
        for v in names:
            env[v] = S.vals[v] * 2
        doubled = np.broadcast_to(lhs(env), (self.n,))
        degree = np.log2(np.abs(doubled / have))
        ok = (rows & (have != 0) & (want / have > 0) & np.isfinite(degree) & (degree > 0)
              & (np.abs(degree - np.round(degree)) <= 1e-9))
        factor = (want / have) ** (1 / np.round(degree))
        old = {v: S.vals[v].copy() for v in names}
        for v in names:
            S.vals[v][ok] = old[v][ok] * factor[ok]
        undo = ok & ~holds()
        for v in names:
            S.vals[v][undo] = old[v][undo]

    # ------------------------------------------------------------------ open values
    def _resolve(self, f: Node, S: State, rows: np.ndarray, cond: Node | None) -> None:
        """Give every open value f reads a value, in the interpreter's order: formulas
        short-circuit left to right; a value an equation of `cond` pins down is solved
        for, any other is drawn (and logged)."""
        if not rows.any():
            return
        op = f.op
        if op in ("and", "or"):
            cur = rows.copy()
            for a in f.args:
                self._resolve(a, S, cur, cond)
                t = self._truth(a, S)
                cur &= t if op == "and" else ~t
            return
        if op == "implies":
            self._resolve(f.args[0], S, rows, cond)
            self._resolve(f.args[1], S, rows & self._truth(f.args[0], S), cond)
            return
        if op in ("not", "iff"):
            for a in f.args:
                self._resolve(a, S, rows, cond)
            return
        for name in self._order(f):
            need = rows & S.open[name]
            if need.any():
                self._choose(name, S, need, cond)

    def _choose(self, name: str, S: State, need: np.ndarray, cond: Node | None) -> None:
        left = need.copy()
        for atom in conjuncts(cond) if cond is not None else ():
            if atom.op != "cmp" or atom.payload != "==" or not atom.args[0].sort.is_numeric:
                continue
            others = [v for v in self._order(atom) if v != name]
            rows = left.copy()
            for v in others:
                rows &= ~S.open[v]
            if not rows.any():
                continue
            lhs, rhs = self.vc(atom.args[0]), self.vc(atom.args[1])
            x = _solve(lhs, rhs, name, S.vals, self.n)
            solved = rows & np.isfinite(x)
            S.set(name, solved, x)
            left &= ~solved
            if not left.any():
                return
        x = self.rng.uniform(-REAL_RANGE, REAL_RANGE, self.n)
        S.set(name, left, x)
        self._log("real", left, x)

    def _truth(self, f: Node, S: State) -> np.ndarray:
        return np.asarray(np.broadcast_to(self.vc(f)(S.vals), (self.n,)), bool)

    # ------------------------------------------------------------------ statements
    def _exec(self, p: Program, S: State, rows: np.ndarray) -> np.ndarray:
        """Run p on `rows`; the rows that did not block."""
        if not rows.any():
            return rows
        if isinstance(p, Assign):
            self._resolve(p.value, S, rows, None)
            x = np.broadcast_to(self.vc(p.value)(S.vals), (self.n,))
            self.dropped |= rows & ~np.isfinite(x)
            ok = rows & ~self.dropped
            S.set(p.target.payload, ok, x)
            return ok
        if isinstance(p, Havoc):
            S.open[p.target.payload][rows] = True
            S.vals[p.target.payload][rows] = np.nan
            return rows
        if isinstance(p, Test):
            self._resolve(p.cond, S, rows, p.cond)
            return rows & self._truth(p.cond, S)
        if isinstance(p, Seq):
            cur = rows
            for k, q in enumerate(p.parts):
                if isinstance(q, Loop) and q is not self.top:
                    after = p.parts[k + 1] if k + 1 < len(p.parts) else None
                    cur = self._loop(q, S, cur, after.cond if isinstance(after, Test) else None)
                else:
                    cur = self._exec(q, S, cur)
            return cur
        if isinstance(p, Choice):
            return self._choice(p, S, rows)
        if isinstance(p, Loop):
            return self._outer(p, S, rows) if p is self.top else self._loop(p, S, rows, None)
        if isinstance(p, ODE):
            return self._ode(p, S, rows)
        raise Unsupported(f"statement {p!r}")

    def _attempt(self, p: Program, S: State, rows: np.ndarray) -> np.ndarray:
        trial = S.copy()
        ok = self._exec(p, trial, rows)
        S.merge(trial, ok)
        return ok

    def _choice(self, p: Choice, S: State, rows: np.ndarray) -> np.ndarray:
        n = len(p.alternatives)
        first = np.zeros(self.n, int)
        if n > 1:
            first = self.rng.integers(0, n, self.n)
            self._log("integer", rows, first)
        pending, done = rows.copy(), np.zeros(self.n, bool)
        for k in range(n):
            for a in range(n):
                try_a = pending & ((first + k) % n == a)
                if try_a.any():
                    ok = self._attempt(p.alternatives[a], S, try_a)
                    done |= ok
                    pending &= ~ok & ~self.dropped
        return done

    def _loop(self, p: Loop, S: State, rows: np.ndarray, exit_test: Node | None) -> np.ndarray:
        out, active = np.zeros(self.n, bool), rows.copy()
        for k in range(LOOP_BOUND):
            if exit_test is not None:
                finished = active & self._quietly(exit_test, S)
            elif k >= OPEN_LOOP_ITERATIONS:
                finished = active.copy()
            else:
                flag = self.rng.integers(0, 2, self.n)
                self._log("integer", active, flag)
                finished = active & (flag == 0)
            out |= finished
            active &= ~finished
            if not active.any():
                return out
            ok = self._attempt(p.body, S, active)
            out |= active & ~ok & ~self.dropped  # a blocked iteration ends the loop, as in the interpreter
            active &= ok
        return out  # runs still looping after LOOP_BOUND iterations block

    def _quietly(self, f: Node, S: State) -> np.ndarray:
        known = np.ones(self.n, bool)
        for v in self._order(f):
            known &= ~S.open[v]
        return known & self._truth(f, S)

    def _outer(self, p: Loop, S: State, rows: np.ndarray) -> np.ndarray:
        alive = rows & ~self._checkpoint(S, rows)
        steps = self.rng.integers(1, self.max_steps + 1, self.n)
        self._log("integer", alive, steps)
        for k in range(self.max_steps):
            act = alive & (steps > k)
            if not act.any():
                break
            ok = self._attempt(p.body, S, act)
            alive &= ~(act & ~ok)  # no further step possible: the run ends there
            alive &= ~self._checkpoint(S, ok)
        return rows  # every run ends well here: a blocked step ends it, a violation is marked

    def _checkpoint(self, S: State, rows: np.ndarray) -> np.ndarray:
        """Mark the rows where the guarantee fails; they end there."""
        self._resolve(self.theorem.guarantee, S, rows, None)
        bad = rows & ~self._truth(self.theorem.guarantee, S)
        if bad.any():
            self.out.violated |= bad
            self.out.worst[bad] = self._watch(S.vals, S, (self.n,))[bad]
        return bad

    def _watch(self, env: dict[str, Any], S: State, shape: tuple[int, ...]) -> np.ndarray:
        """The smallest margin of the guarantee's parts that read no open value."""
        worst = np.full(shape, np.inf)
        for fn, names in self.parts:
            known = np.ones(shape[0], bool)
            for v in names:
                known &= ~S.open[v]
            if len(shape) == 2:
                known = known[:, None]
            worst = np.where(known, np.minimum(worst, np.broadcast_to(fn(env), shape)), worst)
        return np.where(np.isinf(worst), 1.0, worst)

    def _ode(self, p: ODE, S: State, rows: np.ndarray) -> np.ndarray:
        flow = self.flows[id(p)]
        for f in (*flow.rhs_nodes, *p.variables):
            self._resolve(f, S, rows, None)
        self._resolve(p.domain, S, rows, p.domain)
        ok = rows & self._truth(p.domain, S)
        u = np.where(self.rng.random(self.n) < 0.5, 1.0, self.rng.random(self.n))
        if not ok.any():
            return ok
        at = np.flatnonzero(ok)  # flows are followed on the runs that take them only
        sub = S.take(at)
        closed = flow.solution is not None
        end = u[at] * flow.longest(sub, self.horizon, depth=8 if closed else 1)
        if self.top is not None:  # stopping is always allowed: stop where the guarantee is worst
            times = end[:, None] * (WATCH if closed else RK4_WATCH)[None, :]
            env = {k: v[:, None] for k, v in sub.vals.items()}
            env.update(flow.states(sub, times))
            margins = self._watch(env, sub, times.shape)
            margins = np.where(np.isnan(margins), np.inf, margins)  # values RK4 lost: not a stop
            k = margins.argmin(axis=1)
            pick = times[np.arange(len(at)), k]
            end = np.where((end > 0) & (margins[np.arange(len(at)), k] < 0), pick, end)
        after = flow.states(sub, end)
        good = np.isfinite(end)
        for v in after.values():
            good &= np.isfinite(v)
        duration = np.zeros(self.n)
        duration[at] = end
        ok[at[~good]] = False
        self.dropped[at[~good]] = True
        self._log("duration", ok, duration)
        for name, v in after.items():
            S.vals[name][at[good]] = v[good]
            S.open[name][at[good]] = False
        S.time[ok] += duration[ok]
        return ok


def _full(v, shape) -> np.ndarray:
    return v if np.ndim(v) else np.full(shape, float(v))


def _solve(lhs, rhs, name: str, vals: dict[str, np.ndarray], n: int) -> np.ndarray:
    """Per run, x with lhs = rhs where both sides are affine in `name` (state.solve_linear,
    vectorised); nan where they are not."""
    env = dict(vals)
    sides = []
    for x in (0.0, 1.0, 2.0):
        env[name] = np.full(n, x)
        sides.append((np.broadcast_to(lhs(env), (n,)), np.broadcast_to(rhs(env), (n,))))
    (l0, r0), (l1, r1), (l2, r2) = sides
    slope_l, slope_r = l1 - l0, r1 - r0
    linear = ((np.abs((l2 - l1) - slope_l) <= 1e-9 * (1 + np.abs(slope_l)))
              & (np.abs((r2 - r1) - slope_r) <= 1e-9 * (1 + np.abs(slope_r))))
    slope = slope_l - slope_r
    ok = linear & (slope != 0)
    return np.where(ok, (r0 - l0) / np.where(ok, slope, 1.0), np.nan)


_COMPILED: dict[tuple, BatchProgram | Unsupported] = {}


def compiled(theorem: Theorem, max_steps: int) -> BatchProgram:
    """The theorem compiled once per process (raises Unsupported, also from the cache)."""
    key = (theorem.content_hash, max_steps)
    got = _COMPILED.get(key)
    if got is None:
        try:
            got = BatchProgram(theorem, max_steps)
        except Unsupported as exc:
            got = exc
        _COMPILED[key] = got
    if isinstance(got, Unsupported):
        raise got
    return got
