"""The guarantee's margins at many samples of a flow at once, for the interpreter's watch.

`Interpreter.margins` evaluates every part of the guarantee (a ∀ over an index sort: one
part per element) on one state; a flow is watched at `flows.WATCH_SAMPLES` states, so the
same parts are evaluated here once on arrays of the flow's values (`vectorise.VCompiler`).
These margins only decide where a flow is stopped (where the guarantee is worst) and what
the plots show; every checkpoint is still evaluated by the interpreter's scalar closures.
Anything the vectorised closures cannot evaluate as the scalar ones would (an open value, a
missing family cell, a non-finite margin) gives None, and the interpreter's watch is used.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from certiloop.falsify.evaluate import Table
from certiloop.falsify.vectorise import Leaf, Unsupported, VCompiler, check_family, is_index_sort, leaves
from certiloop.models.lang.terms import Node, free_vars


class ManyMargins:
    """Raises Unsupported for a guarantee `vectorise` does not compile."""

    def __init__(self, guarantee: Node) -> None:
        self.vc = VCompiler()
        # (text, element variable or None, margin, the values it reads: vectorise.leaves)
        self.parts: list[tuple[str, str | None, Any, list[Leaf]]] = []
        sorts: dict[str, Any] = {}
        for g in _conjuncts(guarantee):
            if g.op == "forall" and len(g.payload) == 1 and is_index_sort(g.payload[0].sort):
                v, body = g.payload[0], g.args[0]
                sorts[v.sort.name] = v.sort
                _no_quantifier(body)
                read = [leaf for leaf in leaves(body) if leaf != (v.payload, None)]
                self.parts.append((str(body), v.payload, self.vc.margin(body), read))
            else:
                _no_quantifier(g)
                self.parts.append((str(g), None, self.vc.margin(g), leaves(g)))
        self.reads = free_vars(guarantee)
        for sym in self.reads.values():
            if sym.sort.is_array:
                check_family(sym)
                sorts[sym.sort.domain[0].name] = sym.sort.domain[0]
            elif not sym.sort.is_numeric and is_index_sort(sym.sort):
                sorts[sym.sort.name] = sym.sort
        if len(sorts) > 1:
            raise Unsupported(f"more than one index sort ({', '.join(sorts)})")
        self.sort = next(iter(sorts.values()), None)

    def __call__(self, state: dict[str, Any], times: np.ndarray,
                 values: dict[str, np.ndarray]) -> tuple[list[str], np.ndarray] | None:
        """(labels as `Interpreter.margins` gives them, margins: a row per label, a column per
        time) with the flow's variables at `values`, the rest from `state`. A part that reads
        an open value is left out, as the interpreter leaves it out; None if a value is not a
        number or a margin is not finite."""
        size = 0
        if self.sort is not None:
            elements = state.get(f"#universe:{self.sort.name}")
            if not isinstance(elements, range) or elements.start != 0 or elements.step != 1:
                return None
            size = len(elements)
        env: dict[str, Any] = {}
        open_cells: set[tuple[str, int]] = set()
        for name, sym in self.reads.items():
            if name in values:
                env[name] = values[name]
                continue
            value = state.get(name)
            if value is None:
                continue  # open: the parts reading it are left out
            if sym.sort.is_array:
                if not isinstance(value, Table):
                    return None
                boolean = sym.sort.range.name == "Bool"
                cells = []
                for k in range(size):
                    c = value.read((k,))
                    if c is None:
                        open_cells.add((name, k))
                        c = False if boolean else 0.0
                    elif boolean != isinstance(c, bool) or not isinstance(c, (int, float)):
                        return None
                    cells.append(c)
                env[name] = np.array(cells, bool if boolean else float)
            elif sym.sort.is_numeric:
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    return None
                env[name] = float(value)
            elif isinstance(value, int) and not isinstance(value, bool) and 0 <= value < size:
                env[name] = value  # an element of the index sort
            else:
                return None
        self.vc.size = size
        labels: list[str] = []
        rows: list[np.ndarray] = []
        with np.errstate(all="ignore"):
            for text, variable, fn, read in self.parts:
                if any(index is None and name not in env for name, index in read):
                    continue
                if variable is None:
                    if not any((name, env[index]) in open_cells for name, index in read if index is not None):
                        labels.append(text)
                        rows.append(np.broadcast_to(np.asarray(fn(env), float), times.shape))
                    continue
                inner = dict(env)
                for x in range(size):
                    inner[variable] = x
                    if any((name, inner[index]) in open_cells for name, index in read if index is not None):
                        continue
                    labels.append(f"{text} [{variable}={x}]")
                    rows.append(np.broadcast_to(np.asarray(fn(inner), float), times.shape))
        table = np.array(rows, float).reshape(len(rows), len(times))
        if not np.all(np.isfinite(table)):
            return None
        return labels, table


def _conjuncts(f: Node) -> list[Node]:
    if f.op == "and":
        return [a for x in f.args for a in _conjuncts(x)]
    return [f]


def _no_quantifier(f: Node) -> None:
    """A part's margin reads every value it mentions only without quantifiers inside (theirs
    stop at the first element that decides), so only such parts are vectorised."""
    if f.op in ("forall", "exists"):
        raise Unsupported(f"a quantifier inside a part of the guarantee: `{f}`")
    for a in f.args:
        _no_quantifier(a)
