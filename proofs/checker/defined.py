"""Where a formula is free of division by zero: the well-definedness side of each step.

`defined(f)` holds exactly in the states where evaluating f never divides by 0, connectives
read left to right (in `b != 0 & a/b > 1` the division is only evaluated where b != 0), a
quantifier's body for every value of its variables; the theorem's assumptions also under
their conjuncts defined everywhere (`settled_conjuncts`). Once every division is shown to have a
nonzero denominator where it is evaluated, z3's reading of x/0 cannot matter.
"""

from __future__ import annotations

from certiloop.models.lang.terms import TRUE, And, ForAll, Implies, Node, Not, cmp


def risky(t: Node) -> bool:
    """A division whose denominator is not a nonzero number (e/2 is always defined)."""
    return t.op == "/" and not (t.args[1].op == "const" and t.args[1].payload != 0)


def divides(f: Node) -> bool:
    return risky(f) or any(divides(a) for a in f.args)


def denominators(f: Node) -> list[Node]:
    """The risky denominators of f, each once, in order of first occurrence (outside in)."""
    out: list[Node] = []

    def walk(n: Node) -> None:
        if risky(n) and not any(d.same(n.args[1]) for d in out):
            out.append(n.args[1])
        for a in n.args:
            walk(a)
    walk(f)
    return out


def settled_conjuncts(f: Node) -> tuple[Node, ...]:
    """The conjuncts of f that are defined everywhere (no division, no modality): where one is
    false f is false, so the others need to be defined only where these all hold."""
    return tuple(a for a in (f.args if f.op == "and" else ()) if not divides(a) and not modal(a))


def modal(f: Node) -> bool:
    return f.op in ("box", "diamond") or any(modal(a) for a in f.args)


def defined(f: Node) -> Node:
    if f.op in ("true", "false"):
        return TRUE
    if f.op in ("forall", "exists"):
        body = defined(f.args[0])
        return TRUE if body.op == "true" else ForAll(f.payload, body)
    if f.op == "and":
        return And(*(Implies(And(*f.args[:k]), defined(a)) for k, a in enumerate(f.args)))
    if f.op == "or":
        return And(*(Implies(And(*(Not(e) for e in f.args[:k])), defined(a)) for k, a in enumerate(f.args)))
    if f.op == "implies":
        return And(defined(f.args[0]), Implies(f.args[0], defined(f.args[1])))
    if f.op in ("not", "iff"):
        return And(*(defined(a) for a in f.args))
    parts = [defined(a) for a in f.args]  # comparisons and terms: every part is evaluated
    if risky(f):
        parts.append(cmp("!=", f.args[1], 0))
    return And(*parts)
