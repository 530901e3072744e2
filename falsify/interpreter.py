"""Run a theorem's hybrid program on concrete values.

Semantics (those of the proof engine, executed): an assignment stores a value; `x := *`
leaves x open until something reads it — a test that pins it down (x*G = 1) solves for
it, a finite choice (a Bool, an index) is tried value by value, anything else is asked of
the chooser; a test that fails blocks, and a blocked alternative of a choice makes the
interpreter try the next one; an ODE follows its flow for a duration within its domain.
A loop followed by its exit test (`for`, `foreach`) runs until the test holds; the
theorem's outer loop runs a number of control steps the chooser picks.

The guarantee is checked at every point a run may end: at the start, after each
iteration of the outer loop (ODE flows stopped where the guarantee is worst, which is
always an allowed duration) and at the end of the program.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from certiloop.falsify.choosers import REAL_RANGE, Chooser
from certiloop.falsify.evaluate import (
    OPEN,
    Blocked,
    BlockedByTest,
    Compiler,
    NeedValue,
    Table,
    margin,
    universe,
)
from certiloop.falsify.flows import Flow
from certiloop.falsify.initial import initial_state
from certiloop.falsify.store import Rejected, put, remove, solve_linear
from certiloop.models.kyx.square_roots import exact_root
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
from certiloop.models.lang.terms import BOOL, INT, ModelError, Node, free_vars
from certiloop.models.lang.theorem import Theorem

HORIZON = 10.0  # longest duration of an ODE without a time bound in its domain
LOOP_BOUND = 1000  # iterations of an inner loop before the run is abandoned
OPEN_LOOP_ITERATIONS = 3  # at most this many iterations of a loop with no exit test


_NOT_BUILT = object()


@dataclass
class _Model:
    """What every interpreter of one theorem (and number type) computes alike: closures, the
    guarantee's parts, symbols, flows. All of it is a function of the (immutable) theorem,
    so interpreters share it; the search's exact replays build one interpreter each."""

    theorem: Theorem  # kept, so that its id is not reused while cached
    compiler: Compiler
    parts: list
    index_sorts: list
    symbols: dict
    flows: dict = field(default_factory=dict)
    leaf_cache: dict = field(default_factory=dict)


_MODELS: dict[tuple[int, bool], _Model] = {}
MODELS_KEPT = 64


def _model(theorem: Theorem, exact: bool) -> _Model:
    got = _MODELS.get((id(theorem), exact))
    if got is None or got.theorem is not theorem:
        if len(_MODELS) >= MODELS_KEPT:
            _MODELS.clear()
        c = Compiler(exact)
        symbols = {**free_vars(theorem.assumptions), **program_symbols(theorem.program),
                   **free_vars(theorem.guarantee)}
        got = _MODELS[(id(theorem), exact)] = _Model(theorem, c, _parts(theorem.guarantee, c),
                                                      index_sorts(theorem), symbols)
    return got


class _Violated(Exception):
    pass


@dataclass
class Checkpoint:
    """A point where the run may end: the state and the margin of every guarantee part."""

    step: int  # iterations of the outer loop so far
    time: float  # model time (sum of ODE durations)
    choices: list[str]  # labels of the alternatives taken since the previous checkpoint
    state: dict[str, Any]
    margins: dict[str, float]

    def to_json(self) -> dict[str, Any]:
        return {"step": self.step, "time": round(self.time, 9), "choices": self.choices,
                "state": self.state, "margins": {k: round(v, 9) for k, v in self.margins.items()}}


