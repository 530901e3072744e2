"""Following an ODE {x' = f & Q} from a concrete state.

Where the proof engine has the exact (polynomial) solution the flow is evaluated in closed
form; otherwise scipy's `solve_ivp` integrates it with error control and stops at the edge
of the evolution domain Q by event detection. The run may stop at any time the domain
still holds; the chooser picks that time as a share of the longest allowed duration.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any, Callable

import numpy as np

from certiloop.falsify.along import keeps_sign, sign_kept_parts, signed_domain, signs
from certiloop.falsify.evaluate import Blocked, Compiler, margin
from certiloop.falsify.vectorise import Unsupported, VCompiler
from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import And, Node, free_vars
from certiloop.proofs.core.wd import denominators
from certiloop.proofs.core.wp import flow_solution

GRID = 64  # samples when locating where a closed-form flow leaves its domain
WATCH_SAMPLES = 33  # samples along a flow for the guarantee's margins (plots, targeting)
MAX_RHS_CALLS = 20_000  # a stiff flow (a gain of 1e300) is given up, not followed for hours
ESCAPE = 1e9  # a flow is followed until a value reaches this (beyond any model's scale)
RTOL, ATOL = 1e-7, 1e-9  # found runs are re-checked, so search favours speed
NEAR = 1e-9  # a vectorised grid margin this close to 0 (relative) is decided by the scalar path
PROBE = 8  # grid points tried one by one before the rest of the grid is evaluated at once

# The watch over many samples at once: (state at the start, times, the flow's variables at those
# times as arrays) -> (labels, margins: one row per label, one column per time), or None when it
# cannot decide (the scalar watch is used then)
ManyWatch = Callable[[dict, np.ndarray, dict], "tuple[list[str], np.ndarray] | None"]


def _remembered(trajectory: Callable[[float], dict], longest: float) -> tuple[Callable[[float], dict], float]:
    """The trajectory with each time's state computed once and returned as the same object:
    the watch's samples are the run's samples whenever the flow runs to the end (so the
    interpreter computes their margins once)."""
    states: dict[float, dict] = {}

    def at(t: float) -> dict:
        got = states.get(t)
        if got is None:
            got = states[t] = trajectory(t)
        return got
    return at, longest


class Inexact(Exception):
    """This flow has no closed form, so it cannot be replayed in exact arithmetic."""


class Flow:
    def __init__(self, ode: ODE, compiler: Compiler) -> None:
        self.ode = ode
        self.exact = compiler.exact
        self.names = [v.name for v in ode.variables]
        self.rhs = [compiler(f) for _, f in ode.eqs]
        moving = set(self.names)
        dividing = {d.key: d for _, f in ode.eqs for d in denominators(f) if set(free_vars(d)) & moving}
        self._denominators = [compiler(d) for d in dividing.values()]
        # the domain holds at the start in full; along the flow, the equalities it keeps by
        # itself need no watching (a lifted root's s*s = e, which rounding would break at once)
        along = conserved_apart(ode)[0]
        # `a != b` watched as "a - b keeps its starting sign": a grid samples it true on both
        # sides of a = b, where every true run stops (`along.py`)
        signed, pairs = signed_domain(along)
        self._sign_pairs = [(name, compiler(d)) for name, d in pairs]
        self.domain = margin(signed, compiler)
        self.domain_holds = compiler(ode.domain)
        self.along_holds = compiler(along)
        s, solution = flow_solution(ode)
        self.s_name = s.payload
        self.solution = None if solution is None else {n: compiler(x) for n, x in solution.items()}
        self.symbolic = solution
        self._along = None
        # the components of the closed form the domain reads: its scalar margin along the flow
        # computes only these (`_margin_along`)
        reads = free_vars(along)
        self._domain_parts = [] if solution is None else [
            (n, fn) for n, fn in self.solution.items() if n in reads]
        self._vector = _NOT_YET

    @property
    def vector(self) -> "_VectorFlow | None":
        """The closed form and the domain's margin compiled to numpy (None: no closed form, or
        a construct `vectorise` does not compile); built on first use."""
        if self._vector is _NOT_YET:
            try:
                self._vector = None if self.symbolic is None or self.exact else _VectorFlow(self)
            except Unsupported:
                self._vector = None
        return self._vector

    # ---- the state after following the flow for tau
    def at(self, state: dict[str, Any], tau) -> dict[str, Any]:
        if self.solution is None:
            raise Inexact(f"the ODE {self.ode} has no closed-form solution")
        env = dict(state)
        env[self.s_name] = tau
        out = dict(state)
        for name, fn in self.solution.items():
            out[name] = fn(env)
        return out

    def run(self, state: dict[str, Any], duration: Callable[[Callable[[float], float]], float],
            horizon: float, watch: Callable[[dict], float] | None = None, many: ManyWatch | None = None):
        """Follow the flow for a duration chosen through `duration`; returns the end state,
        the duration and sampled (tau, state, guarantee margins or None) triples along the way.
        `many` evaluates the watch on all samples at once where it can (margins given then);
        the end state and the duration's checks never come from it."""
        if not self.domain_holds(state):
            raise Blocked("the evolution domain does not hold at the start")
        if self.exact:
            tau = Fraction(duration(lambda u: 0.0))
            if tau == 0 and self.symbolic is None:  # no time passes: exact without a closed form
                return dict(state), tau, [(0, state, None)]
            self._check_exact(state, tau)
            return self.at(state, tau), tau, [(0, state, None), (tau, self.at(state, tau), None)]
        trajectory, longest, values_at = self._trajectory(state, horizon)
        trajectory, longest = _remembered(trajectory, longest)
        seen: dict[float, tuple[np.ndarray, dict, list[str], np.ndarray]] = {}

        def watched(end: float):
            """The samples up to `end` with their margins, all at once (None: not possible)."""
            if many is None or values_at is None:
                return None
            got = seen.get(end)
            if got is None:
                times = np.linspace(0.0, end, WATCH_SAMPLES)
                values = values_at(times)
                out = None if values is None else many(state, times, values)
                if out is None:
                    return None
                got = seen[end] = (times, values, *out)
            return got

        def settle(u: float) -> float:
            end = u * longest
            if watch is None or end <= 0:
                return end
            # stopping the flow is always allowed: stop where the guarantee is worst
            fast = watched(end)
            if fast is not None:
                times, _values, labels, table = fast
                worst_of = table.min(axis=0) if labels else np.ones(len(times))
                worst = int(np.argmin(worst_of))  # the first of equal minima, as below
                return float(times[worst]) if worst_of[worst] < 0 else end
            times = [float(t) for t in np.linspace(0.0, end, WATCH_SAMPLES)]
            values = [watch(trajectory(t)) for t in times]
            worst = min(range(len(times)), key=values.__getitem__)
            return times[worst] if values[worst] < 0 else end

        tau = float(duration(settle))
        if tau < 0 or tau > longest * (1 + 1e-12) + 1e-15:
            raise Blocked(f"ODE duration {tau} outside [0, {longest}]")
        fast = watched(tau) if tau > 0 else None
        if fast is not None:  # samples for plots: the vectorised values and margins
            times, values, labels, table = fast
            samples = []
            for k, t in enumerate(times):
                st = dict(state)
                for name, column in values.items():
                    st[name] = float(column[k])
                samples.append((float(t), st, {label: float(row[k]) for label, row in zip(labels, table)}))
        else:
            samples = [(float(t), trajectory(float(t)), None) for t in np.linspace(0.0, tau, WATCH_SAMPLES)]
        return trajectory(tau), tau, samples

    def _trajectory(self, state, horizon: float):
        """(tau -> state, longest duration within the domain and the horizon, times -> the
        flow's variables at those times as arrays, or None where that is not available)."""
        if self.solution is not None:
            traj = lambda t: self.at(state, t)  # noqa: E731
            vector = self.vector
            env = None if vector is None else vector.env(state)
            longest = self._exit_time(state, horizon, env)
            if env is None:
                return traj, longest, None
            return traj, longest, lambda times: vector.values(env, times)
        return self._integrate(state, horizon)

    def _exit_time(self, state, horizon: float, env: dict | None = None) -> float:
        g = self._margin_along(state)
        if env is not None:  # the grid's margins at once; the scalar g decides wherever it matters
            grid = lambda times: self.vector.margins(env, times)  # noqa: E731
            try:
                return _last_inside_fast(grid, g, 0.0, horizon, depth=0)
            except _Undecided:
                pass
        return _last_inside(g, 0.0, horizon, depth=0)

    def _margin_along(self, state) -> Callable[[float], float]:
        """tau -> the domain's margin after following the flow for tau from `state`: the same
        closures on the same values as `self.domain(self.at(state, tau))`, computing only the
        components of the closed form the domain reads (and no new dict per tau)."""
        env, out = dict(state), dict(state)
        out.update(signs(self._sign_pairs, state))
        parts, domain, s_name = self._domain_parts, self.domain, self.s_name

        def g(tau: float) -> float:
            env[s_name] = tau
            for name, fn in parts:
                out[name] = fn(env)
            return domain(out)
        return g

    def _integrate(self, state, horizon: float):
        names, rhs = self.names, self.rhs
        work = dict(state)
        work.update(signs(self._sign_pairs, state))

        def put(y):
            for name, value in zip(names, y):
                work[name] = float(value)
            return work

        calls = [0]

        def f(_t, y):
            calls[0] += 1
            if calls[0] > MAX_RHS_CALLS:
                raise Blocked(f"the flow is too stiff to follow ({MAX_RHS_CALLS} steps)")
            return [r(put(y)) for r in rhs]

        def leaves(_t, y):
            return self.domain(put(y))
        leaves.terminal, leaves.direction = True, -1

        def escapes(_t, y):  # a finite escape time: stop where a value leaves the models' scale
            return ESCAPE - float(np.max(np.abs(y)))
        escapes.terminal, escapes.direction = True, -1
        poles = [_pole_event(d, put) for d in self._denominators]  # no run passes x = 0 in x' = 1/x
        y0 = [float(state[n]) for n in names]
        try:
            with np.errstate(all="ignore"):  # a blow-up is detected below, not printed
                from scipy.integrate import solve_ivp  # lazily: importing scipy costs 0.35 s per process

                sol = solve_ivp(f, (0.0, horizon), y0, events=(leaves, escapes, *poles), dense_output=True,
                                rtol=RTOL, atol=ATOL)
        except (ValueError, OverflowError) as exc:  # event location on a blown-up solution
            raise Blocked(f"integration failed: {exc}") from None
        if sol.status == -1 or not np.all(np.isfinite(sol.y)):
            raise Blocked(f"integration failed: {sol.message}")
        longest = float(sol.t_events[0][0]) if len(sol.t_events[0]) else float(sol.t[-1])

        def traj(t):
            out = dict(state)
            for name, value in zip(names, sol.sol(min(t, longest))):
                out[name] = float(value)
            return out

        def values_at(times: np.ndarray) -> dict[str, np.ndarray]:
            return dict(zip(names, np.asarray(sol.sol(np.minimum(times, longest)), float)))
        return traj, longest, values_at

    def _check_exact(self, state, tau) -> None:
        """The domain must hold along the whole flow, decided exactly."""
        from certiloop.models.lang.terms import Var
        from certiloop.proofs.core.exact import truth
        from certiloop.proofs.core.odes import runs_along

        if self.symbolic is None:
            raise Inexact(f"the ODE {self.ode} has no closed-form solution")
        if tau < 0:
            raise Blocked("negative ODE duration")
        if self._along is None:
            # the domain, and the right-hand side as written defined all along (x' = x/x);
            # `a != b` as "a - b keeps one sign" (`along.py`), which is decided exactly
            ode, parts = self.ode, sign_kept_parts(self.ode.domain)
            if parts:
                ode = ODE(ode.eqs, parts[0])
            along = runs_along(ode, self.symbolic, Var("tau@flow"), Var(self.s_name))
            for difference in parts[1:]:
                along = And(along, keeps_sign(difference, self.symbolic, Var("tau@flow"), Var(self.s_name)))
            self._along = along
        env = exact_view(state)
        env["tau@flow"] = tau
        if truth(self._along, env) is not True:
            raise Blocked("the evolution domain does not provably hold along the flow")


