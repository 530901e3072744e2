"""Open values of a batch (`batch.BatchProgram`), chosen as the interpreter chooses them.

A test reads its open values left to right, short-circuiting, a ∀/∃ over the index sort
element by element (`interpreter._holds`, `evaluate._enumerate`): a real an equation of the
test pins down is solved for, any other real is drawn (and logged); a Boolean (a family's
cell) or an element of the index sort is a finite choice, its values tried in the order
`interpreter.candidates` gives (the drawn flag, then its negation; the drawn element, then
the next ones cyclically), the first that makes the test true kept. The interpreter tries
a finite choice's values by backtracking, drawing again whatever it read after one; the
batch logs one path only, so a run that accepted a value before its test was decided and
then fails the test is dropped (never completed, never reported).
"""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np

from certiloop.falsify.batch.state import Bind, State
from certiloop.falsify.choosers import REAL_RANGE
from certiloop.falsify.vectorise import Leaf, conjuncts, is_index_sort, leaves
from certiloop.models.lang.terms import Node


class OpenValues:
    """The open-value part of BatchProgram (a mixin: it uses the program's compiler `vc`,
    `symbols`, `families`, and the batch's `rng`, `n`, `dropped` and `_log`)."""

    vc: Any
    symbols: dict[str, Node]
    families: dict[str, bool]
    rng: np.random.Generator
    n: int
    dropped: np.ndarray
    _leaves: dict[int, list[Leaf]]
    _fns: dict[int, Any]
    _ids: dict[int, int]
    _keys: dict[tuple, int]
    _shadowing: dict[int, bool]
    _symbols_read: dict[int, tuple[str, ...]]

    def _log(self, kind: str, rows: np.ndarray, values: np.ndarray) -> None:
        raise NotImplementedError

    def _order(self, n: Node, bind: Bind | None = None) -> list[Leaf]:
        """The leaves n reads in order, without the variables `bind` binds (not values)."""
        got = self._leaves.get(id(n))  # by identity: hashing a big node's key costs more than its use
        if got is None:
            got = self._leaves[id(n)] = leaves(n)
        return [leaf for leaf in got if leaf[0] not in bind] if bind else got

    def _fn(self, n: Node):
        """n's closure, cached by identity (the theorem keeps its nodes alive)."""
        got = self._fns.get(id(n))
        if got is None:
            got = self._fns[id(n)] = self.vc(n)
        return got

    def _env(self, S: State, bind: Bind) -> dict[str, Any]:
        return {**S.vals, **bind} if bind else S.vals

    def _same(self, n: Node) -> int:
        """One number for every node with n's key (the same closure, the same truth), cached by
        identity: a test's conjunct repeated in a choice's alternatives is evaluated once."""
        got = self._ids.get(id(n))
        if got is None:
            got = self._ids[id(n)] = self._keys.setdefault(n.key, len(self._keys))
        return got

    def _shadows(self, f: Node) -> bool:
        """A quantifier of f binds the name of a symbol (whose cells `_known` would then take at
        that symbol): `_resolve` walks f without asking first whether all of it is known."""
        got = self._shadowing.get(id(f))
        if got is None:
            def walk(x: Node) -> bool:
                if x.op in ("forall", "exists") and any(v.payload in self.symbols for v in x.payload):
                    return True
                return any(walk(a) for a in x.args)
            got = self._shadowing[id(f)] = walk(f)
        return got

    def _reads(self, f: Node) -> tuple[str, ...]:
        """The symbols f reads (a cell's family and index), cached by identity: its truth
        holds while none of them is written."""
        got = self._symbols_read.get(id(f))
        if got is None:
            names = (x for leaf in self._order(f) for x in leaf if x is not None and x in self.symbols)
            got = self._symbols_read[id(f)] = tuple(dict.fromkeys(names))
        return got

    def _truth(self, f: Node, S: State, bind: Bind | None = None) -> np.ndarray:
        """Per run: f holds. Kept in S's memo until a symbol f reads is written (read-only:
        shared). A conjunction, disjunction or ∀/∃ over the index sort whose parts' truths
        are all kept (`_resolve` has just evaluated them) is combined from them, as its
        closure combines its parts (all of them, no short-circuit)."""
        key = ("truth", self._same(f), tuple(bind.items()) if bind else ())
        stamp = S.stamp(self._reads(f))
        got = S.recall(key, stamp)
        if got is not None:
            return got
        got = self._combined(f, S, bind)
        if got is None:
            got = np.asarray(self._fn(f)(self._env(S, bind or {})), bool)
            got = got if got.shape == (S.n,) else np.broadcast_to(got, (S.n,))
        if got.flags.writeable:
            got.flags.writeable = False
        S.keep(key, stamp, got)
        return got

    def _combined(self, f: Node, S: State, bind: Bind | None) -> np.ndarray | None:
        """f's truth from its parts' kept truths, or None if one of them is not kept."""
        op = f.op
        if op in ("and", "or"):
            at = tuple(bind.items()) if bind else ()
            parts = [S.recall(("truth", self._same(a), at), S.stamp(self._reads(a))) for a in f.args]
            every = op == "and"
        elif op in ("forall", "exists"):
            name, body = f.payload[0].payload, f.args[0]
            part, stamp = self._same(body), S.stamp(self._reads(body))
            inner = {**bind, name: 0} if bind else {name: 0}
            parts = []
            for k in range(self.vc.size):
                inner[name] = k
                parts.append(S.recall(("truth", part, tuple(inner.items())), stamp))
            every = op == "forall"
        else:
            return None
        if not parts or any(t is None for t in parts):
            return None
        join = np.logical_and if every else np.logical_or
        got = parts[0] if len(parts) == 1 else join(parts[0], parts[1])
        for t in parts[2:]:
            got = join(got, t)
        return got

    def _known(self, f: Node, S: State, bind: Bind | None = None) -> np.ndarray:
        """Per run: every value f reads is chosen (a cell at a bound variable: every element).
        Conservative: f may short-circuit before an open value the interpreter never reads.
        Kept in S's memo until a symbol f reads is written (read-only: shared)."""
        at = tuple(bind.items()) if bind else ()
        key, stamp = ("known", self._same(f), at), S.stamp(self._reads(f))
        got = S.recall(key, stamp)
        if got is None and f.op in ("and", "or"):  # from its parts', where all are kept
            parts = [S.recall(("known", self._same(a), at), S.stamp(self._reads(a))) for a in f.args]
            if parts and all(t is not None for t in parts):
                got = parts[0] if len(parts) == 1 else parts[0] & parts[1]
                for t in parts[2:]:
                    got = got & t
                got.flags.writeable = False
                S.keep(key, stamp, got)
        if got is None:
            got = np.ones(S.n, bool)
            for leaf in self._order(f, bind):
                got &= ~S.is_open(leaf, bind or {})
            got.flags.writeable = False
            S.keep(key, stamp, got)
        return got

    # ------------------------------------------------------------------ choosing
    def _decide(self, cond: Node, S: State, rows: np.ndarray) -> np.ndarray:
        """A test (or a domain) on `rows`: its open values chosen, then its truth. A run that
        accepted a finite choice before the test was decided and then fails it is dropped:
        the interpreter would go back and try the choice's other values."""
        self.flagged = np.zeros(self.n, bool)
        self.failed = np.zeros(self.n, bool)
        self._resolve(cond, S, rows, cond, {}, (cond, {}), True)
        holds = rows & self._truth(cond, S) & ~self.failed
        self.dropped |= rows & self.flagged & ~holds
        return holds

    def _resolve(self, f: Node, S: State, rows: np.ndarray, cond: Node | None, bind: Bind | None = None,
                 unit: tuple[Node, Bind] | None = None, conj: bool = False) -> None:
        """Give every open value f reads a value, in the interpreter's order: formulas
        short-circuit left to right, ∀/∃ element by element; a value an equation of `cond`
        pins down is solved for, any other real is drawn (and logged), a Boolean or an element
        is tried value by value. `unit` is the part of `cond` whose falsity makes `cond` false
        (a conjunct, a ∀'s body at one element): a finite choice must make it true."""
        if cond is not None:  # runs whose test a finite choice already failed read nothing more
            rows = rows & ~self.failed
        if not rows.any():
            return
        bind = bind or {}
        if not self._shadows(f) and not (rows & ~self._known(f, S, bind)).any():
            return  # every value f reads is chosen on rows: nothing to do
        op = f.op
        if op in ("and", "or"):
            cur = rows.copy()
            for a in f.args:
                inner = conj and op == "and"
                self._resolve(a, S, cur, cond, bind, (a, bind) if inner else unit, inner)
                t = self._truth(a, S, bind)
                cur &= t if op == "and" else ~t
            return
        if op == "implies":
            self._resolve(f.args[0], S, rows, cond, bind, unit)
            self._resolve(f.args[1], S, rows & self._truth(f.args[0], S, bind), cond, bind, unit)
            return
        if op in ("not", "iff"):
            for a in f.args:
                self._resolve(a, S, rows, cond, bind, unit)
            return
        if op in ("forall", "exists"):
            self._resolve_elements(f, S, rows, cond, bind, unit, conj)
            return
        for leaf in self._order(f, bind):
            need = rows & S.is_open(leaf, bind)
            if need.any():
                self._choose(leaf, S, need, cond, bind, unit)

    def _resolve_elements(self, f: Node, S: State, rows: np.ndarray, cond: Node | None, bind: Bind,
                          unit: tuple[Node, Bind] | None, conj: bool) -> None:
        """∀/∃ over the index sort, as the interpreter enumerates it: element by element, up to
        the first that decides it."""
        name, body, every = f.payload[0].payload, f.args[0], f.op == "forall"
        cur = rows.copy()
        for k in range(self.vc.size):
            inner = {**bind, name: k}
            deeper = conj and every
            self._resolve(body, S, cur, cond, inner, (body, inner) if deeper else unit, deeper)
            t = self._truth(body, S, inner)
            cur &= t if every else ~t

    def _choose(self, leaf: Leaf, S: State, need: np.ndarray, cond: Node | None, bind: Bind,
                unit: tuple[Node, Bind] | None) -> None:
        name = leaf[0]
        if self.families.get(name) or is_index_sort(self.symbols[name].sort):
            self._choose_finite(leaf, S, need, cond, bind, unit)
            return
        left = need.copy()
        for atom in conjuncts(cond) if cond is not None else ():
            if atom.op != "cmp" or atom.payload != "==" or not atom.args[0].sort.is_numeric:
                continue
            order = self._order(atom, bind)
            if all(other[0] != name for other in order):  # it does not read the value: no solution
                continue
            rows = left.copy()
            for other in order:
                if other != leaf:
                    rows &= ~S.is_open(other, bind)
            if not rows.any():
                continue
            lhs, rhs = self._fn(atom.args[0]), self._fn(atom.args[1])
            env = self._env(S, bind)
            fixed = (name not in self._reads(atom.args[0]), name not in self._reads(atom.args[1]))
            x = solve_affine(lhs, rhs, partial(S.with_value, env, leaf, bind), self.n, fixed)
            solved = rows & np.isfinite(x)
            S.put(leaf, bind, solved, x)
            left &= ~solved
            if not left.any():
                return
        x = self.rng.uniform(-REAL_RANGE, REAL_RANGE, self.n)
        S.put(leaf, bind, left, x)
        self._log("real", left, x)

    def _choose_finite(self, leaf: Leaf, S: State, need: np.ndarray, cond: Node | None, bind: Bind,
                       unit: tuple[Node, Bind] | None) -> None:
        """A Boolean (the drawn flag first, then its negation) or an element (from a drawn
        one on, cyclically), as interpreter.candidates orders them: the first that makes the
        test true is kept; without a test (a value read), the first."""
        boolean = bool(self.families.get(leaf[0]))
        count = 2 if boolean else self.vc.size
        first = self.rng.integers(0, count, self.n)
        self._log("integer", need, first)
        pending = need.copy()
        for k in range(count):
            S.put(leaf, bind, pending, np.abs(first - k) if boolean else (first + k) % count)
            if cond is None:
                return
            pending &= ~self._accepts(S, cond, unit or (cond, {}), pending)
            if not pending.any():
                return
        S.put(leaf, bind, pending, np.nan, open_=True)  # none did: the test fails, the value stays open
        self.failed |= pending

    def _accepts(self, S: State, cond: Node, unit: tuple[Node, Bind], rows: np.ndarray) -> np.ndarray:
        """Per run: the candidate just written makes the test true — decided where the test
        reads no open value any more, else where its `unit` does, else (the unit reads values
        still open, chosen next) provisionally. Where the test is not decided yet the run is
        flagged: should the test fail, the interpreter would come back to try the next one."""
        whole = self._known(cond, S)
        node, bind = unit
        part = self._known(node, S, bind)
        ok = rows & np.where(whole, self._truth(cond, S), ~part | self._truth(node, S, bind))
        self.flagged |= ok & ~whole
        return ok