@dataclass
class Run:
    checkpoints: list[Checkpoint] = field(default_factory=list)
    # along flows: (model time, guarantee margins, scalar state) for plots
    samples: list[tuple[float, dict[str, float], dict[str, float]]] = field(default_factory=list)
    step_starts: list[float] = field(default_factory=list)  # model time at each control step
    violated: str | None = None  # the guarantee part that failed, with its margin
    final: dict[str, Any] = field(default_factory=dict)  # the last checkpoint's state, unrounded
    # flows followed in closed form: (ODE, state before, duration, state after), so that a
    # replay can confirm them by numerical integration
    closed_form_flows: list[tuple[ODE, dict[str, Any], Any, dict[str, Any]]] = field(default_factory=list)

    @property
    def worst(self) -> float:
        return min((min(c.margins.values(), default=1.0) for c in self.checkpoints), default=1.0)


@dataclass
class _Part:
    """One conjunct of the guarantee; ∀ over an index sort splits into one per element."""

    text: str
    variable: str | None
    sort: Any
    margin: Any
    holds: Any


class Interpreter:
    def __init__(self, theorem: Theorem, exact: bool = False, max_steps: int = 3,
                 families: tuple[int, int] = (1, 8), horizon: float = HORIZON) -> None:
        self.theorem, self.max_steps, self.families, self.horizon = theorem, max_steps, families, horizon
        model = _model(theorem, exact)
        self.c = model.compiler
        self.exact = exact
        self.top = outer_loop(theorem.program)
        self.guarantee = self.c(theorem.guarantee)
        self.parts = model.parts
        self.index_sorts = model.index_sorts
        self.symbols = model.symbols
        self._flows: dict[int, Flow] = model.flows
        self._many: Any = _NOT_BUILT
        self.leaf_cache = model.leaf_cache  # initial._leaves: what an instance of an assumption atom reads

    # ------------------------------------------------------------------ a run
    def run(self, chooser: Chooser, initial: dict[str, Any] | None = None,
            checked: bool = False) -> Run:
        """One run; from `initial` (which must satisfy the assumptions, unless the caller
        `checked` that exactly already) or from a drawn state."""

        self.chooser, self.out = chooser, Run()
        self.path: list[str] = []
        self.time: Any = 0
        self.step = 0
        if initial is None:
            state = initial_state(self, chooser)
        else:
            state = copy_state(initial)
            if not checked and not self._holds(self.c(self.theorem.assumptions), state):
                raise Rejected("the given state does not satisfy the assumptions")
        try:
            if self.top is None or self.top is not self.theorem.program:
                self._exec(self.theorem.program, state)
                if self.top is None:
                    self._checkpoint(state)
            else:
                self._exec(self.top, state)
        except _Violated:
            pass
        return self.out

    def _checkpoint(self, s: dict[str, Any]) -> None:
        holds = bool(self._value(self.guarantee, s))  # values still open: any will do
        margins = self.margins(s)
        self.out.checkpoints.append(Checkpoint(self.step, float(self.time), self.path, snapshot(s), margins))
        self.out.final = copy_state(s)
        self.path = []
        if not holds:
            worst = min(margins, key=margins.get) if margins else str(self.theorem.guarantee)
            self.out.violated = f"{worst} (margin {margins.get(worst, -1.0):.6g})"
            raise _Violated

    def margins(self, s: dict[str, Any]) -> dict[str, float]:
        out: dict[str, float] = {}
        for part in self.parts:
            if part.variable is None:
                _keep_known(out, part.text, part.margin, s)
                continue
            saved = s.get(part.variable)
            for x in universe(s, part.sort):
                s[part.variable] = x
                _keep_known(out, f"{part.text} [{part.variable}={x}]", part.margin, s)
            if saved is None:
                s.pop(part.variable, None)
            else:
                s[part.variable] = saved
        return out


    # ------------------------------------------------------------------ statements
    def _exec(self, p: Program, s: dict[str, Any]) -> None:
        if isinstance(p, Assign):
            store(s, p.target, self._value(self.c(p.value), s), self)
        elif isinstance(p, Havoc):
            self._open(p.target, s)
        elif isinstance(p, Test):
            if not self._holds(self.c(p.cond), s, p.cond):
                raise BlockedByTest(p.cond)
        elif isinstance(p, Seq):
            parts = p.parts
            for k, q in enumerate(parts):
                if isinstance(q, Loop) and q is not self.top:
                    after = parts[k + 1] if k + 1 < len(parts) else None
                    self._loop(q, s, after.cond if isinstance(after, Test) else None)
                else:
                    self._exec(q, s)
        elif isinstance(p, Choice):
            self._choice(p, s)
        elif isinstance(p, Loop):
            if p is self.top:
                self._outer(p, s)
            else:
                self._loop(p, s, None)
        elif isinstance(p, ODE):
            self._ode(p, s)
        else:
            raise ModelError(f"cannot execute {p!r}")

    def _attempt(self, p: Program, s: dict[str, Any]) -> dict[str, Any] | None:
        """Run p on a copy of s; the new state, or None (and nothing changed) if it blocks."""
        mark = (len(self.path), len(self.out.samples), self.time)
        trial = copy_state(s)
        try:
            self._exec(p, trial)
            return trial
        except Blocked:
            del self.path[mark[0]:]
            del self.out.samples[mark[1]:]
            self.time = mark[2]
            return None

    def _choice(self, p: Choice, s: dict[str, Any]) -> None:
        n = len(p.alternatives)
        first = self.chooser.pick_label(p.labels) if n > 1 else 0
        for k in range(n):
            at = (first + k) % n
            self.path.append(p.labels[at])
            new = self._attempt(p.alternatives[at], s)
            if new is not None:
                s.clear()
                s.update(new)
                return
            self.path.pop()
        raise Blocked("every alternative blocks")

    def _loop(self, p: Loop, s: dict[str, Any], exit_test: Node | None) -> None:
        done = self.c(exit_test) if exit_test is not None else None
        for n in range(LOOP_BOUND):
            if done is not None and self._quietly(done, s):
                return
            if done is None and (n >= OPEN_LOOP_ITERATIONS or not self.chooser.flag("iterate")):
                return
            new = self._attempt(p.body, s)
            if new is None:
                return
            s.clear()
            s.update(new)
        raise Blocked(f"{p.label}: more than {LOOP_BOUND} iterations")

    def _outer(self, p: Loop, s: dict[str, Any]) -> None:
        self._checkpoint(s)
        for _ in range(self.chooser.integer("control steps", 1, self.max_steps)):
            self.out.step_starts.append(float(self.time))
            new = self._attempt(p.body, s)
            if new is None:  # no further step possible: the run ends here
                return
            s.clear()
            s.update(new)
            self.step += 1
            self._checkpoint(s)

    def _ode(self, p: ODE, s: dict[str, Any]) -> None:
        flow = self._flows.get(id(p))
        if flow is None:
            flow = self._flows[id(p)] = Flow(p, self.c)
        # open values the flow reads (a force rate nobody constrained, an unset position)
        for f in (*flow.rhs, *(self.c(v) for v in p.variables)):
            self._value(f, s)
        if not self._holds(flow.domain_holds, s, p.domain):
            raise Blocked("evolution domain false")
        seen: dict[int, tuple[dict, dict]] = {}  # id(state) -> (state, its margins)

        def margins_of(st: dict) -> dict[str, float]:  # a sample the watch saw is not redone
            got = seen.get(id(st))
            if got is None:
                got = seen[id(st)] = (st, self.margins(st))
            return got[1]

        watch = (lambda st: min(margins_of(st).values(), default=1.0)) if self.top is not None else None
        many = self._many_margins() if watch is not None else None
        before = copy_state(s) if flow.solution is not None else None
        end, tau, samples = flow.run(s, self.chooser.duration, self.horizon, watch, many)
        if before is not None:
            self.out.closed_form_flows.append((p, before, tau, dict(end)))
        # a sample differs from s only in the flow's variables: the other scalars are read once
        moving = set(flow.names) | set(flow.symbolic or ())
        fixed = {k: float(v) for k, v in s.items()
                 if k not in moving and isinstance(v, (float, Fraction)) and "@" not in k}
        for t, st, known in samples:
            scalars = dict(fixed)
            for k in moving:
                v = st.get(k)
                if isinstance(v, (float, Fraction)) and "@" not in k:
                    scalars[k] = float(v)
            margins = known if known is not None else margins_of(st)
            self.out.samples.append((float(self.time) + float(t), margins, scalars))
        self.time = self.time + tau
        s.update(end)

    def _many_margins(self):
        """The guarantee's margins on many samples at once (watch.ManyMargins), or None where
        it does not compile; built once per interpreter."""
        if self._many is _NOT_BUILT:
            from certiloop.falsify.vectorise import Unsupported
            from certiloop.falsify.watch import ManyMargins

            try:
                self._many = None if self.exact else ManyMargins(self.theorem.guarantee)
            except Unsupported:
                self._many = None
        return self._many

    def _quietly(self, fn, s) -> bool:
        try:
            return bool(fn(s))
        except (NeedValue, Blocked):
            return False

    # ------------------------------------------------------------------ open values
    def _open(self, target: Node, s: dict[str, Any]) -> None:
        given = self.chooser.havoc_value(str(target))
        if given is not None:  # a replay that knows the value
            if target.op == "var" and target.sort.is_array:
                s[target.payload] = given
            else:
                store(s, target, given, self)
            return
        if target.op == "var":
            if target.sort.is_array:
                s[target.payload] = Table()
            else:
                s.pop(target.payload, None)
            return
        name, idx = cell_of(target, s, self)
        table = s.setdefault(name, Table())
        if table.default is None:
            table.cells.pop(idx, None)
        else:
            table.cells[idx] = OPEN

    def _value(self, fn, s: dict[str, Any]) -> Any:
        """Evaluate a term; open values it reads are chosen freely."""
        while True:
            try:
                return fn(s)
            except NeedValue as need:
                put(s, need.key, self.candidates(need, s, None)[0])

    def _holds(self, fn, s: dict[str, Any], cond: Node | None = None) -> bool:
        """Evaluate a test; open values it reads are solved for or tried one by one."""
        try:
            return bool(fn(s))
        except NeedValue as need:
            for value in self.candidates(need, s, cond):
                put(s, need.key, value)
                if self._holds(fn, s, cond):
                    return True
                remove(s, need.key)
            return False

    def candidates(self, need: NeedValue, s: dict[str, Any], cond: Node | None) -> list[Any]:
        what = need.key if isinstance(need.key, str) else f"{need.key[0]}{list(need.key[1])}"
        sort = need.sort
        if sort == BOOL:
            first = self.chooser.flag(what)
            return [first, not first]
        if sort == INT:
            solved = self._solve(need.key, s, cond)
            if solved is not None:
                return [solved]
            lo, hi = self._int_bounds(need.key, s, cond)
            return [self.chooser.integer(what, lo, hi)]
        if sort.is_numeric:
            solved = self._solve(need.key, s, cond)
            if solved is not None:
                return [solved]
            bounds = self._real_bounds(need.key, s, cond)
            if bounds is not None:
                return [self.c.number(self.chooser.real_between(what, *bounds))]
            return [self.c.number(self.chooser.real(what))]
        elements = list(universe(s, sort))
        first = self.chooser.pick(what, len(elements))
        return elements[first:] + elements[:first]

    def _int_bounds(self, key, s: dict[str, Any], cond: Node | None) -> tuple[int, int]:
        """Where to draw an open Int: [-2, 8], narrowed by the test's bounds on it that are known
        now (`0 <= k & k < N` with N set: [0, N - 1]), so a havoc followed by a range test is not
        rejected most of the time. Only where the draw comes from; the test is still checked."""
        found_lo = found_hi = None
        for bound, strict, below in self._bounds(key, s, cond):
            if not isinstance(bound, (int, Fraction)) and not float(bound).is_integer():
                continue
            if below:
                b = int(bound) + strict
                found_lo = b if found_lo is None else max(found_lo, b)
            else:
                b = int(bound) - strict
                found_hi = b if found_hi is None else min(found_hi, b)
        return _span(found_lo, found_hi, 10, (-2, 8))

    def _real_bounds(self, key, s: dict[str, Any], cond: Node | None) -> tuple[float, float] | None:
        """Where to draw an open real that the test bounds (`-w/2 <= u & u <= w/2` with w set:
        [-w/2, w/2]); None when it bounds it on neither side. As for Ints, the test decides."""
        found_lo = found_hi = None
        for bound, _strict, below in self._bounds(key, s, cond):
            b = float(bound)
            if not math.isfinite(b):
                continue
            if below:
                found_lo = b if found_lo is None else max(found_lo, b)
            else:
                found_hi = b if found_hi is None else min(found_hi, b)
        if found_lo is None and found_hi is None:
            return None
        return _span(found_lo, found_hi, REAL_RANGE, None)

    def _bounds(self, key, s: dict[str, Any], cond: Node | None) -> list[tuple[Any, bool, bool]]:
        """The test's conjuncts `key op t` (either side) whose t is known now, as
        (value of t, strict, whether t bounds key from below)."""
        if cond is None or not isinstance(key, str):
            return []
        out = []
        for atom in _conjuncts(cond):
            if atom.op != "cmp" or atom.payload not in ("<", "<=", ">", ">="):
                continue
            left, right = atom.args
            op = atom.payload
            if right.op == "var" and right.payload == key:  # a < k reads as k > a
                left, right, op = right, left, {"<": ">", "<=": ">=", ">": "<", ">=": "<="}[op]
            if left.op != "var" or left.payload != key:
                continue
            try:
                bound = self.c(right)(s)
            except (NeedValue, Blocked, ArithmeticError):
                continue
            out.append((bound, op in ("<", ">"), op in (">", ">=")))
        return out

    def _solve(self, key, s: dict[str, Any], cond: Node | None):
        """The value of `key` that an equation of the test pins down, if it is linear in it."""
        if cond is None:
            return None
        for atom in _conjuncts(cond):
            if atom.op != "cmp" or atom.payload != "==" or not atom.args[0].sort.is_numeric:
                continue
            x = solve_linear(self.c(atom.args[0]), self.c(atom.args[1]), key, s, self.exact)
            if x is None:
                x = self._square_root(atom, key, s)
            if x is not None:
                return x
        return None

    def _square_root(self, atom: Node, key, s: dict[str, Any]):
        """The root that `key*key = t` (a square root lifted by the kyx reader: `?(r > 0 & r*r = e)`)
        pins down, with t known now: its non-negative root, exact only where it is rational
        (else None: the exact replay cannot take it). The test still decides."""
        for square, other in (atom.args, atom.args[::-1]):
            if not (isinstance(key, str) and _is_square_of(square, key)) or key in free_vars(other):
                continue
            try:
                t = self.c(other)(s)
            except (NeedValue, Blocked, ArithmeticError):
                return None
            if isinstance(t, bool) or not isinstance(t, (int, float, Fraction)) or t < 0:
                return None
            if self.exact:
                return exact_root(Fraction(t))
            return math.sqrt(t) if math.isfinite(t) else None
        return None


