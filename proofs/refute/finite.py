"""Searching runs over a concrete finite family (refutation only).

A bounded run that unrolls a `foreach` d times visits at most d elements, so small
families suffice to find violations. For an index sort with m elements b1..bm:

  ∀j φ(j)  becomes  φ(b1) ∧ ... ∧ φ(bm),   ∃ likewise with ∨,
  a = b for families over the sort becomes pointwise equality,
  every index symbol is one of b1..bm,

after which `lowering.lower` gives plain real arithmetic for nlsat. A model maps back to
a finite universe {b1..bm} with families as finite tables, on which the *original* claim
is then evaluated exactly; only then is the run trusted.
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from certiloop.models.lang.terms import (
    BOOL,
    And,
    Node,
    Or,
    Var,
    cmp,
    const,
    free_vars,
    rebuild,
    substitute,
)
from certiloop.proofs.core.lowering import lower
from certiloop.proofs.core.solver import ArrayValue


class _Unsupported(Exception):
    pass


def element(sort_name: str, k: int) -> Node:
    return Var(f"{sort_name}!{k}", _sort_named(sort_name))


def _sort_named(name: str):
    from certiloop.models.lang.terms import Sort

    return Sort(name)


def _expand(n: Node, sort_name: str, m: int) -> Node:
    if n.op in ("forall", "exists"):
        body = _expand(n.args[0], sort_name, m)
        ours = [v for v in n.payload if v.sort.name == sort_name and not v.sort.is_array]
        rest = [v for v in n.payload if v not in ours]
        if rest:
            raise _Unsupported(f"quantifier over another sort in `{n}`")
        cases = []
        for combo in _combos(len(ours), m):
            env = {v.payload: element(sort_name, k) for v, k in zip(ours, combo)}
            cases.append(substitute(body, env))
        return And(*cases) if n.op == "forall" else Or(*cases)
    if n.op == "cmp" and n.payload == "==" and n.args[0].sort.is_array:
        a, b = n.args
        if a.sort.domain == (_sort_named(sort_name),):
            pts = []
            for k in range(1, m + 1):
                x, y = a[element(sort_name, k)], b[element(sort_name, k)]
                pts.append(cmp("==", x, y) if x.sort != BOOL else And(x >> y, y >> x))
            return And(*pts)
    if n.op == "iff" and n.args[0].sort == BOOL:
        return rebuild(n, tuple(_expand(a, sort_name, m) for a in n.args))
    if not n.args or n.sort != BOOL:
        return n
    return rebuild(n, tuple(_expand(a, sort_name, m) for a in n.args))


def _combos(arity: int, m: int):
    import itertools

    return itertools.product(range(1, m + 1), repeat=arity)


def over_family(claim: Node, sort_name: str, m: int) -> tuple[Node, dict[str, tuple]] | None:
    """The claim over the family {b1..bm}, lowered to plain arithmetic, and the table of
    array reads (symbol name -> (array, indices)) needed to map a model back."""
    try:
        expanded = _expand(claim, sort_name, m)
    except _Unsupported:
        return None
    index_syms = [v for v in free_vars(expanded).values()
                  if v.sort.name == sort_name and not v.sort.is_array and "!" not in v.payload]
    members = [Or(*(cmp("==", s, element(sort_name, k)) for k in range(1, m + 1))) for s in index_syms]
    if expanded.op == "implies":
        expanded = rebuild(expanded, (And(*members, expanded.args[0]), expanded.args[1]))
    else:
        expanded = And(*members) >> expanded
    reads: dict[str, tuple] = {}
    lowered = lower(expanded, reads)
    if lowered is None:
        return None
    numbering = {element(sort_name, k).payload: const(k) for k in range(1, m + 1)}
    return substitute(lowered, numbering), reads


def model_back(model: dict[str, Any], reads: dict[str, tuple], claim: Node, sort_name: str,
               m: int) -> dict[str, Any]:
    """The solver's plain values as a state over the finite universe {b1..bm}."""
    names = [element(sort_name, k).payload for k in range(1, m + 1)]

    def as_element(x: Any) -> Any:
        k = int(x) if isinstance(x, (int, Fraction)) and Fraction(x).denominator == 1 else None
        return names[k - 1] if k is not None and 1 <= k <= m else x

    state: dict[str, Any] = {f"#universe:{sort_name}": names}
    symbols = free_vars(claim)
    for name, sym in symbols.items():
        if sym.sort.is_array:
            continue
        if name in model:
            state[name] = as_element(model[name]) if sym.sort.name == sort_name else model[name]
    for read, (array, indices) in reads.items():
        value = model.get(read)
        if value is None:
            continue
        key = tuple(n.payload if n.op == "var" and n.payload in names else as_element(model.get(n.payload, n))
                    for n in indices)
        table = state.setdefault(array, ArrayValue({}, _default(symbols.get(array))))
        ranged = symbols.get(array)
        index_valued = ranged is not None and getattr(ranged.sort.range, "name", None) == sort_name
        table.entries[key] = as_element(value) if index_valued else value
    for name, sym in symbols.items():
        if sym.sort.is_array and name not in state:
            state[name] = ArrayValue({}, _default(sym))
    return state


def _default(sym: Node | None) -> Any:
    if sym is None or sym.sort.range is None:
        return Fraction(0)
    return False if sym.sort.range == BOOL else Fraction(0)

