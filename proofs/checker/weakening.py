"""A leaf proved through a weakening (format v2): a formula W whose validity implies the leaf's,
built here from the leaf and the recorded choices of the prover's instantiation, lowering and
abstraction (README.md, "Weakenings"): instances substituted into the leaf's own hypotheses
after its goal is skolemised here, the lowering recomputed, each rewritten atom the same
comparison of an identical polynomial once the abbreviations are replaced by their
definitions. Index values occur in W only in equalities, so W valid over the reals is W valid
over any index sort. The recorded SMT-LIB text must be W's.
"""

from __future__ import annotations

import itertools

import sympy

from certiloop.models.lang import terms as lang
from certiloop.models.lang.terms import REAL, And, Implies, Node, Var, cmp, free_vars, rebuild, substitute
from certiloop.proofs.arith.smtlib import script
from certiloop.proofs.checker import keys
from certiloop.proofs.checker.derive import Rejected
from certiloop.proofs.checker.keys import Malformed, fields
from certiloop.proofs.checker.ode_facts import NotCheckable

FIELDS = {"instances", "lowered", "abbreviations", "facts", "atoms", "smtlib"}
BINDERS = ("forall", "exists")
CONNECTIVES = ("and", "or", "not", "implies", "iff", *BINDERS)


def weakened(leaf: Node, record: object, where: str) -> Node:
    """The weaker formula W the record describes, built here and checked to imply `leaf`."""
    rec = fields(record, FIELDS, f"{where}: the weakening")
    f = leaf if rec["instances"] is None else instantiated(leaf, rec["instances"])
    if not isinstance(rec["lowered"], bool):
        raise Malformed(f"{where}: `lowered` must be true or false")
    f, undo = lowered(f) if rec["lowered"] else (f, {})
    sigma, atoms = _pairs(rec["abbreviations"], str, where), _pairs(rec["atoms"], int, where)
    facts = [keys.from_text(t, want_formula=True) for t in _list(rec["facts"], where)]
    watched = set(sigma).union(*(free_vars(d) for d in sigma.values()))
    seen = [0]
    w = Implies(And(*facts), _rewritten(f, {k: keys.from_text(a, True) for k, a in atoms.items()}, sigma,
                                        watched, seen, True))
    if any(not 0 <= k < seen[0] for k in atoms):
        raise Rejected(f"{where}: a rewritten atom's index is not one of the formula's {seen[0]} atoms")
    taken, used = free_vars(f), free_vars(w)
    index = {n for n, t in undo.items() if _index_sort(t.sort)}
    for name, d in sigma.items():
        if name in taken or name not in used or used[name].sort != d.sort or not d.sort.is_numeric \
                or set(free_vars(d)) & index:
            raise Rejected(f"{where}: the abbreviation {name} is not a fresh symbol of the weaker formula "
                           "standing for a term of its sort")
    if not _only_compared(w, index, undo):
        raise Rejected(f"{where}: a symbol standing for an index value is used in arithmetic")
    if not all(_congruence(substitute(substitute(fact, sigma), undo)) for fact in facts):
        raise Rejected(f"{where}: a congruence of the abstraction is not one")
    if rec["smtlib"] != script(w):  # every choice recorded is seen in the formula decided
        raise Rejected(f"{where}: the recorded weaker formula is not the one these steps give")
    return w


def _pairs(x: object, kind: type, where: str) -> dict:
    """[[key, key text], ...] as a dict (abbreviations: symbol -> its definition's node)."""
    out: dict = {}
    for entry in _list(x, where):
        if not (isinstance(entry, list) and len(entry) == 2 and type(entry[0]) is kind):
            raise Malformed(f"{where}: expected [{kind.__name__}, key text] pairs, got {entry!r:.60}")
        if entry[0] in out:
            raise Rejected(f"{where}: {entry[0]} is given twice")
        out[entry[0]] = keys.from_text(entry[1]) if kind is str else entry[1]
    return out


def _list(x: object, where: str) -> list:
    if not isinstance(x, list):
        raise Malformed(f"{where}: expected a list in the weakening, got {type(x).__name__}")
    return x


# --------------------------------------------------------------------------- instantiate


def instantiated(f: Node, entries: object) -> Node:
    made: list[Node] = []
    hyps, goal = _split(f, made)
    if set(free_vars(f)) & {c.payload for c in made}:
        raise Rejected("a skolem constant of the goal is not fresh")
    known, out = {**free_vars(f), **{c.payload: c for c in made}}, []
    for e in _list(entries, "instances"):
        k, terms = (e, None) if type(e) is int else e if isinstance(e, list) and len(e) == 2 else (None, 0)
        if type(k) is not int or not 0 <= k < len(hyps) or not (terms is None or isinstance(terms, list)) \
                or isinstance(e, list) and terms is None:
            raise Malformed(f"instances: bad entry {e!r:.60} ({len(hyps)} hypotheses)")
        terms = None if terms is None else [keys.from_text(t) for t in terms]
        if any(known.get(n, v).sort != v.sort for t in terms or () for n, v in free_vars(t).items()):
            raise Rejected(f"instances: a term's symbol has another sort in the leaf ({e!r:.60})")
        out.append(hyps[k] if terms is None else _instance(hyps[k], terms))
    return Implies(And(*out), goal)


