"""Subterm abstraction (a trusted weakening): rewrite atoms in terms of named abbreviations.

Given an abbreviation a == e(x) (e.g. d0 == (p - r)·n), each atom g(x) ⋈ 0 is reduced
modulo a - e(x) (a Gröbner-basis normal form with x eliminated first). Where the reduced
form no longer mentions the eliminated symbols, the atom is replaced by it, and `a` is a
fresh symbol. This is sound for ANY instances (whoever chose them): the abstracted formula
φ'(x, a) satisfies φ'(x, e(x)) ≡ φ(x), so if φ' holds for every a, φ holds. It is the
paper's projection onto d0, fn, fnp: three real numbers per boundary instead of nine
coordinates. What this module checks itself: an instance's symbol is fresh, and a
congruence fact (b1 = b2 -> a1 = a2) is only stated for two instances whose definitions
differ exactly by the index renaming.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from fractions import Fraction

from sympy import QQ
from sympy.polys.orderings import lex
from sympy.polys.rings import ring

from certiloop.models.lang.memos import NodeMemo, substitute_shared
from certiloop.models.lang.terms import (
    REAL,
    And,
    Implies,
    Node,
    Var,
    add,
    cmp,
    const,
    free_vars,
    mul,
    rebuild,
)
from certiloop.proofs.core.instantiate import has_quantifier


@dataclass(frozen=True)
class Instance:
    """An abbreviation instance: `symbol` stands for `definition`; instances of one family
    differ only in their index parameters, so equal indices mean equal values."""

    symbol: Node
    definition: Node
    family: tuple = ()
    indices: tuple = ()

    def with_definition(self, definition: Node) -> "Instance":
        return Instance(self.symbol, definition, self.family, self.indices)


def congruences(inst: list[Instance], index_term=lambda t: t) -> list[Node]:
    """(b1 = b2) -> (a1 = a2) for instances of one family at index symbols b1, b2 — only
    where a2's definition is a1's with b1 renamed to b2 (so the fact is a congruence)."""
    facts = []
    for a, b in itertools.combinations(inst, 2):
        if a.family == b.family and a.indices and [x.key for x in a.indices] != [y.key for y in b.indices]:
            if len(a.indices) != len(b.indices) or not _renamed(a, b):
                continue
            same = And(*(cmp("==", index_term(x), index_term(y)) for x, y in zip(a.indices, b.indices)))
            facts.append(Implies(same, cmp("==", a.symbol, b.symbol)))
    return facts


def _renamed(a: Instance, b: Instance) -> bool:
    if not all(x.op == "var" and y.op == "var" for x, y in zip(a.indices, b.indices)):
        return False
    swap = {x.payload: y for x, y in zip(a.indices, b.indices)}
    return substitute_shared(a.definition, swap).same(b.definition)


def fresh_instances(formula: Node, inst: list[Instance]) -> list[Instance]:
    """The instances whose symbols are fresh (a stale or reused name would not be a
    generalisation but an assumption)."""
    taken = set(free_vars(formula))
    out, names = [], set()
    for i in inst:
        if i.symbol.op != "var" or i.symbol.payload in taken or i.symbol.payload in names:
            continue
        names.add(i.symbol.payload)
        out.append(i)
    return out


def lower_term(t: Node) -> Node:
    """The same renaming of array reads and index symbols as `lowering.lower` applies."""
    from certiloop.proofs.core.lowering import read_name

    if t.op == "select":
        return Var(read_name(t), t.sort)
    if t.op == "var" and not t.sort.is_array and not t.sort.is_numeric and t.sort.name != "Bool":
        return Var(t.payload, REAL)
    if not t.args:
        return t
    return rebuild(t, tuple(lower_term(a) for a in t.args))


def abstract(formula: Node, inst: list[Instance], extra_facts: list[Node] = ()) -> Node | None:
    """The abstracted formula, or None when no atom could be rewritten. `extra_facts`
    (true whenever the abbreviations equal their definitions) become hypotheses."""
    if not inst or _binds_an_abbreviated_symbol(formula, inst):
        return None
    poly = _Polys(formula, inst)
    if poly.ring is None:
        return None
    relations: dict[int, object] = {}  # built when an atom first needs one: most atoms need none
    defined = [set(_syms(i.definition)) for i in inst]
    by_definition = {i.definition.key: i.symbol for i in inst}
    all_defined = set().union(*defined)
    # a definition can occur in an atom only if the atom has all its free symbols (no
    # quantifier binds them here): most atoms have no such definition and are not walked
    needs = [frozenset(free_vars(i.definition)) for i in inst]
    changed = [False]

    def may_occur(n: Node) -> bool:
        names = free_vars(n).keys()
        return any(need <= names for need in needs)

    def replace(n: Node) -> Node:
        hit = by_definition.get(n.key)
        if hit is not None:
            return hit
        return rebuild(n, tuple(replace(a) for a in n.args)) if n.args else n

    def rewrite(n: Node) -> Node:
        if n.op == "cmp" and n.args[0].sort.is_numeric:
            # the definitions usually occur verbatim (substituted from the same template)
            direct = replace(n) if may_occur(n) else n
            if not direct.same(n) and not (set(_syms(direct)) & all_defined):
                changed[0] = True
                return direct
            n = direct
            atom_syms = set(_syms(n))
            # only instances built from this atom's own symbols (right SSA versions, right
            # boundary): two instances with one leading monomial would derail the division.
            # Decided before the atom's polynomial is built: most atoms have none.
            mine = [k for k, syms in enumerate(defined) if syms and syms <= atom_syms]
            if not mine:
                return n
            try:
                g = poly.element(n.args[0]) - poly.element(n.args[1])
            except _NotPolynomial:
                return n
            for k in mine:
                if k not in relations:
                    relations[k] = poly.element(inst[k].symbol) - poly.element(inst[k].definition)
            rem = g.rem([relations[k] for k in mine])
            if poly.mentions(rem, set().union(*(defined[k] for k in mine))):
                return n
            changed[0] = True
            return cmp(n.payload, poly.node(rem), 0)
        if n.op in ("and", "or", "not", "implies", "iff", "forall", "exists"):
            return rebuild(n, tuple(rewrite(a) for a in n.args))
        return n

    out = rewrite(formula)
    if not changed[0]:
        return None
    return Implies(And(*extra_facts), out) if extra_facts else out


class _NotPolynomial(Exception):
    pass


_SYMS = NodeMemo()


def _syms(n: Node) -> dict[str, Node]:
    """Atomic arithmetic subterms (symbols and array reads) by their text (remembered per
    node: the atoms of a model's hypotheses recur in each of its obligations)."""
    got = _SYMS.get(n)
    if got is None:
        got = _SYMS.put(n, _find_syms(n))
    return dict(got)


def _find_syms(n: Node) -> dict[str, Node]:
    out: dict[str, Node] = {}

    def walk(x: Node) -> None:
        if x.op in ("var", "select"):
            if x.sort.is_numeric:
                out.setdefault(_text(x), x)
            return
        for a in x.args:
            walk(a)

    walk(n)
    return out


def _text(atom: Node) -> str:
    """An atom's text: a symbol's is its name (printing it gives the same), a read's is printed."""
    return atom.payload if atom.op == "var" else str(atom)


class _Polys:
    """One polynomial ring over QQ per obligation, lex order with the symbols the
    abbreviations eliminate first, so division rewrites atoms towards the abbreviations."""

    def __init__(self, formula: Node, inst: list[Instance]) -> None:
        abbrevs = {_text(i.symbol): i.symbol for i in inst}
        defined: dict[str, Node] = {}
        for i in inst:
            defined.update(_syms(i.definition))
        others = {k: v for k, v in _syms(formula).items() if k not in defined and k not in abbrevs}
        order = sorted(defined) + sorted(others) + sorted(abbrevs)
        self.index = {name: k for k, name in enumerate(order)}
        self.atoms = {**defined, **others, **abbrevs}
        self.order = order
        if not order:
            self.ring = None
            return
        self.ring, *self.gens = ring(",".join(f"v{k}" for k in range(len(order))), QQ, lex)

    def element(self, n: Node):
        op = n.op
        if op == "const":
            return self.ring(QQ(n.payload.numerator, n.payload.denominator))
        if op in ("var", "select"):
            k = self.index.get(_text(n))
            if k is None or not n.sort.is_numeric:
                raise _NotPolynomial(str(n))
            return self.gens[k]
        if op == "+":
            out = self.ring(0)
            for a in n.args:
                out += self.element(a)
            return out
        if op == "*":
            out = self.ring(1)
            for a in n.args:
                out *= self.element(a)
            return out
        if op == "neg":
            return -self.element(n.args[0])
        if op == "^":
            return self.element(n.args[0]) ** n.payload
        if op == "/" and n.args[1].op == "const":
            return self.element(n.args[0]) * QQ(n.args[1].payload.denominator, n.args[1].payload.numerator)
        raise _NotPolynomial(str(n))

    def mentions(self, p, names: set[str]) -> bool:
        ks = [self.index[n] for n in names]
        return any(monom[k] for monom in p.monoms() for k in ks)

    def node(self, p) -> Node:
        terms = []
        for monom, coeff in p.terms():
            c = Fraction(int(coeff.numerator), int(coeff.denominator))
            factors = [] if c == 1 else [const(c)]
            for k, power in enumerate(monom):
                if power:
                    atom = self.atoms[self.order[k]]
                    factors.append(atom if power == 1 else atom**power)
            terms.append(mul(*factors) if len(factors) > 1 else factors[0] if factors else const(1))
        return add(*terms) if terms else const(0)


def _binds_an_abbreviated_symbol(n: Node, inst: list[Instance]) -> bool:
    """A quantifier over a symbol a definition mentions, or over an abbreviation's symbol:
    the projection would move it out of its scope. (Quantifiers over other symbols are
    rewritten inside, atom by atom.)"""
    watched = {name for i in inst for name in free_vars(i.definition)} | {i.symbol.payload for i in inst}
    return _binds(n, watched)


def _binds(n: Node, watched: set[str]) -> bool:
    if not has_quantifier(n):
        return False
    if n.op in ("forall", "exists") and any(v.payload in watched for v in n.payload):
        return True
    return any(_binds(a, watched) for a in n.args)
