"""Lower a quantifier-free obligation with arrays and index sorts to plain real arithmetic,
so z3's nlsat (complete for nonlinear real arithmetic) can decide it.

1. Read over write: an atom P(select(store(a, i, v), j)) becomes
   (i = j -> P(v)) ∧ (i ≠ j -> P(select(a, j))), an equivalence.
2. Ackermann reduction: every remaining read a[t] becomes a symbol `a[t]`, and for every two
   reads of the same array, (s = t) -> (a[s] = a[t]) is assumed, an equisatisfiable rewrite.
3. Index-sort symbols become reals. They are only ever compared for equality, and a
   quantifier-free formula with equality is valid over every domain iff it is valid over
   an infinite one, such as the reals.
"""

from __future__ import annotations

import itertools

from certiloop.models.lang.memos import NodeMemo
from certiloop.models.lang.terms import BOOL, INT, REAL, And, Iff, Implies, Node, Not, Var, cmp, rebuild

ATOM_OPS = ("cmp", "select", "var", "true", "false")


def _find_read_over_write(n: Node) -> Node | None:
    if n.op == "select" and n.args[0].op == "store":
        return n
    for a in n.args:
        found = _find_read_over_write(a)
        if found is not None:
            return found
    return None


def _replace(n: Node, old: Node, new: Node) -> Node:
    if n.same(old):
        return new
    if not n.args:
        return n
    return rebuild(n, tuple(_replace(a, old, new) for a in n.args))


def _eq(a: Node, b: Node) -> Node:
    return Iff(a, b) if a.sort == BOOL else cmp("==", a, b)


_STORES_ELIMINATED = NodeMemo()


def eliminate_stores(f: Node) -> Node:
    """Every read over a write split into its two cases (kept per node: the obligations of a
    model share their hypotheses)."""
    if not _has(f, "store"):
        return f  # no read over a write below: the walk would rebuild nothing
    got = _STORES_ELIMINATED.get(f)
    if got is None:
        got = _STORES_ELIMINATED.put(f, _eliminate_stores(f))
    return got


def _eliminate_stores(f: Node) -> Node:
    if f.op in ("and", "or", "not", "implies", "iff", "forall", "exists"):
        return rebuild(f, tuple(eliminate_stores(a) for a in f.args))
    read = _find_read_over_write(f)
    if read is None:
        return f
    st, *reads = read.args
    base, *rest = st.args
    writes, value = rest[:-1], rest[-1]
    if all(w.same(r) for w, r in zip(writes, reads)):
        return eliminate_stores(_replace(f, read, value))
    same = And(*(_eq(w, r) for w, r in zip(writes, reads)))
    other = Node("select", (base, *reads), read.sort)
    return And(Implies(same, eliminate_stores(_replace(f, read, value))),
               Implies(Not(same), eliminate_stores(_replace(f, read, other))))


_HAS = {"select": NodeMemo(), "store": NodeMemo()}


def _has(n: Node, op: str) -> bool:
    if n.op == op:
        return True
    if not n.args:
        return False
    memo = _HAS[op]
    got = memo.get(n)
    return memo.put(n, any(_has(a, op) for a in n.args)) if got is None else got


def _lowered_sort(sort):
    """Index-sort values become reals (they are only compared for equality)."""
    return REAL if sort not in (REAL, INT, BOOL) and not sort.is_array else sort


_KEEPABLE = NodeMemo()  # outside any quantifier only: the common case


def _quantifiers_keepable(n: Node, bound: frozenset[str]) -> bool:
    if not n.args:
        return True
    if not bound:
        got = _KEEPABLE.get(n)
        if got is None:
            got = _KEEPABLE.put(n, _keepable(n, bound))
        return got
    return _keepable(n, bound)


def _keepable(n: Node, bound: frozenset[str]) -> bool:
    if n.op in ("forall", "exists"):
        if any(v.sort != REAL for v in n.payload):
            return False
        bound = bound | {v.payload for v in n.payload}
    if n.op == "select" and any(_mentions(i, bound) for i in n.args[1:]):
        return False
    return all(_quantifiers_keepable(a, bound) for a in n.args)


def _mentions(n: Node, names: frozenset[str]) -> bool:
    return (n.op == "var" and n.payload in names) or any(_mentions(a, names) for a in n.args)


_READ_NAMES = NodeMemo()


def read_name(read: Node) -> str:
    got = _READ_NAMES.get(read)
    if got is None:
        array, *idx = read.args
        got = _READ_NAMES.put(read, f"{array.payload}[{','.join(str(i) for i in idx)}]")
    return got


_READS = NodeMemo()
_NESTED = "nested reads"


def _reads(n: Node) -> dict[str, Node] | None:
    """The array reads in `n` by `read_name`, in the order they first occur; None if an index
    reads an array itself. Kept per node: a model's obligations share their hypotheses."""
    if not n.args:
        return {}
    got = _READS.get(n)
    if got is None:
        got = _READS.put(n, _find_reads(n))
    return None if got is _NESTED else got


def _find_reads(n: Node) -> dict[str, Node] | str:
    if n.op == "select":
        if n.args[0].op != "var" or any(_has(i, "select") for i in n.args[1:]):
            return _NESTED
        return {read_name(n): n}
    out: dict[str, Node] = {}
    for a in n.args:
        got = _reads(a)
        if got is None:
            return _NESTED
        for name, read in got.items():
            out.setdefault(name, read)
    return out


def lower(formula: Node, reads_out: dict[str, tuple] | None = None) -> Node | None:
    """Plain real/Bool/Int arithmetic equivalent in validity, or None if not applicable.
    reads_out, if given, receives symbol name -> (array name, index terms) for each read.
    Quantifiers may stay if they bind Real variables that no read's index mentions (each
    read is then one value, the same for every value of the bound variable)."""
    f = eliminate_stores(formula)
    if _has(f, "store") or not _quantifiers_keepable(f, frozenset()):
        return None
    reads = _reads(f)
    if reads is None:
        return None  # nested reads
    mapping = {k: Var(k, _lowered_sort(r.sort)) for k, r in reads.items()}
    if reads_out is not None:
        reads_out.update({k: (r.args[0].payload, r.args[1:]) for k, r in reads.items()})

    facts = []
    by_array: dict[str, list[Node]] = {}
    for r in reads.values():
        by_array.setdefault(r.args[0].payload, []).append(r)
    for group in by_array.values():
        for a, b in itertools.combinations(group, 2):
            same_index = And(*(cmp("==", _to_real_index(x), _to_real_index(y))
                               for x, y in zip(a.args[1:], b.args[1:])))
            facts.append(Implies(same_index, _eq(mapping[read_name(a)], mapping[read_name(b)])))
    lowered = _to_real_index(f)
    return Implies(And(*facts), lowered) if facts else lowered


_LOWERED = NodeMemo()


def _to_real_index(n: Node) -> Node:
    """Reads as their symbols (`read_name`, the lowered sort), index-sort symbols as reals."""
    if n.op == "var" and not n.sort.is_array and n.sort not in (REAL, INT, BOOL):
        return Var(n.payload, REAL)
    if n.op == "select":
        return Var(read_name(n), _lowered_sort(n.sort))
    if not n.args:
        return n
    got = _LOWERED.get(n)
    if got is None:
        got = _LOWERED.put(n, rebuild(n, tuple([_to_real_index(a) for a in n.args])))
    return got