def _split(goal: Node, made: list[Node]) -> tuple[list[Node], Node]:
    """(hypotheses, goal): ∀ skolemised (x@skN, N counting), implications' left sides taken."""
    if goal.op == "forall":
        env = {v.payload: Var(f"{v.payload.split('@')[0]}@sk{len(made) + n}", v.sort)
               for n, v in enumerate(goal.payload, 1)}
        made.extend(env.values())
        return _split(substitute(goal.args[0], env), made)
    if goal.op == "implies":
        hyps, rest = _split(goal.args[1], made)
        return [*(goal.args[0].args if goal.args[0].op == "and" else (goal.args[0],)), *hyps], rest
    if goal.op == "and":
        return [], And(*(Implies(And(*h), g) for h, g in (_split(part, made) for part in goal.args)))
    return [], goal


def _instance(h: Node, terms: list[Node]) -> Node:
    """∀x (A -> ∀y B) at terms (t, u): A(t) -> B(t, u), each variable taking the next term."""
    if h.op == "forall" and len(terms) >= len(h.payload):
        vs, body = h.payload, h.args[0]
        if any(t.sort != v.sort or v.payload not in free_vars(body) for v, t in zip(vs, terms)):
            raise Rejected(f"an instance of `{h}` is not of its variables' sorts, or one is unused")
        return _instance(substitute(body, {v.payload: t for v, t in zip(vs, terms)}), terms[len(vs):])
    if h.op == "implies" and terms:
        return Implies(h.args[0], _instance(h.args[1], terms))
    if terms:
        raise Rejected(f"more instance terms than quantified variables in `{h}`")
    return h


# --------------------------------------------------------------------------- lower


def _index_sort(s) -> bool:
    return not s.is_array and s not in (REAL, lang.BOOL) and not s.is_numeric


def _eq(a: Node, b: Node) -> Node:
    return lang.Iff(a, b) if a.sort == lang.BOOL else cmp("==", a, b)


def read_name(read: Node) -> str:
    return f"{read.args[0].payload}[{','.join(str(i) for i in read.args[1:])}]"


def lowered(f: Node) -> tuple[Node, dict[str, Node]]:
    """F2 for F1, and each symbol lowering made (read symbol, index symbol) -> what it stands for."""
    f = _no_stores(f)
    reads: dict[str, Node] = {}

    def collect(n: Node, bound: frozenset) -> None:
        if n.op in BINDERS:
            if any(v.sort != REAL for v in n.payload):
                raise NotCheckable("lowering under a quantifier over a non-real")
            bound = bound | {v.payload for v in n.payload}
        if n.op == "store" or n.op == "select" and (n.args[0].op != "var" or any(
                _has_read(i) or set(free_vars(i)) & bound for i in n.args[1:])):
            raise NotCheckable(f"lowering `{n}`")
        if n.op == "select" and reads.setdefault(read_name(n), n).key != n.key:
            raise NotCheckable(f"two reads named {read_name(n)}")
        for a in n.args:
            collect(a, bound)

    collect(f, frozenset())
    by_array: dict[str, list[Node]] = {}
    for r in reads.values():
        by_array.setdefault(r.args[0].payload, []).append(r)
    ack = [Implies(And(*(cmp("==", _real(x), _real(y)) for x, y in zip(a.args[1:], b.args[1:]))),
                   _eq(_real(a), _real(b)))
           for group in by_array.values() for a, b in itertools.combinations(group, 2)]
    undo = {n: v for n, v in free_vars(f).items() if v.op == "var" and _index_sort(v.sort)}
    if set(reads) & set(free_vars(f)):
        raise Rejected("a read's symbol is already a symbol of the leaf")
    return (Implies(And(*ack), _real(f)) if ack else _real(f)), {**undo, **reads}


def _has_read(n: Node) -> bool:
    return n.op == "select" or any(_has_read(a) for a in n.args)


def _real(n: Node) -> Node:
    """Reads as symbols, index symbols as reals."""
    if n.op == "var" and _index_sort(n.sort):
        return Var(n.payload, REAL)
    if n.op == "select":
        return Var(read_name(n), REAL if _index_sort(n.sort) else n.sort)
    return rebuild(n, tuple(_real(a) for a in n.args)) if n.args else n


