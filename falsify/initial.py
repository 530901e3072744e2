"""Initial states that satisfy a theorem's assumptions.

Drawing every value at random almost never satisfies `n·n = 1 ∧ (p - r)·n >= 0` for eight
boundaries at once, so values are drawn and then *repaired*: each violated assumption atom
is made true by moving one value it mentions (the one that occurs in the fewest atoms, so
that repairs do not undo each other) to where the atom holds, plus a chosen slack — often
zero, since boundaries are where designs break. Linear atoms are solved for that value;
an equation that is homogeneous in its values (a unit normal) is met by scaling them.
Whatever the repairs achieve, the state is used only if the assumptions hold exactly as
written; otherwise the example is rejected.
"""

from __future__ import annotations

import math
from collections import Counter
from fractions import Fraction
from typing import Any

from certiloop.falsify.evaluate import Blocked, NeedValue, Table
from certiloop.falsify.store import Rejected, get, put, quadratic_points, remove, solve_linear
from certiloop.models.lang.terms import INT, Node

REPAIR_PASSES = 3
REINSTANTIATE = 2  # extra rounds for assumptions with a bounded ∀ over Int


def initial_state(interp, chooser) -> dict[str, Any]:
    s: dict[str, Any] = {}
    lo, hi = interp.families
    for sort in interp.index_sorts:
        size = chooser.integer(f"size of {sort.name}", lo, hi)
        s[f"#universe:{sort.name}"] = range(size)
    for name, sym in interp.symbols.items():
        if sym.sort.is_array:
            s[name] = Table()
    assumptions = interp.theorem.assumptions
    edges: set = set()  # atoms whose edge was already considered (once per atom)
    # a bounded ∀ over Int is instantiated over the range drawn so far; repairs may move its
    # bounds (a path's length), so it is instantiated again over the repaired range
    rounds = 1 + REINSTANTIATE * _has_int_forall(assumptions)
    for _ in range(rounds):
        instances = _instances(interp, assumptions, {}, s, chooser)
        counts = Counter(key for atom, env in instances for key in _leaves(interp, atom, env, s))
        for _ in range(REPAIR_PASSES):
            broken = 0
            for atom, env in instances:
                if not _repair(interp, atom, env, s, counts, chooser, edges):
                    broken += 1
            if not broken:
                break
        if interp._holds(interp.c(assumptions), s, assumptions):
            return s
    raise Rejected("the drawn state does not satisfy the assumptions")


def _has_int_forall(f: Node) -> bool:
    if f.op == "forall" and len(f.payload) == 1 and f.payload[0].sort == INT:
        return True
    return any(_has_int_forall(a) for a in f.args if isinstance(a, Node))


def _instances(interp, f: Node, env: dict[str, Any], s, chooser) -> list[tuple[Node, dict]]:
    """The atoms to make true: conjuncts, ∀ over index sorts per element, one disjunct."""
    if f.op == "and":
        return [i for a in f.args for i in _instances(interp, a, env, s, chooser)]
    if f.op == "or":
        pick = chooser.pick("disjunct", len(f.args))
        return _instances(interp, f.args[pick], env, s, chooser)
    if f.op == "forall" and len(f.payload) == 1 and f.payload[0].sort == INT:
        expanded = _bounded_instances(interp, f, env, s, chooser)
        if expanded is not None:
            return expanded
    if f.op == "forall" and all(not v.sort.is_numeric and not v.sort.is_array for v in f.payload):
        from itertools import product

        from certiloop.falsify.evaluate import universe

        names = [v.payload for v in f.payload]
        pools = [universe(s, v.sort) for v in f.payload]
        return [i for combo in product(*pools)
                for i in _instances(interp, f.args[0], {**env, **dict(zip(names, combo))}, s, chooser)]
    return [(f, env)]


MAX_RANGE = 64  # elements of a bounded integer ∀ instantiated one by one (a path's elements)