def solve_affine(lhs, rhs, at, n: int, fixed: tuple[bool, bool] = (False, False)) -> np.ndarray:
    """Per run, x with lhs = rhs where both sides are affine in a value (state.solve_linear,
    vectorised); `at(x)` is the environment with that value set to x; nan where they are not
    affine in it. `fixed`: the side does not read the value (evaluated once, the same
    arrays as three evaluations would give)."""
    sides: list[tuple[np.ndarray, np.ndarray]] = []
    for x in (0.0, 1.0, 2.0):
        env = at(np.full(n, x))
        sides.append((sides[0][0] if sides and fixed[0] else runs(lhs(env), n),
                      sides[0][1] if sides and fixed[1] else runs(rhs(env), n)))
    (l0, r0), (l1, r1), (l2, r2) = sides
    slope_l, slope_r = l1 - l0, r1 - r0
    linear = ((np.abs((l2 - l1) - slope_l) <= 1e-9 * (1 + np.abs(slope_l)))
              & (np.abs((r2 - r1) - slope_r) <= 1e-9 * (1 + np.abs(slope_r))))
    slope = slope_l - slope_r
    ok = linear & (slope != 0)
    return np.where(ok, (r0 - l0) / np.where(ok, slope, 1.0), np.nan)


def runs(v, n: int) -> np.ndarray:
    """v as one value per run: np.broadcast_to(v, (n,)), without its cost where v already is."""
    return v if type(v) is np.ndarray and v.shape == (n,) else np.broadcast_to(v, (n,))
