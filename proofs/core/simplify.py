"""Small equivalence-preserving rewrites that keep solver formulas small (trusted: each rule
is a propositional or arithmetic identity, checked syntactically by structural keys).

  c1 ⋈ c2 for constants           -> true / false (exact rational comparison)
  A ∨ ... ∨ ¬A-complement          -> true   (a ≥ b with a < b, a ≤ b with a > b, a = b with a ≠ b)
  P -> (P ∧ R)                     -> P -> R
  P -> P                           -> true
"""

from __future__ import annotations

from certiloop.models.lang.terms import FALSE, TRUE, And, Implies, Node, Or, rebuild

_COMPLEMENT = {">=": "<", "<": ">=", "<=": ">", ">": "<=", "==": "!=", "!=": "=="}


def simplify(f: Node) -> Node:
    if f.sort.name != "Bool" or not f.args:
        return f
    args = tuple(simplify(a) for a in f.args) if f.op not in ("cmp",) else f.args
    if f.op == "cmp":
        a, b = f.args
        if a.op == "const" and b.op == "const":
            return TRUE if _holds(f.payload, a.payload, b.payload) else FALSE
        return f
    if f.op == "or":
        keys = {_atom_key(a) for a in args if a.op == "cmp"}
        for a in args:
            if a.op == "cmp" and _complement_key(a) in keys:
                return TRUE
        return Or(*args)
    if f.op == "implies":
        p, r = args
        if p.same(r):
            return TRUE
        if r.op == "and":
            parts = tuple(x for x in r.args if not x.same(p))
            if len(parts) < len(r.args):
                return Implies(p, And(*parts))
        return Implies(p, r)
    if f.op == "and":
        return And(*args)
    return rebuild(f, args)


def _holds(op: str, a, b) -> bool:
    return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "==": a == b, "!=": a != b}[op]


def _atom_key(a: Node) -> tuple:
    return (a.payload, a.args[0].key, a.args[1].key)


def _complement_key(a: Node) -> tuple:
    return (_COMPLEMENT[a.payload], a.args[0].key, a.args[1].key)
