"""An evolution domain as a flow must keep it: `a != b` as "a - b keeps its starting sign".

Sampled on a grid, `x != 1` holds at almost every sample of `x' = 1` from 0, so a sampled
flow runs straight through x = 1, where the domain stops every true run. Along a continuous
flow, though, `a != b` holds on [0, t] exactly while a - b keeps the (nonzero) sign it had
at the start. So every `!=` atom the domain states positively becomes `sign·(a - b) > 0`,
the sign a fresh variable set from the start state (`signs`): a margin that changes sign
where the flow reaches a = b, which a grid and a root search find like any other edge.
Under an `or` this may end a flow early (the other disjunct could have carried it on): a
shorter flow is still a run, so the search loses runs at worst, never invents one.
"""

from __future__ import annotations

from typing import Any, Callable

from certiloop.models.lang.terms import TRUE, And, Node, Or, Var

SIGN = "sign@along"  # the fresh variables' prefix ("@": never part of a shown state)


def signed_domain(domain: Node) -> tuple[Node, list[tuple[str, Node]]]:
    """The domain with each positive numeric `a != b` as `sign_k * (a - b) > 0`, and the
    (sign variable, a - b) pairs."""
    pairs: list[tuple[str, Node]] = []

    def walk(n: Node) -> Node:
        if n.op == "cmp" and n.payload == "!=" and n.args[0].sort.is_numeric:
            name = f"{SIGN}{len(pairs)}"
            difference = n.args[0] - n.args[1]
            pairs.append((name, difference))
            return Var(name) * difference > 0
        if n.op == "and":
            return And(*(walk(a) for a in n.args))
        if n.op == "or":
            return Or(*(walk(a) for a in n.args))
        return n  # under a negation or an implication: left as written

    return walk(domain), pairs


def sign_kept_parts(domain: Node) -> list[Node]:
    """[the domain without its top-level numeric `a != b` conjuncts, then each such a - b]
    (empty if it has none). The exact replay decides `a != b` all along a flow as "a - b > 0
    all along or a - b < 0 all along", which a polynomial's continuity makes the same."""
    conj = domain.args if domain.op == "and" else (domain,)
    differences = [a.args[0] - a.args[1] for a in conj
                   if a.op == "cmp" and a.payload == "!=" and a.args[0].sort.is_numeric]
    if not differences:
        return []
    rest = [a for a in conj if not (a.op == "cmp" and a.payload == "!=" and a.args[0].sort.is_numeric)]
    return [And(*rest) if rest else TRUE, *differences]


def keeps_sign(difference: Node, solution: dict[str, Node], tau: Node, s: Node) -> Node:
    """d(x(s)) != 0 for all s in [0, τ], exactly where d is polynomial in s."""
    from certiloop.proofs.core.odes import keeps_sign_along

    return keeps_sign_along(difference, solution, tau, s)


def signs(pairs: list[tuple[str, Callable[[Any], Any]]], start: Any) -> dict[str, Any]:
    """Each sign variable's value at the start: +1 where a - b > 0 there, else -1 (where
    a = b at the start the domain is false already, and stays so)."""
    out = {}
    for name, difference in pairs:
        d = difference(start)
        try:
            import numpy as np

            out[name] = np.where(np.asarray(d) > 0, 1.0, -1.0) if np.ndim(d) else (1.0 if d > 0 else -1.0)
        except TypeError:  # a value that does not compare (open): no flow is sampled from it
            out[name] = 1.0
    return out
