"""Well-definedness: where is a term or formula free of division by zero?

`defined(f)` is a formula that holds exactly in the states where evaluating f never divides
by zero. Connectives are read left to right, as a programmer reads them: in `b != 0 & a/b > 1`
the division is only evaluated where `b != 0` holds, so the formula is well-defined
everywhere. The theorem's assumptions may also rely on their conjuncts that are defined
everywhere, wherever those stand (`settled_conjuncts`: a false one makes the assumptions false
whatever the others read, and the claim then holds of that state). Quantifiers ask it for
every value of their variables: `\\forall b b*(1/b) = 1` is defined nowhere, however its body
would be read.

The obligation generator asks, at every statement, test, assertion and ODE, that what is
evaluated there is defined in that context. Once every division is known to have a nonzero
denominator where it is evaluated, the solver's own reading of x/0 (an arbitrary value)
can no longer matter, so a proof means the same with real division.
"""

from __future__ import annotations

from certiloop.models.lang.terms import (
    MODALITIES,
    QUANTIFIERS,
    TRUE,
    And,
    ForAll,
    Implies,
    Node,
    Not,
    cmp,
)


def defined_term(t: Node) -> Node:
    """Every division inside the term t has a nonzero denominator."""
    parts = [defined_term(a) for a in t.args] if t.args else []
    if _risky(t):
        parts.append(cmp("!=", t.args[1], 0))
    return And(*parts)


def _risky(t: Node) -> bool:
    """A division whose denominator is not a nonzero constant (e/2 is always defined)."""
    return t.op == "/" and not (t.args[1].op == "const" and t.args[1].payload != 0)


def defined(f: Node) -> Node:
    """The states in which the formula (or term) f can be evaluated without dividing by 0."""
    op = f.op
    if op in MODALITIES:
        raise ValueError("expand [.] and <.> before asking whether a formula is defined")
    if op in ("true", "false"):
        return TRUE
    if op in QUANTIFIERS:
        body = defined(f.args[0])
        return TRUE if body.op == "true" else ForAll(f.payload, body)
    if op == "and":
        return _left_to_right(f.args, lambda earlier: And(*earlier))
    if op == "or":
        return _left_to_right(f.args, lambda earlier: And(*(Not(e) for e in earlier)))
    if op == "implies":
        a, b = f.args
        return And(defined(a), Implies(a, defined(b)))
    if op in ("not", "iff"):
        return And(*(defined(a) for a in f.args))
    return defined_term(f)  # comparisons and terms: every part is evaluated


def settled_conjuncts(f: Node) -> tuple[Node, ...]:
    """The conjuncts of f that are defined everywhere (no division, no modality). Where one of
    them is false, f is false however its other conjuncts read, so those need to be defined
    only where these all hold: the assumptions `x + v^2/(2*B) <= m & B > 0` are meaningful
    as the literature writes them (at B = 0 they are false, not undefined)."""
    return tuple(a for a in (f.args if f.op == "and" else ()) if not has_division(a) and not _modal(a))


def _modal(f: Node) -> bool:
    return f.op in MODALITIES or any(_modal(a) for a in f.args)


def _left_to_right(args, reached) -> Node:
    """Argument k is evaluated only where `reached(args[:k])` holds."""
    return And(*(Implies(reached(args[:k]), defined(a)) for k, a in enumerate(args)))


def denominators(f: Node) -> list[Node]:
    """The denominators of f's divisions that are not nonzero constants, each once."""
    out: list[Node] = []

    def walk(n: Node) -> None:
        if _risky(n) and not any(d.same(n.args[1]) for d in out):
            out.append(n.args[1])
        for a in n.args:
            walk(a)
    walk(f)
    return out


def has_division(f: Node) -> bool:
    """Does f divide by anything but a nonzero constant?"""
    return _risky(f) or any(has_division(a) for a in f.args)
