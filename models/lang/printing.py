"""KeYmaera X-like text for terms, formulas and programs (stable: content hashes use it)."""

from __future__ import annotations

from fractions import Fraction
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the printer reads nodes and programs by their fields only: no import cycle
    from certiloop.models.lang.terms import Node

# binding strength: higher binds tighter
_PREC = {
    "iff": 1, "implies": 2, "or": 3, "and": 4, "not": 5, "forall": 5, "exists": 5,
    "box": 5, "diamond": 5, "cmp": 6, "+": 7, "neg": 9, "*": 9, "/": 9, "^": 10,
}
_CMP = {"==": "=", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">="}


def _num(f: Fraction) -> str:
    if f.denominator == 1:
        return str(f.numerator)
    return f"{f.numerator}/{f.denominator}"


def show(n: Node, outer: int = 0) -> str:
    op = n.op
    prec = _PREC.get(op, 11)
    if op == "const":
        s = _num(n.payload)
        prec = 11 if n.payload >= 0 and n.payload.denominator == 1 else 9
        if n.payload < 0:
            prec = 8
    elif op == "var":
        s = n.payload
    elif op == "true":
        s = "true"
    elif op == "false":
        s = "false"
    elif op == "select":
        s = show(n.args[0], 11) + "".join(f"[{show(i)}]" for i in n.args[1:])
    elif op == "store":
        a, *idx, v = n.args
        s = f"{show(a, 11)}{{{','.join(show(i) for i in idx)} := {show(v)}}}"
    elif op == "+":
        s = show(n.args[0], prec)
        for a in n.args[1:]:
            if a.op == "neg":
                s += " - " + show(a.args[0], prec + 1)
            elif a.op == "const" and a.payload < 0:
                s += " - " + _num(-a.payload)
            else:
                s += " + " + show(a, prec)
    elif op == "neg":
        s = "-" + show(n.args[0], 10)
    elif op == "*":
        s = "*".join(show(a, prec) for a in n.args)
    elif op == "/":
        s = f"{show(n.args[0], prec)}/{show(n.args[1], prec + 1)}"
    elif op == "^":
        s = f"{show(n.args[0], prec + 1)}^{n.payload}"
    elif op == "cmp":
        s = f"{show(n.args[0], prec + 1)} {_CMP[n.payload]} {show(n.args[1], prec + 1)}"
    elif op == "and":
        s = " & ".join(show(a, prec + 1) for a in n.args)
    elif op == "or":
        s = " | ".join(show(a, prec + 1) for a in n.args)
    elif op == "not":
        s = "!" + show(n.args[0], _PREC["cmp"] + 1)
    elif op == "implies":
        s = f"{show(n.args[0], prec + 1)} -> {show(n.args[1], prec)}"
    elif op == "iff":
        s = f"{show(n.args[0], prec + 1)} <-> {show(n.args[1], prec + 1)}"
    elif op in ("forall", "exists"):
        q = "\\forall" if op == "forall" else "\\exists"
        vs = " ".join(v.payload for v in n.payload)
        s = f"{q} {vs} {show(n.args[0], prec)}"
    elif op == "box":
        s = f"[{show_program(n.payload)}]{show(n.args[0], prec)}"
    elif op == "diamond":
        s = f"<{show_program(n.payload)}>{show(n.args[0], prec)}"
    else:  # pragma: no cover - every op is listed above
        raise AssertionError(op)
    return f"({s})" if prec < outer else s


def show_program(p, indent: int = 0) -> str:
    pad = "  " * indent
    kind = type(p).__name__
    if kind == "Assign":
        return f"{show(p.target)} := {show(p.value)};"
    if kind == "Havoc":
        return f"{show(p.target)} := *;"
    if kind == "Test":
        return f"?{show(p.cond, 6)};"
    if kind == "ODE":
        eqs = ", ".join(f"{v.payload}' = {show(f)}" for v, f in p.eqs)
        dom = "" if p.domain.op == "true" else f" & {show(p.domain)}"
        return f"{{{eqs}{dom}}}"
    if kind == "Seq":
        return ("\n" + pad).join(show_program(q, indent) for q in p.parts)
    if kind == "Choice":
        inner = "  " * (indent + 1)
        alts = [
            f"/* {lab} */\n{inner}" + show_program(q, indent + 1)
            for lab, q in zip(p.labels, p.alternatives)
        ]
        return "{ " + f"\n{pad}++ ".join(alts) + f"\n{pad}}}"
    if kind == "Loop":
        inv = "" if p.invariant is None else f" /* invariant: {show(p.invariant)} */"
        return "{\n" + pad + "  " + show_program(p.body, indent + 1) + f"\n{pad}}}*{inv}"
    raise AssertionError(type(p))