def _pole_event(denominator, put):
    """A terminal event where the denominator changes sign: the flow is not defined there."""
    def crosses(_t, y):
        return float(denominator(put(y)))
    crosses.terminal, crosses.direction = True, 0
    return crosses


def conserved_apart(ode: ODE) -> tuple[Node, tuple[Node, ...]]:
    """The domain without its equalities `a = b` that the flow conserves (the derivative of
    a - b along it is identically 0), and those equalities. A solution that starts on such an
    equality stays on it for as long as it is defined, so only the rest must be watched."""
    from certiloop.models.lang.terms import ModelError
    from certiloop.proofs.core.odes import lie_derivative
    from certiloop.proofs.core.wd import has_division

    parts = ode.domain.args if ode.domain.op == "and" else (ode.domain,)
    kept, conserved = [], []
    for part in parts:
        # not one that divides: its derivative is simplified (x/x = 1 has derivative 0), but it
        # is false where its denominator is 0, which a run may reach
        equality = part.op == "cmp" and part.payload == "==" and part.args[0].sort.is_numeric
        if equality and not has_division(part):
            try:
                rate = lie_derivative(part.args[0] - part.args[1], ode)
            except ModelError:
                rate = None
            if rate is not None and rate.op == "const" and rate.payload == 0:
                conserved.append(part)
                continue
        kept.append(part)
    return And(*kept), tuple(conserved)


