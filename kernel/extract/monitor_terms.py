"""What the generated monitors share: the one error they raise (MonitorError, a one-line
ExtractError), fresh names, the model's symbols, how a value of a sort is converted on entry,
and a term or a quantifier-free formula as Python over a dict of values (`term`)."""

from __future__ import annotations

from certiloop.kernel.extract.errors import ExtractError, brief
from certiloop.models.lang.terms import BOOL, INT, REAL, Node, free_vars
from certiloop.models.lang.theorem import Theorem


class MonitorError(ExtractError):
    """No monitor can be generated for this model's shape."""


def fresh(taken: set[str], base: str) -> str:
    name, n = base, 2
    while name in taken:
        name, n = f"{base}{n}", n + 1
    taken.add(name)
    return name


def theorem_symbols(theorem: Theorem) -> dict[str, Node]:
    return {**free_vars(theorem.assumptions), **theorem.program.symbols(), **free_vars(theorem.guarantee)}


def numpy_conversion(sort) -> str:
    if sort == REAL:
        return "np.float64"
    if sort == INT:
        return "int"
    if sort == BOOL:
        return "bool"
    return "np.asarray"


def term(n: Node, env: str, kit: str | None = None) -> str:
    """A real term or a quantifier-free formula as Python over the dict `env`; with `kit` (the
    number kit of certiloop.kernel.decide), constants are exact and divisions the kit's."""
    op = n.op
    if op == "const":
        if kit is not None:
            v = n.payload  # an exact rational, whatever float it is nearest to
            return f"{kit}.c({v.numerator})" if v.denominator == 1 else \
                f"{kit}.c({v.numerator}, {v.denominator})"
        return repr(float(n.payload))
    if op == "true":
        return "True"
    if op == "false":
        return "False"
    if op == "var":
        return f"{env}[{n.payload!r}]"
    a = [term(x, env, kit) for x in n.args]
    if op == "+":
        return "(" + " + ".join(a) + ")"
    if op == "*":
        return "(" + " * ".join(a) + ")"
    if op == "neg":
        return f"(-{a[0]})"
    if op == "/":
        return f"{kit}.div({a[0]}, {a[1]})" if kit is not None else f"_div({a[0]}, {a[1]})"
    if op == "^":
        return f"({a[0]} ** {n.payload})"
    if op == "cmp":
        return f"({a[0]} {n.payload} {a[1]})"
    if op == "and":
        return "(" + " and ".join(a) + ")" if a else "True"
    if op == "or":
        return "(" + " or ".join(a) + ")" if a else "False"
    if op == "not":
        return f"(not {a[0]})"
    if op == "implies":
        return f"((not {a[0]}) or {a[1]})"
    raise MonitorError(f"cannot monitor `{brief(n)}`: not an arithmetic term or a quantifier-free formula")