def _bounded_instances(interp, f: Node, env: dict[str, Any], s, chooser) -> list[tuple[Node, dict]] | None:
    """`∀y. lo <= y < hi -> body` over Int (a path's elements): the atoms of body for each y in
    the range the drawn state gives, so each element's atoms can be repaired one by one; an
    implication inside is instantiated when its premise holds there. None when f is not of this
    shape or the range is too long (then f stays one atom). The range is the one drawn now; the
    final check of the assumptions as written decides either way."""
    var = f.payload[0].payload
    body = f.args[0]
    if body.op != "implies":
        return None
    lo = hi = None
    with _bound(s, env):
        for atom in _conjunct_atoms(body.args[0]):
            if atom.op != "cmp" or atom.args[0].op != "var" or atom.args[0].payload != var:
                return None
            try:
                bound = interp._value(interp.c(atom.args[1]), s)
            except Blocked:
                return None
            if isinstance(bound, bool) or not isinstance(bound, (int, float, Fraction)) \
                    or bound != int(bound):
                return None  # constants may come as floats or Fractions; integral ones are bounds
            bound = int(bound)
            if atom.payload in (">=", ">"):
                lo = bound + (atom.payload == ">")
            elif atom.payload in ("<", "<="):
                hi = bound + (atom.payload == "<=")
            else:
                return None
    if lo is None or hi is None or hi - lo > MAX_RANGE:
        return None
    out: list[tuple[Node, dict]] = []
    for y in range(lo, hi):
        out += _implied(interp, body.args[1], {**env, var: y}, s, chooser)
    return out


def _implied(interp, f: Node, env: dict[str, Any], s, chooser) -> list[tuple[Node, dict]]:
    """Atoms of f (inside a bounded ∀): conjuncts split, `p -> q` kept only where p holds."""
    if f.op == "and":
        return [i for a in f.args for i in _implied(interp, a, env, s, chooser)]
    if f.op == "implies":
        with _bound(s, env):
            holds = interp._holds(interp.c(f.args[0]), s, f.args[0])
        return _implied(interp, f.args[1], env, s, chooser) if holds else []
    return _instances(interp, f, env, s, chooser)


def _conjunct_atoms(f: Node) -> list[Node]:
    return [a for x in f.args for a in _conjunct_atoms(x)] if f.op == "and" else [f]


def _leaves(interp, atom: Node, env: dict, s) -> list:
    """The values an atom reads: symbols and array cells (with their indices evaluated).
    Where every cell's index is a variable the instance binds (`rx[j]` in ∀j), the answer
    depends on the atom and the binding only, and is remembered per interpreter."""
    cache = interp.leaf_cache
    key = (id(atom), tuple(sorted(env.items())))
    got = cache.get(key)
    if got is not None and got[0] is atom:
        return got[1]
    out = _read_leaves(interp, atom, env, s)
    if _bound_indices(atom, env):
        if len(cache) >= LEAF_CACHE:
            cache.clear()
        cache[key] = (atom, out)  # the atom is kept, so that its id is not reused
    return out


LEAF_CACHE = 100_000  # remembered (atom, binding) pairs per interpreter


def _bound_indices(n: Node, env: dict) -> bool:
    if n.op == "select":
        if not all(i.op == "var" and i.payload in env for i in n.args[1:]):
            return False
    return all(_bound_indices(a, env) for a in n.args)


def _read_leaves(interp, atom: Node, env: dict, s) -> list:
    out: list = []

    def walk(n: Node) -> None:
        if n.op == "var":
            if n.payload not in env and not n.sort.is_array:
                out.append(n.payload)
            return
        if n.op == "select":
            with _bound(s, env):
                try:
                    idx = tuple(interp._value(interp.c(i), s) for i in n.args[1:])
                except Blocked:
                    return
            out.append((n.args[0].payload, tuple(int(i) if not isinstance(i, bool) else i for i in idx)))
            return
        for a in n.args:
            walk(a)
    walk(atom)
    return out


class _bound:
    """Bind quantified variables in the state for the duration of a `with` block."""

    def __init__(self, s, env) -> None:
        self.s, self.env = s, env

    def __enter__(self):
        self.saved = {k: self.s[k] for k in self.env if k in self.s}
        self.s.update(self.env)

    def __exit__(self, *exc):
        for k in self.env:
            self.s.pop(k, None)
        self.s.update(self.saved)


