"""The batch simulator's state: every symbol as an array over the runs of a batch.

A real symbol (or an element of the index sort, as a float) is an array (runs,); a family
over the index sort is an array (runs, size) whose last axis is the family's elements,
Booleans stored as 0.0 / 1.0. `open` marks the values not yet chosen, as the interpreter's
missing keys and cells do. A value is read or written through a *leaf* (`vectorise.leaves`):
a symbol, or a family's cell at an index symbol — an element per run — or at a variable a
quantifier binds (`bind`: variable -> element, the same for every run).

`memo` keeps what is derived from the values (a cell's columns, open masks, the truths
`batch_open` computes), each with the stamps of the symbols it was derived from: kept while
none of them is written (`recall`). `stamps` gives each symbol a new stamp at every write,
and `written` lists the symbols written since the state was copied (a trial's: what `merge`
takes back): every write goes through this class or calls `changed(names)`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import count
from typing import Any, Iterable

import numpy as np

from certiloop.falsify.vectorise import Leaf

Bind = dict[str, int]
_STAMPS = count(1)  # never the same stamp twice, in any state


@dataclass
class State:
    vals: dict[str, np.ndarray]
    open: dict[str, np.ndarray]
    time: np.ndarray
    memo: dict[tuple, tuple[tuple, Any]] = field(default_factory=dict, repr=False, compare=False)
    written: set[str] = field(default_factory=set, repr=False, compare=False)
    stamps: dict[str, int] = field(default_factory=dict, repr=False, compare=False)

    def changed(self, *names: str) -> None:
        """After writing the symbols `names` directly (vals or open): new stamps for them (what
        was derived from them is stale), and note them written."""
        for k in names:
            self.stamps[k] = next(_STAMPS)
        self.written.update(names)

    def stamp(self, names: tuple[str, ...]) -> tuple:
        """The symbols' stamps: what was derived from them with these stamps still holds."""
        get = self.stamps.get
        return tuple([get(k, 0) for k in names])

    def recall(self, key: tuple, stamp: tuple) -> Any:
        """What `keep` kept under key, if derived with these stamps; else None."""
        got = self.memo.get(key)
        return got[1] if got is not None and got[0] == stamp else None

    def keep(self, key: tuple, stamp: tuple, value: Any) -> None:
        """Keep value (not to be modified: shared) as derived from symbols with these stamps."""
        self.memo[key] = (stamp, value)

    @property
    def n(self) -> int:
        return self.time.shape[0]

    def copy(self, names: Iterable[str] | None = None) -> "State":
        """A copy; with `names`, of those symbols only, the others shared (a trial that only
        touches `names`: 3-4 times fewer arrays copied per alternative of sbs.ctrl2's choices)."""
        vals, opened = dict(self.vals), dict(self.open)
        for k in self.vals if names is None else names:
            vals[k], opened[k] = self.vals[k].copy(), self.open[k].copy()
        return State(vals, opened, self.time.copy(), dict(self.memo), set(), dict(self.stamps))

    def merge(self, other: "State", rows: np.ndarray, names: Iterable[str] | None = None) -> None:
        """Take `other`'s values on `rows` (the runs whose attempt succeeded): of the symbols
        it wrote since it was copied from this state (the others are this state's still)."""
        if not rows.any():
            return
        for k in other.written if names is None else [k for k in names if k in other.written]:
            self.changed(k)
            v = self.vals[k]
            where = rows if v.ndim == 1 else rows[:, None]
            np.copyto(v, other.vals[k], where=where)
            np.copyto(self.open[k], other.open[k], where=where)
        np.copyto(self.time, other.time, where=rows)

    def take(self, at: np.ndarray) -> "State":
        """The runs `at` as a smaller batch."""
        return State({k: v[at] for k, v in self.vals.items()}, {k: v[at] for k, v in self.open.items()},
                     self.time[at])

    def set(self, name: str, rows: np.ndarray, values) -> None:
        self.changed(name)
        self.vals[name][rows] = np.broadcast_to(values, rows.shape)[rows]
        self.open[name][rows] = False

    # ------------------------------------------------------------------ leaves
    def column(self, leaf: Leaf, bind: Bind) -> int | np.ndarray | None:
        """Where a cell is: one element (bound), an element per run, or None (every element:
        a cell at a bound variable read outside its quantifier)."""
        index = leaf[1]
        if index in bind:
            return bind[index]
        if index in self.vals:
            key, stamp = ("column", index), (self.stamps.get(index, 0),)
            got = self.recall(key, stamp)
            if got is None:
                at = self.vals[index]
                got = np.where(np.isfinite(at), at, 0).astype(np.intp)
                got.flags.writeable = False
                self.keep(key, stamp, got)
            return got
        return None

    def is_open(self, leaf: Leaf, bind: Bind) -> np.ndarray:
        """Per run: the leaf is still open (for a cell at an open index: open too; for a cell
        at every element: any of them open)."""
        name, index = leaf
        if index is None:
            return self.open[name]
        key = ("open", name, bind[index] if index in bind else index)
        get = self.stamps.get
        stamp = (get(name, 0), get(index, 0))
        got = self.recall(key, stamp)
        if got is None:
            at = self.column(leaf, bind)
            table = self.open[name]
            if at is None:
                got = table.any(axis=1)
            elif isinstance(at, int):
                got = table[:, at].copy()
            else:
                got = self.open[index] | table[_rows(self.n), at]
            got.flags.writeable = False  # shared
            self.keep(key, stamp, got)
        return got

    def get(self, leaf: Leaf, bind: Bind) -> np.ndarray:
        """The leaf's values, one per run (a copy)."""
        name, index = leaf
        if index is None:
            return self.vals[name].copy()
        at = self.column(leaf, bind)
        table = self.vals[name]
        return table[:, at].copy() if isinstance(at, int) else table[_rows(self.n), at]

    def put(self, leaf: Leaf, bind: Bind, rows: np.ndarray, values, open_: bool = False) -> None:
        """Write (or, with open_, reopen) the leaf on `rows`."""
        name, index = leaf
        if open_ or np.shape(values) != rows.shape:
            values = np.broadcast_to(np.nan if open_ else values, rows.shape)
        if index is None:
            self.changed(name)
            self.vals[name][rows] = values[rows]
            self.open[name][rows] = open_
            return
        at = self.column(leaf, bind)
        r = np.flatnonzero(rows)
        if not r.size:
            return
        self.changed(name)
        cols = at if isinstance(at, int) else at[r]
        self.vals[name][r, cols] = values[r]
        self.open[name][r, cols] = open_

    def with_value(self, env: dict[str, Any], leaf: Leaf, bind: Bind, x: np.ndarray) -> dict[str, Any]:
        """env with the leaf set to x on every run (for solving a test for it)."""
        name, index = leaf
        out = dict(env)
        if index is None:
            out[name] = x
            return out
        at = self.column(leaf, bind)
        table = np.array(env[name], dtype=float)
        if isinstance(at, int):
            table[:, at] = x
        else:
            table[_rows(self.n), at] = x
        out[name] = table
        return out


_ARANGE: dict[int, np.ndarray] = {}


def _rows(n: int) -> np.ndarray:
    """np.arange(n), kept (read-only)."""
    got = _ARANGE.get(n)
    if got is None:
        got = _ARANGE[n] = np.arange(n)
        got.flags.writeable = False
    return got