def _last_inside(g, start: float, end: float, depth: int) -> float:
    """The end of the first stretch from `start` on which g >= 0, on a grid refined where
    the flow starts on the domain's edge (g(start) = 0) and leaves it within one cell."""
    previous = start
    for t in np.linspace(start, end, GRID)[1:]:
        t = float(t)
        if g(t) < 0:
            if g(previous) > 0:
                try:
                    from scipy.optimize import brentq

                    root = brentq(g, previous, t, xtol=1e-14)
                except ValueError:  # g overflowed to inf/nan between the samples
                    return previous
                return root if g(root) >= 0 else previous + (root - previous) * (1 - 1e-9)
            if previous == start and depth < 8:
                return _last_inside(g, start, t, depth + 1)
            return previous
        previous = t
    return end


class _Undecided(Exception):
    """The vectorised grid and the scalar margin disagree (or the grid is not finite): the
    scalar `_last_inside` decides."""


def _last_inside_fast(grid, g, start: float, end: float, depth: int) -> float:
    """`_last_inside` with the margins on most of the grid computed at once by `grid` (numpy).
    The first PROBE points are the scalar path's own (a flow often leaves its domain within
    them, and numpy costs more than a few scalar margins); beyond them every grid point whose
    vectorised margin is within NEAR of 0, the first point found outside, the point before
    it and the root between them are evaluated by the scalar g, and any disagreement raises
    `_Undecided`. So the result is the scalar path's, unless the two evaluations differ by
    more than NEAR somewhere."""
    times = np.linspace(start, end, GRID)
    first = None  # the index in `times` of the first point outside
    for k in range(1, PROBE + 1):
        if g(float(times[k])) < 0:
            first = k
            break
    if first is None:
        with np.errstate(all="ignore"):
            values = np.asarray(grid(times[PROBE + 1:]), float)
        if values.shape != (GRID - PROBE - 1,) or not np.all(np.isfinite(values)):
            raise _Undecided
        band = NEAR * (1.0 + float(np.max(np.abs(values))))
        for k in np.flatnonzero(values < band):  # in grid order: the candidates for the first exit
            t = float(times[PROBE + 1 + k])
            if values[k] > -band:  # near 0: the scalar margin decides this point
                if g(t) < 0:
                    first = PROBE + 1 + int(k)
                    break
                continue
            if not g(t) < 0:
                raise _Undecided
            first = PROBE + 1 + int(k)
            break
    if first is None:
        return end
    t, previous = float(times[first]), (start if first == 1 else float(times[first - 1]))
    if g(previous) > 0:
        try:
            from scipy.optimize import brentq

            root = brentq(g, previous, t, xtol=1e-14)
        except ValueError:  # g overflowed to inf/nan between the samples
            return previous
        return root if g(root) >= 0 else previous + (root - previous) * (1 - 1e-9)
    if previous == start and depth < 8:
        return _last_inside_fast(grid, g, start, t, depth + 1)
    return previous