# --------------------------------------------------------------------------- helpers


def _is_square_of(n: Node, key: str) -> bool:
    """Is n written `key*key` or `key^2`?"""
    if n.op == "^":
        base = n.args[0]
        return n.payload == 2 and base.op == "var" and base.payload == key
    return (n.op == "*" and len(n.args) == 2
            and all(a.op == "var" and a.payload == key for a in n.args))


def _span(lo, hi, width, neither):
    """[lo, hi] from the bounds found: both (if they leave room), one side and `width`
    beyond it, or `neither`."""
    if lo is not None and hi is not None:
        return (lo, hi) if lo <= hi else neither
    if lo is not None:
        return lo, lo + width
    if hi is not None:
        return hi - width, hi
    return neither


def _keep_known(out: dict[str, float], label: str, fn, s) -> None:
    """The margin of a guarantee part, left out while it reads a value still open."""
    try:
        out[label] = float(fn(s))
    except (NeedValue, Blocked):
        pass


def _conjuncts(f: Node) -> list[Node]:
    if f.op == "and":
        return [a for x in f.args for a in _conjuncts(x)]
    return [f]


def outer_loop(p: Program) -> Loop | None:
    if isinstance(p, Loop):
        return p
    if isinstance(p, Seq) and isinstance(p.parts[-1], Loop):
        return p.parts[-1]
    return None


