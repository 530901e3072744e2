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

Compiled: real scalars, families of reals or Booleans over one index sort (the family's
size fixed per batch: runs of another size go in another batch), symbols of that sort
(`i := *; ?¬done(i)`: an element per run, tried in the interpreter's order), `foreach`
loops, and ∀/∃ over the index sort in tests, assumptions and the guarantee. A model over
integers and arrays (a Hoare triple: loop counters, array indices) is compiled by the
integer batch instead (`batch_ints.IntBatchProgram`: integer constants drawn per batch,
array cells per run; see there for its fragment). Anything else (Boolean symbols, reals
next to integers, other quantifiers, ...) raises `Unsupported` and the model keeps the
per-run search. Runs that hit a non-finite value (1/0, overflow) are dropped,
never reported; so are runs where the interpreter would backtrack over a finite choice (a
Boolean or an element accepted, then the test fails), whose decisions the batch does not
log.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

from certiloop.falsify.along import signed_domain, signs
from certiloop.falsify.batch.ints import IntBatchProgram, has_ints
from certiloop.falsify.batch.open_values import OpenValues, runs, solve_affine
from certiloop.falsify.batch.state import Bind, State
from certiloop.falsify.choosers import REAL_RANGE
from certiloop.falsify.evaluate import Table
from certiloop.falsify.flows import conserved_apart
from certiloop.falsify.interpreter import HORIZON, LOOP_BOUND, OPEN_LOOP_ITERATIONS, index_sorts, outer_loop
from certiloop.falsify.vectorise import (
    Leaf,
    Unsupported,
    VCompiler,
    check_family,
    conjuncts,
    is_index_sort,
)
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
from certiloop.models.lang.terms import BOOL, REAL, Node, free_vars
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
DIPS = 3  # sampled local minima of a domain's margin searched for a dip below 0, per run
GOLDEN_STEPS = 40  # golden-section steps: the cell shrinks by 0.618^40 (~4e-9)
GOLDEN = (math.sqrt(5) - 1) / 2


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
    families: dict[str, bool] = field(default_factory=dict)  # every family: Boolean-valued?
    sorts: list[str] = field(default_factory=list)  # the index sort(s), of size `elements`
    elements: int = 0

    def initial_state(self, r: int) -> dict[str, Any]:
        """Run r's initial state as the interpreter keeps one: families as tables (those the
        assumptions do not mention empty, i.e. open) and the index sort's universe."""
        out: dict[str, Any] = {f"#universe:{sort}": range(self.elements) for sort in self.sorts}
        for name in self.families:
            out[name] = Table()
        for name in self.symbols:
            v = self.initial[name][r]
            if name in self.families:
                cast = bool if self.families[name] else float
                out[name] = Table({(k,): cast(x) for k, x in enumerate(v)})
            else:
                out[name] = float(v)
        return out

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
        # along the flow (flows.py), `a != b` as "a - b keeps its starting sign" (along.py)
        signed, pairs = signed_domain(conserved_apart(ode)[0])
        self.domain_margin = vc.margin(signed)
        self.sign_pairs = [(name, vc(d)) for name, d in pairs]
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
        with np.errstate(all="ignore"):
            start = {**S.vals, **signs(self.sign_pairs, S.vals)}
        env = {k: (v[:, None] if grid else v) for k, v in start.items()}
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
            if closed:  # a window the flow passes between two samples (z' = 50, (z-1)^2 >= 1/100)
                self._dips(S, ts, g, g0)
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

    def _dips(self, S: State, ts: np.ndarray, g: np.ndarray, g0: np.ndarray) -> None:
        """Where the sampled margin has a positive local minimum, the least margin near it
        (golden-section search between its neighbours); a negative one replaces the sample
        (its time and margin), so the flow leaves the domain there, not beyond."""
        n = g.shape[0]
        at = np.arange(n)
        times = np.concatenate([np.zeros((n, 1)), ts], axis=1)
        full = np.concatenate([g0[:, None], g], axis=1)
        wall = np.full((n, 1), np.inf)  # the ends count as minima when the margin rises away from them
        left = np.concatenate([wall, full[:, :-1]], axis=1)
        right = np.concatenate([full[:, 1:], wall], axis=1)
        local = (full > 0) & (full <= left) & (full <= right) & np.isfinite(full)
        local &= np.cumsum(full < 0, axis=1) == 0  # only dips before any sampled exit
        last = full.shape[1] - 1
        for _ in range(DIPS):
            has = local.any(axis=1)
            if not has.any():
                return
            k = local.argmax(axis=1)  # index in `full`
            local[at[has], k[has]] = False
            lo, hi = times[at, np.maximum(k - 1, 0)].copy(), times[at, np.minimum(k + 1, last)].copy()
            for _ in range(GOLDEN_STEPS):
                a, b = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
                left = self._margin_at(S, a) < self._margin_at(S, b)
                hi, lo = np.where(left, b, hi), np.where(left, lo, a)
            t = (lo + hi) / 2
            m = self._margin_at(S, t)
            dip = has & (m < 0)
            if dip.any():  # the sample after the dip's start becomes the dip (t0 = 0 is not a sample of g)
                rows = at[dip]
                cols = np.maximum(k[dip] - 1, 0) + (times[rows, np.maximum(k[dip], 1)] < t[dip])
                cols = np.minimum(cols, g.shape[1] - 1)
                ts[rows, cols], g[rows, cols] = t[dip], m[dip]
                local[rows] = False

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


class BatchProgram(OpenValues):
    """A theorem compiled for batch simulation (raises Unsupported)."""

    def __init__(self, theorem: Theorem, max_steps: int = 3, horizon: float = HORIZON) -> None:
        self.theorem, self.max_steps, self.horizon = theorem, max_steps, horizon
        self.symbols = {**free_vars(theorem.assumptions), **program_symbols(theorem.program),
                        **free_vars(theorem.guarantee)}
        self.sorts = [sort.name for sort in index_sorts(theorem)]
        if len(self.sorts) > 1:
            raise Unsupported(f"more than one index sort ({', '.join(self.sorts)})")
        self.families = _families(self.symbols)
        self.vc = VCompiler()
        self.top = outer_loop(theorem.program)
        self.given = list(free_vars(theorem.assumptions))
        self.assumptions = self.vc(theorem.assumptions)
        self.guarantee = self.vc(theorem.guarantee)
        self.parts = [(self._part_margin(g), g) for g in conjuncts(theorem.guarantee)]
        self.flows: dict[int, _Flow] = {}
        self._leaves: dict[int, list[Leaf]] = {}
        self._fns: dict[int, Any] = {}
        self._ids: dict[int, int] = {}
        self._keys: dict[tuple, int] = {}
        self._shadowing: dict[int, bool] = {}
        self._symbols_read: dict[int, tuple[str, ...]] = {}
        self._touched: dict[int, list[str]] = {}
        self._prepare(theorem.program)
        self._prepare_formula(theorem.assumptions)

    def _part_margin(self, g: Node):
        """A ∀ over the index sort is one part per element in the interpreter: the smallest."""
        if g.op == "forall" and len(g.payload) == 1 and is_index_sort(g.payload[0].sort):
            self.vc(g)  # compiles or raises Unsupported
            return self.vc.element_margin(g)
        return self.vc.margin(g)

    def sizes(self, families: tuple[int, int]) -> list[int]:
        """The family sizes to run, one batch each: the search's range (at least one element,
        so that a cell is always there to read); [0] for a model without families."""
        if not self.sorts:
            return [0]
        lo, hi = families
        return list(range(max(lo, 1), max(hi, 1) + 1))

    # ------------------------------------------------------------------ compile
    def _prepare(self, p: Program) -> None:
        if isinstance(p, (Assign, Havoc)):
            if p.target.op not in ("var", "select"):
                raise Unsupported(f"assignment to `{p.target}`")
            if p.target.op == "select":
                self.vc(p.target)  # a family's cell at an index symbol, or Unsupported
            if isinstance(p, Assign):
                self.vc(p.value)
        elif isinstance(p, Test):
            self._prepare_formula(p.cond)
        elif isinstance(p, (Seq, Choice)):
            for q in (p.parts if isinstance(p, Seq) else p.alternatives):
                self._prepare(q)
        elif isinstance(p, Loop):
            self._prepare(p.body)
        elif isinstance(p, ODE):
            if any(v.payload in self.families for v in p.variables):
                raise Unsupported(f"a flow of a family in {p!r}")
            self.flows[id(p)] = _Flow(p, self.vc)
            self._prepare_formula(p.domain)
        else:
            raise Unsupported(f"statement {p!r}")

    def _prepare_formula(self, f: Node) -> None:
        self.vc(f)
        self.vc.margin(f)

    # ------------------------------------------------------------------ a batch
    def simulate(self, rng: np.random.Generator, n: int, elements: int = 0) -> Batch:
        """n runs whose index sort (if any) has `elements` elements."""
        if self.sorts and elements < 1:
            raise ValueError("a model with families needs a family size of at least 1")
        self.rng, self.n, self.vc.size = rng, n, elements
        self.events: list[tuple[str, np.ndarray, np.ndarray]] = []
        self.dropped = np.zeros(n, bool)  # a value went non-finite or RK4 lost it: abandoned
        self.flagged = np.zeros(n, bool)  # a finite choice accepted before its test was decided
        self.failed = np.zeros(n, bool)  # no value of a finite choice made its test true
        with np.errstate(all="ignore"):  # 1/0 and overflow: such runs are dropped
            S, accepted = self._initial()
            batch = Batch(n, self.given, {k: S.vals[k].copy() for k in self.given}, accepted,
                          np.zeros(n, bool), np.full(n, np.nan), self.events, families=self.families,
                          sorts=self.sorts, elements=elements)
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
        n, m = self.n, self.vc.size
        shape = {k: (n, m) if k in self.families else (n,) for k in self.symbols}
        S = State({k: np.full(shape[k], np.nan) for k in self.symbols},
                  {k: np.ones(shape[k], bool) for k in self.symbols}, np.zeros(n))
        for name in self.given:
            S.vals[name][:] = self._draw(name, shape[name])
            S.open[name][:] = False
        S.changed(*self.given)
        instances = self._instances(self.theorem.assumptions, np.ones(n, bool), {})
        counts = Counter(_where(leaf, bind) for atom, _, bind in instances
                         for leaf in self._order(atom, bind))
        edged: set[int] = set()
        for _ in range(REPAIR_PASSES):
            for at, (atom, rows, bind) in enumerate(instances):
                self._repair(atom, rows, bind, S, counts, at, edged)
        accepted = np.asarray(np.broadcast_to(self.assumptions(S.vals), (n,)), bool).copy()
        for name in self.given:
            v = S.vals[name]
            accepted &= np.isfinite(v).all(axis=1) if v.ndim == 2 else np.isfinite(v)
        return S, accepted

    def _draw(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """A given value: a real in the models' scale, a Boolean, or an element."""
        sort = self.symbols[name].sort
        if self.families.get(name):
            return self.rng.integers(0, 2, shape).astype(float)
        if is_index_sort(sort):
            return self.rng.integers(0, self.vc.size, shape).astype(float)
        return self.rng.uniform(-REAL_RANGE, REAL_RANGE, shape)

    def _instances(self, f: Node, rows: np.ndarray, bind: Bind) -> list[tuple[Node, np.ndarray, Bind]]:
        """Atoms to make true: conjuncts, one disjunct, a ∀ over the index sort per element."""
        if f.op == "and":
            return [i for a in f.args for i in self._instances(a, rows, bind)]
        if f.op == "or":
            pick = self.rng.integers(0, len(f.args), self.n)
            return [i for k, a in enumerate(f.args) for i in self._instances(a, rows & (pick == k), bind)]
        if f.op == "forall" and len(f.payload) == 1 and is_index_sort(f.payload[0].sort):
            name = f.payload[0].payload
            body = f.args[0]
            return [i for k in range(self.vc.size) for i in self._instances(body, rows, {**bind, name: k})]
        return [(f, rows, bind)]

    def _movable(self, leaf: Leaf, bind: Bind) -> bool:
        """A given real (a symbol, or a given family's cell at a bound element) a repair may move."""
        name, index = leaf
        if name not in self.given or self.families.get(name) or is_index_sort(self.symbols[name].sort):
            return False
        return index is None or index in bind

    def _repair(self, atom: Node, rows: np.ndarray, bind: Bind, S: State, counts: Counter, at: int,
                edged: set) -> None:
        if atom.op == "implies":
            self._repair_premise(atom, rows, bind, S)
            return
        if atom.op != "cmp":
            return
        holds = lambda: self._truth(atom, S, bind)  # noqa: E731
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
        lhs, rhs = self._fn(atom.args[0]), self._fn(atom.args[1])
        env = self._env(S, bind)
        for leaf in sorted(dict.fromkeys(self._order(atom, bind)), key=lambda v: counts[_where(v, bind)]):
            if not self._movable(leaf, bind) or not broken.any():
                continue
            x = solve_affine(lambda env: lhs(env) - rhs(env), lambda env: target,
                       partial(S.with_value, env, leaf, bind), self.n)
            old = S.get(leaf, bind)
            move = broken & np.isfinite(x)
            S.put(leaf, bind, move, x)
            env = self._env(S, bind)
            fixed = move & holds()
            S.put(leaf, bind, move & ~fixed, old)
            broken &= ~fixed
        if op == "==" and broken.any():
            self._scale(atom, broken, bind, S, holds)

    def _repair_premise(self, atom: Node, rows: np.ndarray, bind: Bind, S: State) -> None:
        """`b(j) -> φ` with b a given Boolean family (active boundaries): where φ fails, b(j)
        is made false, as the interpreter's draw of b(j) would have to be."""
        premise = atom.args[0]
        if premise.op != "select" or not self.families.get(premise.args[0].payload) \
                or premise.args[0].payload not in self.given:
            return
        leaf = self._order(premise)[-1]
        if leaf[1] not in bind:
            return
        S.put(leaf, bind, rows & ~self._truth(atom, S, bind), 0.0)

    def _scale(self, atom: Node, rows: np.ndarray, bind: Bind, S: State, holds) -> None:
        """Meet `h(x) = c` for h homogeneous of degree d by scaling every x by (c/h)^(1/d)
        (initial._scale, vectorised): unit normals."""
        names = [v for v in dict.fromkeys(self._order(atom, bind)) if self._movable(v, bind)]
        lhs, rhs = self._fn(atom.args[0]), self._fn(atom.args[1])
        env = self._env(S, bind)
        want = np.broadcast_to(rhs(env), (self.n,))
        have = np.broadcast_to(lhs(env), (self.n,))
        old = {v: S.get(v, bind) for v in names}
        for v in names:
            env = S.with_value(env, v, bind, old[v] * 2)
        doubled = np.broadcast_to(lhs(env), (self.n,))
        degree = np.log2(np.abs(doubled / have))
        ok = (rows & (have != 0) & (want / have > 0) & np.isfinite(degree) & (degree > 0)
              & (np.abs(degree - np.round(degree)) <= 1e-9))
        factor = (want / have) ** (1 / np.round(degree))
        for v in names:
            S.put(v, bind, ok, old[v] * factor)
        undo = ok & ~holds()
        for v in names:
            S.put(v, bind, undo, old[v])

    # ------------------------------------------------------------------ statements
    def _exec(self, p: Program, S: State, rows: np.ndarray) -> np.ndarray:
        """Run p on `rows`; the rows that did not block."""
        if not rows.any():
            return rows
        if isinstance(p, Assign):
            return self._assign(p, S, rows)
        if isinstance(p, Havoc):
            self._havoc(p.target, S, rows)
            return rows
        if isinstance(p, Test):
            return self._decide(p.cond, S, rows)
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

    def _assign(self, p: Assign, S: State, rows: np.ndarray) -> np.ndarray:
        self._resolve(p.value, S, rows, None)
        x = runs(np.asarray(self._fn(p.value)(S.vals), float), self.n)
        self.dropped |= rows & ~np.isfinite(x)
        ok = rows & ~self.dropped
        S.put(self._target(p.target, S, ok), {}, ok, x)
        return ok

    def _havoc(self, target: Node, S: State, rows: np.ndarray) -> None:
        if target.op == "var" and target.payload in self.families:  # a whole family: every cell open
            S.open[target.payload][rows] = True
            S.vals[target.payload][rows] = np.nan
            S.changed(target.payload)
            return
        S.put(self._target(target, S, rows), {}, rows, np.nan, open_=True)

    def _target(self, target: Node, S: State, rows: np.ndarray) -> Leaf:
        """The leaf a statement writes; a cell's index, if open, is chosen first (interpreter.store)."""
        if target.op == "var":
            return (target.payload, None)
        self._resolve(target.args[1], S, rows, None)
        return self._order(target)[-1]

    def _attempt(self, p: Program, S: State, rows: np.ndarray) -> np.ndarray:
        names = self._touched.get(id(p))
        if names is None:  # what p reads or writes: its open values may be chosen too
            names = self._touched[id(p)] = [k for k in program_symbols(p) if k in S.vals]
        trial = S.copy(names)
        ok = self._exec(p, trial, rows)
        S.merge(trial, ok, names)
        return ok

    def _choice(self, p: Choice, S: State, rows: np.ndarray) -> np.ndarray:
        """Each run tries the alternatives from its drawn first one on, cyclically, up to one
        that does not block. Runs are independent, so they go in rounds: in round t every
        run still pending tries its t-th alternative, grouped by alternative. Alternatives
        whose guard is false on known values block at once, deciding nothing: skipped."""
        n = len(p.alternatives)
        first = np.zeros(self.n, int)
        if n > 1:
            first = self.rng.integers(0, n, self.n)
            self._log("integer", rows, first)
        blocked = np.array([self._blocks_at_once(q, S, rows) for q in p.alternatives])  # (n, runs)
        order = (first[None, :] + np.arange(n)[:, None]) % n  # (k, runs): the k-th alternative tried
        eligible = ~np.take_along_axis(blocked, order, axis=0)
        rank = np.cumsum(eligible, axis=0) - 1  # among the ones tried, which round
        pending, done = rows.copy(), np.zeros(self.n, bool)
        for t in range(n):
            now = eligible & (rank == t)
            if not (pending & now.any(axis=0)).any():
                break
            for a in range(n):
                try_a = pending & (now & (order == a)).any(axis=0)
                if try_a.any():
                    ok = self._attempt(p.alternatives[a], S, try_a)
                    done |= ok
                    pending &= ~ok & ~self.dropped
        return done

    def _blocks_at_once(self, p: Program, S: State, rows: np.ndarray) -> np.ndarray:
        """Rows where p starts with a test that fails before it reads an open value."""
        while isinstance(p, Seq):
            p = p.parts[0]
        if not isinstance(p, Test):
            return np.zeros(self.n, bool)
        parts = conjuncts(p.cond)
        cur, out = rows.copy(), np.zeros(self.n, bool)
        for c in parts:  # left to right, as far as every value read so far is known
            known = self._known(c, S)
            t = self._truth(c, S)
            out |= cur & known & ~t
            cur &= known & t
            if not cur.any():
                break
        return out

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
        return self._known(f, S) & self._truth(f, S)

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
        for fn, part in self.parts:
            known = self._known(part, S)
            if len(shape) == 2:
                known = known[:, None]
            worst = np.where(known, np.minimum(worst, np.broadcast_to(fn(env), shape)), worst)
        return np.where(np.isinf(worst), 1.0, worst)

    def _ode(self, p: ODE, S: State, rows: np.ndarray) -> np.ndarray:
        flow = self.flows[id(p)]
        for f in (*flow.rhs_nodes, *p.variables):
            self._resolve(f, S, rows, None)
        ok = self._decide(p.domain, S, rows)
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
        S.changed(*after)
        S.time[ok] += duration[ok]
        return ok


def _full(v, shape) -> np.ndarray:
    return v if np.ndim(v) else np.full(shape, float(v))


def _families(symbols: dict[str, Node]) -> dict[str, bool]:
    """Every family of the model (name -> Boolean-valued); Unsupported for a symbol the batch
    cannot keep."""
    out: dict[str, bool] = {}
    for name, sym in symbols.items():
        sort = sym.sort
        if sort.is_array:
            check_family(sym)
            out[name] = sort.range == BOOL
        elif sort != REAL and not is_index_sort(sort):
            raise Unsupported(f"`{name}` is not a real scalar, a family over an index sort or an index")
    return out


def _where(leaf: Leaf, bind: Bind) -> tuple:
    """A leaf with its bound element filled in: which value it is, for counting repairs."""
    name, index = leaf
    return (name, bind.get(index, index)) if index is not None else (name,)


_COMPILED: dict[tuple, BatchProgram | IntBatchProgram | Unsupported] = {}


def compiled(theorem: Theorem, max_steps: int) -> BatchProgram | IntBatchProgram:
    """The theorem compiled once per process (raises Unsupported, also from the cache): by the
    real-valued batch, else, for a model over integers and arrays, by the integer batch."""
    key = (theorem.content_hash, max_steps)
    got = _COMPILED.get(key)
    if got is None:
        try:
            got = BatchProgram(theorem, max_steps)
        except Unsupported as exc:
            got = exc
            if has_ints(theorem):  # loop counters and array indices: the integer batch
                try:
                    got = IntBatchProgram(theorem, max_steps)
                except Unsupported as why:
                    got = why
        _COMPILED[key] = got
    if isinstance(got, Unsupported):
        raise got
    return got
