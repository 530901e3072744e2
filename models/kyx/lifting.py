"""Square roots in an ODE's right-hand side, lifted to a variable of the flow; abs, min and max
there, by a constant sign.

KeYmaera X writes Kepler's problem as `{x' = v, v' = -x/(x^2+y^2)^(3/2), ... & x != 0 | y != 0}`.
certiloop's terms have no square root, so each root r = sqrt(e) in a right-hand side becomes a
fresh variable s of an equivalent program:

    s := *; ?(s > 0 & s*s = e);  {x' = f(x, s), s' = (de/dt)/(2 s) & Q & s > 0 & s*s = e}

Why a proof of the lifted box is a proof of the original. Take a run x(t) of the original
flow. If Q implies e > 0 (the side condition `Q -> e > 0`, proved like any obligation, for all
values of all symbols), then e(x(t)) > 0 all along the run, so s(t) = sqrt(e(x(t))) is
differentiable, has exactly the derivative written for s', and (x, s) is a run of the lifted
flow that stays inside its domain and starts where the test puts it. So every run of the
original is (the projection of) a run of the lifted program, and a postcondition that holds
after every lifted run holds after every original one. Conversely every lifted run keeps
s = sqrt(e) (the domain says s > 0 and s*s = e), so it projects to a run of the original: a
diamond needs no side condition, and a state the lifted program reaches is a real one, so a
counterexample found on it is real.

A root of a term the flow does not move (its symbols are not the flow's variables) is the
constant s with s >= 0 & s*s = e, with no equation and no side condition.

Right after such a flow (a box or diamond whose program ends with it) and along it (its
annotations), the same root written again means s: the reader reads it as s there
(`Builder.root`), which keeps an invariant such as the energy of Kepler's problem in the form
whose derivative is a polynomial identity.

abs, min and max in a right-hand side (`signed`, built by `Builder._lifted_case`). A run may
cross from one case into the other, so the flow cannot be split into its cases. Instead
|a| = g*a for a constant sign g chosen before the flow,

    {g := 1; ?a > 0 ++ g := -1; ?a < 0};  {x' = f(x, g*a) & Q & g*a > 0}

(min(a, b) = (a + b - |a - b|)/2, max(a, b) = (a + b + |a - b|)/2), with the side condition
`Q -> a != 0`. Why: along a run of the original flow that stays in Q, a is continuous and never
0, so it keeps the sign it starts with, g*a = |a| all along, and the run is a run of the signed
flow inside its domain. Conversely the domain keeps g*a > 0, so g*a = |a| along every signed
run, which is a run of the original: no side condition is needed for a diamond or a
counterexample. The right-hand side stays polynomial (it may still be solved, and a
counterexample confirmed by interval enclosures). Where the flow may reach a = 0 the side
condition fails and the claim is unknown. If the flow does not move a, the sign is a constant
chosen with `a >= 0` and needs neither pin nor side condition.
"""

from __future__ import annotations

from certiloop.models.lang.terms import Node, const, div, free_vars


class NotDifferentiable(ValueError):
    """The term holds an operation whose derivative is not written here."""


def rate(e: Node, rates: dict[str, Node]) -> Node:
    """de/dt where each symbol x changes at rates[x] (the others are constant)."""
    op = e.op
    if op == "const":
        return const(0)
    if op == "var":
        return rates.get(e.payload, const(0))
    if op == "+":
        return _sum([rate(a, rates) for a in e.args])
    if op == "neg":
        return -rate(e.args[0], rates)
    if op == "*":
        terms = []
        for i, a in enumerate(e.args):
            d = rate(a, rates)
            if not (d.op == "const" and d.payload == 0):
                terms.append(_product([d] + [b for j, b in enumerate(e.args) if j != i]))
        return _sum(terms)
    if op == "/":
        a, b = e.args
        return div(rate(a, rates) * b - a * rate(b, rates), b ** 2)
    if op == "^":
        n = e.payload
        return const(0) if n == 0 else n * e.args[0] ** (n - 1) * rate(e.args[0], rates)
    raise NotDifferentiable(f"`{e}`")


def moves(e: Node, flow: frozenset[str]) -> bool:
    """Does the flow change e (does e mention one of its variables)?"""
    return bool(set(free_vars(e)) & flow)


def _sum(items: list[Node]) -> Node:
    if not items:
        return const(0)
    out = items[0]
    for x in items[1:]:
        out = out + x
    return out


def _product(items: list[Node]) -> Node:
    out = items[0]
    for x in items[1:]:
        out = out * x
    return out