def _parts(guarantee: Node, c: Compiler) -> list[_Part]:
    out = []
    for g in _conjuncts(guarantee):
        if g.op == "forall" and len(g.payload) == 1 and _is_index(g.payload[0].sort):
            v = g.payload[0]
            out.append(_Part(str(g.args[0]), v.payload, v.sort, margin(g.args[0], c), c(g.args[0])))
        else:
            out.append(_Part(str(g), None, None, margin(g, c), c(g)))
    return out


def _is_index(sort) -> bool:
    return not sort.is_numeric and sort != BOOL and not sort.is_array


def index_sorts(theorem: Theorem) -> list:
    syms = {**program_symbols(theorem.program), **free_vars(theorem.assumptions),
            **free_vars(theorem.guarantee)}
    found: dict[str, Any] = {}

    def visit(sort):
        if sort.is_array:
            for d in sort.domain:
                visit(d)
        elif _is_index(sort):
            found[sort.name] = sort
    for sym in syms.values():
        visit(sym.sort)
    _bound_sorts(theorem.assumptions, visit)
    _bound_sorts(theorem.guarantee, visit)
    return list(found.values())


def _bound_sorts(f: Node, visit) -> None:
    if f.op in ("forall", "exists"):
        for v in f.payload:
            visit(v.sort)
    for a in f.args:
        _bound_sorts(a, visit)