def _repair(interp, atom: Node, env: dict, s, counts: Counter, chooser, done_edges: set) -> bool:
    """Make one atom true if it is not; False if it stays violated."""
    fn = interp.c(atom)
    with _bound(s, env):
        numeric = atom.op == "cmp" and atom.args[0].sort.is_numeric
        where = (atom.key, tuple(sorted(env.items())))
        edge = numeric and atom.payload in ("<=", ">=") and where not in done_edges
        if edge:
            done_edges.add(where)
            # designs break at the edges: sometimes put a non-strict bound exactly on its edge
            edge = chooser.flag("onto the edge")
        if interp._holds(fn, s, atom) and not edge:
            return True
        if not numeric:
            return False
        lhs, rhs = interp.c(atom.args[0]), interp.c(atom.args[1])
        interp._value(lhs, s)  # every value the atom reads gets one, to be moved below
        interp._value(rhs, s)
        if _quiet(fn, s) and not edge:
            return True
        leaves = [k for k in dict.fromkeys(_leaves(interp, atom, env, s)) if _numeric(k, s)]
        leaves.sort(key=lambda k: counts[k])
        slack = 0 if atom.payload == "==" or edge else chooser.slack(atom.payload in ("<", ">"))
        target = {">=": slack, ">": slack, "<=": -slack, "<": -slack, "==": 0, "!=": 1}[atom.payload]
        for key in leaves:
            old = get(s, key)
            x = solve_linear(lambda st: lhs(st) - rhs(st), lambda st: interp.c.number(target), key, s,
                             interp.exact)
            if x is None:
                continue
            if _is_int(interp, key):
                x = math.floor(x) if _holds_at(interp, fn, s, key, math.floor(x)) else math.ceil(x)
            put(s, key, x)
            if _quiet(fn, s):
                return True
            put(s, key, old) if old is not None else remove(s, key)
        if not interp.exact:  # quadratic in a value (gap*(w - gap) >= k*Y): its vertex or roots
            for key in leaves:
                if _is_int(interp, key) or get(s, key) is None:
                    continue
                old = get(s, key)
                for x in quadratic_points(lambda st: lhs(st) - rhs(st), key, s, edge):
                    put(s, key, x)
                    if _quiet(fn, s):
                        return True
                put(s, key, old)
        return atom.payload == "==" and _scale(interp, atom, fn, leaves, s)


def _scale(interp, atom: Node, fn, leaves, s) -> bool:
    """Meet `h(x) = c` for h homogeneous of degree d by scaling every x by (c/h)^(1/d)."""
    lhs, rhs = interp.c(atom.args[0]), interp.c(atom.args[1])
    try:
        want, have = float(rhs(s)), float(lhs(s))
        old = {k: get(s, k) for k in leaves}
        for k in leaves:
            put(s, k, old[k] * 2)
        doubled = float(lhs(s))
    except (NeedValue, Blocked, TypeError):
        return False
    if have == 0 or want / have <= 0:
        for k in leaves:
            put(s, k, old[k])
        return False
    degree = math.log2(abs(doubled / have)) if doubled else 0
    if not math.isfinite(degree) or degree <= 0 or abs(degree - round(degree)) > 1e-9:
        for k in leaves:
            put(s, k, old[k])
        return False
    factor = (want / have) ** (1 / round(degree))
    for k in leaves:
        put(s, k, interp.c.number(old[k] * factor) if not interp.exact else Fraction(old[k] * factor))
    return _quiet(fn, s)


def _holds_at(interp, fn, s, key, value) -> bool:
    put(s, key, value)
    try:
        return _quiet(fn, s)
    finally:
        remove(s, key)


def _quiet(fn, s) -> bool:
    try:
        return bool(fn(s))
    except (NeedValue, Blocked):
        return False


def _numeric(key, s) -> bool:
    value = get(s, key)
    return value is None or (isinstance(value, (int, float, Fraction)) and not isinstance(value, bool))


def _is_int(interp, key) -> bool:
    name = key if isinstance(key, str) else key[0]
    sym = interp.symbols.get(name)
    if sym is None:
        return False
    return (sym.sort.range if sym.sort.is_array else sym.sort) == INT