_NOT_YET = object()


def _plain(n: Node) -> None:
    """Unsupported unless n is built from real scalars only (no family cells, quantifiers or
    index symbols: the vectorised flow binds none of them)."""
    if n.op in ("select", "forall", "exists", "store", "apply", "box", "diamond"):
        raise Unsupported(f"`{n.op}` in `{n}`")
    for a in n.args:
        _plain(a)


class _VectorFlow:
    """A closed-form flow and its domain's margin as numpy closures over many times at once
    (`vectorise.VCompiler`): where to look for the domain's edge and the guarantee's worst
    point. Nothing it computes is a run's state or duration by itself."""

    def __init__(self, flow: Flow) -> None:
        vc = VCompiler()
        _plain(flow.ode.domain)
        for x in flow.symbolic.values():
            _plain(x)
        self.s_name = flow.s_name
        self.solution = {n: vc(x) for n, x in flow.symbolic.items()}
        signed, pairs = signed_domain(flow.ode.domain)  # as the scalar margin watches it
        self.domain = vc.margin(signed)
        self.sign_pairs = [(name, vc(d)) for name, d in pairs]
        reads: dict[str, None] = {}
        for x in (flow.ode.domain, *flow.symbolic.values()):
            reads.update(dict.fromkeys(free_vars(x)))
        reads.pop(self.s_name, None)
        self.reads = list(reads)

    def env(self, state: dict[str, Any]) -> dict[str, float] | None:
        """The values the closures read, as floats (None: one is open or not a number)."""
        out = {}
        for name in self.reads:
            value = state.get(name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                return None
            out[name] = float(value)
        with np.errstate(all="ignore"):
            out.update({k: float(v) for k, v in signs(self.sign_pairs, out).items()})
        return out

    def values(self, env: dict[str, float], times: np.ndarray) -> dict[str, np.ndarray] | None:
        """The flow's variables at `times` (None if one is not finite there)."""
        inner = dict(env)
        inner[self.s_name] = times
        out = {}
        with np.errstate(all="ignore"):
            for name, fn in self.solution.items():
                column = np.broadcast_to(np.asarray(fn(inner), float), times.shape)
                if not np.all(np.isfinite(column)):
                    return None
                out[name] = column
        return out

    def margins(self, env: dict[str, float], times: np.ndarray) -> np.ndarray:
        """The domain's margin at `times` (nan where a value is not finite)."""
        inner = dict(env)
        inner[self.s_name] = times
        after = dict(env)
        with np.errstate(all="ignore"):
            for name, fn in self.solution.items():
                after[name] = fn(inner)
            return np.broadcast_to(np.asarray(self.domain(after), float), times.shape)


def exact_view(state: dict[str, Any]) -> dict[str, Any]:
    """The state as proofs.exact expects it (arrays as ArrayValue, universes as lists)."""
    from certiloop.falsify.evaluate import Table
    from certiloop.proofs.core.solver import ArrayValue

    out = {}
    for name, value in state.items():
        if isinstance(value, Table):
            out[name] = ArrayValue(dict(value.cells), None)
        elif isinstance(value, range):
            out[name] = list(value)
        else:
            out[name] = value
    return out


NUMERIC_RTOL = 1e-6  # a closed form and the integration must agree this closely (relative)


def confirm_numerically(ode: ODE, before: dict[str, Any], tau: Any, after: dict[str, Any]) -> str:
    """'' if integrating the ODE's right-hand side numerically (scipy, DOP853, tight
    tolerances) from `before` for `tau` reaches `after` (the closed form's answer) within
    NUMERIC_RTOL; otherwise what disagrees. Independent of the closed form: the right-hand
    sides are compiled afresh and integrated step by step."""
    from certiloop.falsify.evaluate import Compiler, Table

    floats = Compiler(exact=False)
    rhs = [floats(f) for _, f in ode.eqs]
    names = [v.name for v in ode.variables]
    state = {k: (Table({i: float(x) for i, x in v.cells.items()}, None) if isinstance(v, Table)
                 else float(v) if isinstance(v, (int, float, Fraction)) and not isinstance(v, bool) else v)
             for k, v in before.items()}
    duration = float(tau)
    if duration == 0:
        return ""

    def f(_t, y):
        for name, value in zip(names, y):
            state[name] = float(value)
        return [r(state) for r in rhs]

    y0 = [float(before[n]) for n in names]
    with np.errstate(all="ignore"):
        from scipy.integrate import solve_ivp

        sol = solve_ivp(f, (0.0, duration), y0, method="DOP853", rtol=1e-12, atol=1e-14)
    if sol.status != 0:
        return f"the numerical integration failed: {sol.message}"
    for name, value in zip(names, sol.y[:, -1]):
        closed = float(after[name])
        scale = max(1.0, abs(closed), abs(float(before[name])))
        if not abs(value - closed) <= NUMERIC_RTOL * scale:
            return (f"{name} after {duration:g} s: the closed form gives {closed:.12g}, a numerical "
                    f"integration {value:.12g}")
    return ""
