"""LaTeX for terms, formulas, programs and claims in differential dynamic logic notation,
for notebooks (`Theorem._repr_latex_`, `Node._repr_latex_`, `Program._repr_latex_`).

The shapes follow `printing.py` (same binding strengths); the notation is the papers':
`x := e`, `x := *`, `?Q`, `α; β`, `α ∪ β`, `α^*`, `{x' = f & Q}`, `[α]P`, `⟨α⟩P`.
Annotations (invariants, branch labels) are left out: they are not part of the claim.
"""

from __future__ import annotations

from fractions import Fraction
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # read by fields only, as printing.py: no import cycle
    from certiloop.models.lang.terms import Node

_PREC = {
    "iff": 1, "implies": 2, "or": 3, "and": 4, "not": 5, "forall": 5, "exists": 5,
    "box": 5, "diamond": 5, "cmp": 6, "+": 7, "neg": 9, "*": 9, "/": 11, "^": 10,
}
_CMP = {"==": "=", "!=": r"\neq", "<": "<", "<=": r"\leq", ">": ">", ">=": r"\geq"}
_CONNECTIVE = {"and": r"\land", "or": r"\lor"}
_PROGRAM_PREC = {"Choice": 1, "Seq": 2}  # a loop, an ODE and atomic statements bind tightest


def name(text: str) -> str:
    """A symbol: one letter as is (`x`), longer names upright-italic and escaped (`\\mathit{v\\_max}`)."""
    if len(text) == 1:
        return text
    return r"\mathit{" + text.replace("_", r"\_") + "}"


def _num(f: Fraction) -> str:
    if f.denominator == 1:
        return str(f.numerator)
    sign = "-" if f < 0 else ""
    return rf"{sign}\frac{{{abs(f.numerator)}}}{{{f.denominator}}}"


def latex(n: Node, outer: int = 0) -> str:
    """A term or formula as LaTeX math (no surrounding `$`)."""
    op = n.op
    prec = _PREC.get(op, 11)
    if op == "const":
        s = _num(n.payload)
        prec = 8 if n.payload < 0 else 11
    elif op == "var":
        s = name(n.payload)
    elif op in ("true", "false"):
        s = rf"\mathrm{{{op}}}"
    elif op == "select":
        s = latex(n.args[0], 11) + "".join(f"[{latex(i)}]" for i in n.args[1:])
    elif op == "store":
        a, *idx, v = n.args
        s = rf"{latex(a, 11)}\{{{', '.join(latex(i) for i in idx)} := {latex(v)}\}}"
    elif op == "+":
        s = latex(n.args[0], prec)
        for a in n.args[1:]:
            if a.op == "neg":
                s += " - " + latex(a.args[0], prec + 1)
            elif a.op == "const" and a.payload < 0:
                s += " - " + _num(-a.payload)
            else:
                s += " + " + latex(a, prec)
    elif op == "neg":
        s = "-" + latex(n.args[0], 10)
    elif op == "*":
        s = r" \cdot ".join(latex(a, prec) for a in n.args)
    elif op == "/":
        s = rf"\frac{{{latex(n.args[0])}}}{{{latex(n.args[1])}}}"
    elif op == "^":
        s = f"{{{latex(n.args[0], 11)}}}^{{{n.payload}}}"
    elif op == "cmp":
        s = f"{latex(n.args[0], prec + 1)} {_CMP[n.payload]} {latex(n.args[1], prec + 1)}"
    elif op in _CONNECTIVE:
        s = f" {_CONNECTIVE[op]} ".join(latex(a, prec + 1) for a in n.args)
    elif op == "not":
        s = r"\lnot " + latex(n.args[0], _PREC["cmp"] + 1)
    elif op == "implies":
        s = rf"{latex(n.args[0], prec + 1)} \rightarrow {latex(n.args[1], prec)}"
    elif op == "iff":
        s = rf"{latex(n.args[0], prec + 1)} \leftrightarrow {latex(n.args[1], prec + 1)}"
    elif op in ("forall", "exists"):
        vs = ", ".join(name(v.payload) for v in n.payload)
        s = rf"\{op} {vs}\, {latex(n.args[0], prec)}"
    elif op == "box":
        s = rf"\left[ {latex_program(n.payload)} \right] {latex(n.args[0], prec)}"
    elif op == "diamond":
        s = rf"\left\langle {latex_program(n.payload)} \right\rangle {latex(n.args[0], prec)}"
    else:  # pragma: no cover - every op is listed above
        raise AssertionError(op)
    return rf"\left({s}\right)" if prec < outer else s


def latex_program(p, outer: int = 0) -> str:
    """A hybrid program as LaTeX math; choices inside sequences are braced."""
    kind = type(p).__name__
    prec = _PROGRAM_PREC.get(kind, 3)
    if kind == "Assign":
        s = f"{latex(p.target)} := {latex(p.value)}"
    elif kind == "Havoc":
        s = f"{latex(p.target)} := *"
    elif kind == "Test":
        s = r"?\," + latex(p.cond, _PREC["not"])
    elif kind == "ODE":
        eqs = ", ".join(f"{name(v.payload)}' = {latex(f)}" for v, f in p.eqs)
        dom = "" if p.domain.op == "true" else rf" \;\&\; {latex(p.domain)}"
        s = rf"\left\{{ {eqs}{dom} \right\}}"
    elif kind == "Seq":
        s = ";\\; ".join(latex_program(q, prec + 1) for q in p.parts)
    elif kind == "Choice":
        s = r" \cup ".join(latex_program(q, prec + 1) for q in p.alternatives)
    elif kind == "Loop":
        s = rf"\left\{{ {latex_program(p.body)} \right\}}^*"
    else:  # pragma: no cover - programs are built from the classes above
        raise AssertionError(kind)
    return rf"\left\{{ {s} \right\}}" if prec < outer else s


def latex_claim(assumptions: Node, program, guarantee: Node) -> str:
    """`assumptions → [program] guarantee`, as one formula."""
    return (rf"{latex(assumptions, _PREC['implies'] + 1)} \rightarrow "
            rf"\left[ {latex_program(program)} \right] {latex(guarantee, _PREC['box'])}")