def _no_stores(f: Node) -> Node:
    """Each atom P(a{i := v}[j]) as (i = j -> P(v)) & (i != j -> P(a[j])), an equivalence."""
    if f.op in CONNECTIVES:
        return rebuild(f, tuple(_no_stores(a) for a in f.args))
    read = _read_over_write(f)
    if read is None:
        return f
    (base, *rest), reads = read.args[0].args, read.args[1:]
    writes, value = rest[:-1], rest[-1]
    if all(w.same(r) for w, r in zip(writes, reads)):
        return _no_stores(_replace(f, read, value))
    same = And(*(_eq(w, r) for w, r in zip(writes, reads)))
    other = Node("select", (base, *reads), read.sort)
    return And(Implies(same, _no_stores(_replace(f, read, value))),
               Implies(lang.Not(same), _no_stores(_replace(f, read, other))))


def _read_over_write(n: Node) -> Node | None:
    if n.op == "select" and n.args[0].op == "store":
        return n
    return next((r for a in n.args if (r := _read_over_write(a)) is not None), None)


def _replace(n: Node, old: Node, new: Node) -> Node:
    if n.same(old):
        return new
    return rebuild(n, tuple(_replace(a, old, new) for a in n.args)) if n.args else n


# --------------------------------------------------------------------------- abstract


def _rewritten(n: Node, atoms: dict[int, Node], sigma: dict[str, Node], watched: set[str], seen: list[int],
               free: bool) -> Node:
    """n with its k-th atom (in pre-order) replaced by atoms[k]: the same comparison, which is
    n's atom once the abbreviations are replaced by their definitions, or compares a polynomial
    identical to it; never under a quantifier that binds a symbol of the abbreviations."""
    if n.op in CONNECTIVES:
        free = free and not (n.op in BINDERS and watched & {v.payload for v in n.payload})
        return rebuild(n, tuple(_rewritten(a, atoms, sigma, watched, seen, free) for a in n.args))
    seen[0] += 1
    new = atoms.get(seen[0] - 1)
    if new is None:
        return n
    mine = substitute(new, sigma)
    if not (free and new.op == n.op == "cmp" and new.payload == n.payload
            and (mine.same(n) or _identity(mine, n))):
        raise Rejected(f"the rewritten atom {seen[0] - 1} is not `{n}` in terms of the abbreviations")
    return new


def _identity(a: Node, b: Node) -> bool:
    """a and b compare a - b the same polynomial with 0 (only + - * ^n and division by numbers)."""
    if not all(x.sort.is_numeric and _polynomial(x) for x in (*a.args, *b.args)):
        return False
    atoms: dict[tuple, int] = {}  # each symbol or array read: one generator of the ring
    stack = [x for c in (a, b) for x in c.args]
    while stack:
        n = stack.pop()
        if n.op in ("var", "select"):
            atoms.setdefault(n.key, len(atoms))
        else:
            stack.extend(n.args)
    # sparse polynomials built directly: no sympy expression, no expansion
    ring, *gens = sympy.polys.rings.ring([f"x{i}" for i in range(max(1, len(atoms)))], sympy.QQ)

    def poly(n: Node):
        if n.op == "const":
            return ring(sympy.QQ(n.payload.numerator, n.payload.denominator))
        if n.op in ("var", "select"):
            return gens[atoms[n.key]]
        ps = [poly(x) for x in n.args]
        if n.op == "/":  # by a nonzero number (_polynomial)
            return ps[0] * ring(sympy.QQ(n.args[1].payload.denominator, n.args[1].payload.numerator))
        if n.op in ("+", "*"):
            return sum(ps) if n.op == "+" else sympy.prod(ps)
        return -ps[0] if n.op == "neg" else ps[0] ** n.payload
    return poly(a.args[0]) - poly(a.args[1]) == poly(b.args[0]) - poly(b.args[1])


def _polynomial(n: Node) -> bool:
    if n.op == "/":
        ok = n.args[1].op == "const" and n.args[1].payload != 0
    else:
        ok = n.op in ("var", "select", "const", "+", "*", "neg") or n.op == "^" and n.payload >= 0
    return ok and all(_polynomial(a) for a in n.args)


def _only_compared(n: Node, index: set[str], undo: dict[str, Node]) -> bool:
    """The index symbols occur only in `s == t` / `s != t` between two of one index sort."""
    if n.op == "cmp" and n.payload in ("==", "!=") and all(a.op == "var" and a.payload in index
                                                           for a in n.args):
        return undo[n.args[0].payload].sort == undo[n.args[1].payload].sort
    if n.op == "var":
        return n.payload not in index
    return all(_only_compared(a, index, undo) for a in n.args)


def _congruence(c: Node) -> bool:
    """(x1 = y1 & ... -> l = r) with l, the x renamed to the y, exactly r."""
    if c.op != "implies" or c.args[1].op != "cmp" or c.args[1].payload != "==":
        return False
    eqs = c.args[0].args if c.args[0].op == "and" else (c.args[0],)
    if not all(e.op == "cmp" and e.payload == "==" and e.args[0].op == "var" for e in eqs):
        return False
    left, right = c.args[1].args
    return substitute(left, {e.args[0].payload: e.args[1] for e in eqs}).same(right)
