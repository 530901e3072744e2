"""The one-point rule: quantified symbols that a formula defines by an equation are replaced by
their definitions (trusted: an exact equivalence, applied before a formula goes to z3).

    ∀x (x = e ∧ A → S)  ⟺  (A → S)[e/x]        ∃x (x = e ∧ A)  ⟺  A[e/x]       (x not in e)

A hypothesis with cases, `∀t ∀r (0 <= t ∧ r = v*t ∨ t < 0 ∧ r = -v*t → S)`, is first split
into one quantified formula per case (∀ distributes over the conjunction `(C1 → S) ∧ (C2 → S)`,
∃ over the disjunction of the cases). KeYmaera X's archives define regions this way (ACAS X's
implicit safe regions: `\\forall t \\forall ro \\forall ho (... ro = rv*t & ho = ... -> ...)`),
and z3's nonlinear quantifier procedures can stall for minutes on the defined symbols where the
same claim with one universal `t` is answered at once.
"""

from __future__ import annotations

from certiloop.models.lang.terms import REAL, And, Implies, Node, Or, free_vars, rebuild, substitute

MAX_CASES = 16  # disjuncts a quantifier body's cases may expand to; past it, left as it is


def eliminate_defined(f: Node) -> Node:
    """`f` with the one-point rule applied to every quantifier, innermost first."""
    if not f.args or f.sort.name != "Bool":
        return f
    args = tuple(eliminate_defined(a) for a in f.args)
    if f.op not in ("forall", "exists"):
        return rebuild(f, args)
    done = _quantified(f.op, f.payload, args[0])
    return Node(f.op, args, f.sort, f.payload) if done is None else done


def _quantified(op: str, bound: tuple[Node, ...], body: Node) -> Node | None:
    """The quantifier without its defined symbols, or None where it defines none. ∀ is
    distributed over a conjunction and ∃ over a disjunction first (nested quantifiers meet
    the conjunction that eliminating the inner one made)."""
    spread = "and" if op == "forall" else "or"
    if body.op == spread:
        parts = [_quantified(op, bound, part) for part in body.args]
        if all(part is None for part in parts):
            return None
        parts = [_bind(op, bound, part) if done is None else done for part, done in zip(body.args, parts)]
        return And(*parts) if op == "forall" else Or(*parts)
    if op == "forall" and body.op == "implies":
        return _forall(bound, *body.args)
    if op == "exists":
        return _exists(bound, body)
    return None


def _bind(op: str, bound: tuple[Node, ...], body: Node) -> Node:
    """The quantifier over those of `bound` that occur in `body`."""
    names = tuple(v for v in bound if v.payload in free_vars(body))
    return Node(op, (body,), body.sort, names) if names else body


def _forall(bound: tuple[Node, ...], cases: Node, conclusion: Node) -> Node | None:
    split = _cases(cases)
    if split is None or not any(_definition(case, bound) for case in split):
        return None
    parts = []
    for case in split:
        rest, names, env = _solve(case, bound)
        parts.append(_bind("forall", names, Implies(And(*rest), substitute(conclusion, env))))
    return And(*parts)


def _exists(bound: tuple[Node, ...], body: Node) -> Node | None:
    split = _cases(body)
    if split is None or not any(_definition(case, bound) for case in split):
        return None
    parts = []
    for case in split:
        rest, names, _ = _solve(case, bound)
        parts.append(_bind("exists", names, And(*rest)))
    return Or(*parts)


def _cases(f: Node) -> list[list[Node]] | None:
    """f as a disjunction of conjunctions of its other subformulas, or None past MAX_CASES."""
    if f.op == "or":
        out: list[list[Node]] = []
        for a in f.args:
            sub = _cases(a)
            if sub is None or len(out) + len(sub) > MAX_CASES:
                return None
            out.extend(sub)
        return out
    if f.op == "and":
        out = [[]]
        for a in f.args:
            sub = _cases(a)
            if sub is None or len(out) * len(sub) > MAX_CASES:
                return None
            out = [x + y for x in out for y in sub]
        return out
    return [[f]]


def _definition(case: list[Node], bound: tuple[Node, ...]) -> tuple[int, Node, Node] | None:
    """(position, x, e) of the first literal `x = e` (or `e = x`) of the case that defines a
    bound symbol x by a term e of its sort without x."""
    names = {v.payload: v for v in bound}
    for k, lit in enumerate(case):
        if lit.op != "cmp" or lit.payload != "==":
            continue
        for x, e in (lit.args, lit.args[::-1]):
            if x.op != "var" or x.payload not in names or x.payload in free_vars(e):
                continue
            if _fits(names[x.payload], e):
                return k, names[x.payload], e
    return None


def _fits(x: Node, e: Node) -> bool:
    """e ranges over x's sort (a real symbol takes any number; others only their own sort)."""
    return e.sort == x.sort or (x.sort == REAL and e.sort.is_numeric)


def _solve(case: list[Node], bound: tuple[Node, ...]) -> tuple[list[Node], tuple[Node, ...], dict]:
    """The case's other literals and the bound symbols left once each defined one is replaced
    by its definition, one at a time (each substitution reaches the later definitions too)."""
    case, left, env = list(case), tuple(bound), {}
    while (found := _definition(case, left)) is not None:
        k, x, e = found
        one = {x.payload: e}
        case = [substitute(lit, one) for j, lit in enumerate(case) if j != k]
        env = {name: substitute(t, one) for name, t in env.items()}
        env[x.payload] = e
        left = tuple(v for v in left if v.payload != x.payload)
    return case, left, env
