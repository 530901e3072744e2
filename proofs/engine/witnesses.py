"""Choosing witness terms for the guarantee's `\\exists v` around a loop (search, outside the
trusted core: the core proves the body with v := the term, and any term is sound, so a bad
choice only fails to prove).

Stability claims read `\\forall eps (eps > 0 -> \\exists del (del > 0 & \\forall x (|x| < del
-> [sys*] |x| < eps)))`; the witnesses tried are the variables the path to the quantifier
binds with `\\forall`, latest first, then their halves and tenths (a smaller ball of starts
is easier to keep inside), then 1.

An equilibrium (`\\exists f (x = f -> [{x' = r + x^2}] x = f)`): where the body compares a
flow's variable x with v and x' = p(x) moves x alone, v := s for a ghost s with p(s) = 0
(Theorem.ghosts: the core proves that one exists, here from r <= 0, before it assumes it).
"""

from __future__ import annotations

from fractions import Fraction
from itertools import islice, product

from certiloop.models.lang.terms import REAL, Node, Real, cmp, const, div, free_vars, substitute
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.vcgen import executed
from certiloop.proofs.engine.odeplan import odes_of

Option = tuple[tuple[tuple[str, Node], ...], tuple[tuple[str, Node], ...]]  # (witnesses, ghosts)

MAX_OPTIONS = 4  # whole proof attempts per theorem: each plans its ODEs again
# a proof with more obligations than this is not attempted again with other witnesses: a
# hybrid automaton of six modes (Automatic cruise controller, 1,300) takes 30 s per attempt
WITNESS_RETRY_OBLIGATIONS = 300


def open_quantifiers(f: Node, scope: tuple[Node, ...] = ()) -> list[tuple[Node, tuple[Node, ...]]]:
    """(variable, the ∀-variables around it) for each ∃ the core takes apart (one whose body
    holds a loop), along the positive paths it follows (nesting.py)."""
    if not executed(f):
        return []
    if f.op == "exists":
        return [(v, scope) for v in f.payload] + open_quantifiers(f.args[0], scope)
    if f.op == "forall":
        return open_quantifiers(f.args[0], scope + tuple(f.payload))
    if f.op == "implies":
        return open_quantifiers(f.args[1], scope)
    if f.op in ("and", "or"):
        return [q for a in f.args for q in open_quantifiers(a, scope)]
    if f.op == "box":
        return open_quantifiers(f.args[0], scope)
    return []


def _terms(v: Node, scope: tuple[Node, ...]) -> list[Node]:
    same = [u for u in reversed(scope) if u.sort == v.sort and u.payload != v.payload]
    out = same + [div(u, 2) for u in same] + [div(u, 10) for u in same]
    return out + ([const(Fraction(1))] if v.sort == REAL else [])


def witness_options(theorem: Theorem) -> list[Option]:
    """(witnesses, ghosts) to try, at most MAX_OPTIONS terms and the equilibria, for the ∃s
    the theorem gives no witness for."""
    given = {v for v, _ in theorem.witnesses}
    needed: dict[str, list[Node]] = {}
    for v, scope in open_quantifiers(theorem.guarantee):
        if v.payload not in given and v.payload not in needed:
            needed[v.payload] = _terms(v, scope)
    if not needed or not all(needed.values()):
        return []
    names = list(needed)
    combos = islice(product(*(needed[n] for n in names)), MAX_OPTIONS)
    options = [(theorem.witnesses + tuple(zip(names, combo)), theorem.ghosts) for combo in combos]
    if len(names) == 1:
        options += _equilibria(theorem, names[0])
    return options


def _equilibria(theorem: Theorem, v: str) -> list[Option]:
    """v := a ghost s with p(s) = 0, for each flow variable x compared with v (`x = v`) in
    the guarantee whose rate p moves x alone."""
    flows = [ode for f in _modalities(theorem.guarantee) for ode in odes_of(f.payload)]
    compared = {a.payload for c in _comparisons(theorem.guarantee) if c.payload == "=="
                for a, b in (c.args, c.args[::-1]) if a.op == "var" and b.op == "var" and b.payload == v}
    options: list[Option] = []
    for flow in flows:
        for x, rate in flow.eqs:
            others = {u.payload for u in flow.variables} - {x.payload}
            if x.payload not in compared or set(free_vars(rate)) & others or x.payload not in free_vars(rate):
                continue
            name = theorem.unused_name(f"{v}_eq")
            fact = cmp("==", substitute(rate, {x.payload: Real(name)}), 0)
            options.append((theorem.witnesses + ((v, Real(name)),), theorem.ghosts + ((name, fact),)))
    return options


def _modalities(f: Node) -> list[Node]:
    here = [f] if f.op in ("box", "diamond") else []
    return here + [m for a in f.args for m in _modalities(a)]


def _comparisons(f: Node) -> list[Node]:
    return ([f] if f.op == "cmp" else []) + [c for a in f.args for c in _comparisons(a)]