def cell_of(target: Node, s: dict[str, Any], interp: Interpreter) -> tuple[str, tuple]:
    from certiloop.falsify.evaluate import index

    root, idx = target.args[0], target.args[1:]
    return root.payload, tuple(index(interp._value(interp.c(i), s)) for i in idx)


def store(s: dict[str, Any], target: Node, value: Any, interp: Interpreter) -> None:
    if target.op == "var":
        s[target.payload] = value
        return
    name, idx = cell_of(target, s, interp)
    table = s.get(name)
    if not isinstance(table, Table):
        table = s[name] = Table()
    table.cells[idx] = value


def copy_state(s: dict[str, Any]) -> dict[str, Any]:
    # `type(...) is` (Table has no subclasses): the interpreter copies a state per attempt
    return {k: (Table(dict(v.cells), v.default) if type(v) is Table else v) for k, v in s.items()}


def snapshot(s: dict[str, Any]) -> dict[str, Any]:
    """The state as plain JSON-able values (floats rounded to 9 significant digits)."""
    out: dict[str, Any] = {}
    for name in sorted(s):
        value = s[name]
        if name.startswith("#") or "@" in name or isinstance(value, range):
            continue
        if isinstance(value, Table):
            out[name] = {",".join(map(str, k)): _plain(v) for k, v in sorted(value.cells.items())
                         if v is not OPEN}
        else:
            out[name] = _plain(value)
    return out


def _plain(v: Any) -> Any:
    if isinstance(v, bool) or isinstance(v, int):
        return v
    if isinstance(v, (float, Fraction)):
        try:
            return float(f"{float(v):.9g}") + 0.0  # + 0.0 turns -0.0 into 0.0
        except OverflowError:  # an exact value beyond the float range (1/(G fn²) for fn = 1e-160)
            return float("inf") if v > 0 else float("-inf")
    return str(v)
