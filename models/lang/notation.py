"""Differential dynamic logic in mathematical notation, as LaTeX or as HTML, for notebooks
(`Theorem._repr_latex_` / `_repr_html_`, `Node._repr_latex_`, `Program._repr_latex_`).

One printer, two notations: `x := e`, `x := *`, `?Q`, `α; β`, `α ∪ β`, `α*`, `{x' = f & Q}`,
`[α]P`, `⟨α⟩P`. Binding strengths follow `printing.py`. Annotations (invariants, branch
labels) are left out: they are not part of the claim.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from html import escape
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:  # read by fields only, as printing.py: no import cycle
    from certiloop.models.lang.terms import Node

_PREC = {
    "iff": 1, "implies": 2, "or": 3, "and": 4, "not": 5, "forall": 5, "exists": 5,
    "box": 5, "diamond": 5, "cmp": 6, "+": 7, "neg": 9, "*": 9, "/": 9, "^": 10,
}
_PROGRAM_PREC = {"Choice": 1, "Seq": 2}  # a loop, an ODE and atomic statements bind tightest


@dataclass(frozen=True)
class Notation:
    name: Callable[[str], str]  # a symbol's name
    fraction: Callable[[int, int], str]  # a non-integer constant (numerator >= 0)
    divide: Callable[[str, str], str]  # a / b from the printed operands
    atomic_division: bool  # the division shape needs no parentheses (LaTeX's \frac)
    power: Callable[[str, int], str]
    group: Callable[[str], str]  # (s)
    block: Callable[[str], str]  # { s }: a program group, an ODE
    words: dict[str, str]  # operators and keywords


def _latex_name(text: str) -> str:
    return text if len(text) == 1 else r"\mathit{" + text.replace("_", r"\_") + "}"


LATEX = Notation(
    name=_latex_name,
    fraction=lambda n, d: rf"\frac{{{n}}}{{{d}}}",
    divide=lambda a, b: rf"\frac{{{a}}}{{{b}}}",
    atomic_division=True,
    power=lambda base, n: f"{{{base}}}^{{{n}}}",
    group=lambda s: rf"\left({s}\right)",
    block=lambda s: rf"\left\{{ {s} \right\}}",
    words={"==": "=", "!=": r"\neq", "<": "<", "<=": r"\leq", ">": ">", ">=": r"\geq",
           "and": r" \land ", "or": r" \lor ", "not": r"\lnot ", "implies": r" \rightarrow ",
           "iff": r" \leftrightarrow ", "forall": r"\forall ", "exists": r"\exists ", "bind": r"\, ",
           "*": r" \cdot ", "true": r"\mathrm{true}", "false": r"\mathrm{false}", "[": r"\left[ ",
           "]": r" \right] ", "<<": r"\left\langle ", ">>": r" \right\rangle ", "{": r"\{", "}": r"\}",
           "test": r"?\,", "seq": r";\; ", "cup": r" \cup ", "star": "^*", "prime": "'",
           "domain": r" \;\&\; "},
)

HTML = Notation(
    name=lambda text: f"<i>{escape(text)}</i>",
    fraction=lambda n, d: f"{n}/{d}",
    divide=lambda a, b: f"{a}/{b}",
    atomic_division=False,
    power=lambda base, n: f"{base}<sup>{n}</sup>",
    group=lambda s: f"({s})",
    block=lambda s: f"{{{s}}}",
    words={"==": "=", "!=": "≠", "<": "&lt;", "<=": "≤", ">": "&gt;", ">=": "≥",
           "and": " ∧ ", "or": " ∨ ", "not": "¬", "implies": " → ", "iff": " ↔ ", "forall": "∀",
           "exists": "∃", "bind": " ", "*": "·", "true": "true", "false": "false", "[": "[", "]": "] ",
           "<<": "⟨", ">>": "⟩ ", "{": "{", "}": "}", "test": "?", "seq": "; ", "cup": " ∪ ",
           "star": "<sup>*</sup>", "prime": "′", "domain": " &amp; "},
)


def term(n: Node, notation: Notation = LATEX, outer: int = 0) -> str:
    """A term or formula (LaTeX: math without the surrounding `$`)."""
    w, op = notation.words, n.op
    prec = _PREC.get(op, 11)
    sub = lambda x, p: term(x, notation, p)
    if op == "const":
        s = _number(n.payload, notation)
        prec = 8 if n.payload < 0 else 11 if n.payload.denominator == 1 else 9
    elif op == "var":
        s = notation.name(n.payload)
    elif op in ("true", "false"):
        s = w[op]
    elif op == "select":
        s = sub(n.args[0], 11) + "".join(f"[{sub(i, 0)}]" for i in n.args[1:])
    elif op == "store":
        a, *idx, v = n.args
        s = f"{sub(a, 11)}{w['{']}{', '.join(sub(i, 0) for i in idx)} := {sub(v, 0)}{w['}']}"
    elif op == "+":
        s = sub(n.args[0], prec)
        for a in n.args[1:]:
            if a.op == "neg":
                s += " - " + sub(a.args[0], prec + 1)
            elif a.op == "const" and a.payload < 0:
                s += " - " + _number(-a.payload, notation)
            else:
                s += " + " + sub(a, prec)
    elif op == "neg":
        s = "-" + sub(n.args[0], 10)
    elif op == "*":
        s = w["*"].join(sub(a, prec) for a in n.args)
    elif op == "/":
        if notation.atomic_division:
            s, prec = notation.divide(sub(n.args[0], 0), sub(n.args[1], 0)), 11
        else:
            s = notation.divide(sub(n.args[0], prec), sub(n.args[1], prec + 1))
    elif op == "^":
        s = notation.power(sub(n.args[0], 11), n.payload)
    elif op == "cmp":
        s = f"{sub(n.args[0], prec + 1)} {w[n.payload]} {sub(n.args[1], prec + 1)}"
    elif op in ("and", "or"):
        s = w[op].join(sub(a, prec + 1) for a in n.args)
    elif op == "not":
        s = w["not"] + sub(n.args[0], _PREC["cmp"] + 1)
    elif op == "implies":
        s = sub(n.args[0], prec + 1) + w["implies"] + sub(n.args[1], prec)
    elif op == "iff":
        s = sub(n.args[0], prec + 1) + w["iff"] + sub(n.args[1], prec + 1)
    elif op in ("forall", "exists"):
        s = w[op] + ", ".join(notation.name(v.payload) for v in n.payload) + w["bind"] + sub(n.args[0], prec)
    elif op == "box":
        s = w["["] + program(n.payload, notation) + w["]"] + sub(n.args[0], prec)
    elif op == "diamond":
        s = w["<<"] + program(n.payload, notation) + w[">>"] + sub(n.args[0], prec)
    else:  # pragma: no cover - every op is listed above
        raise AssertionError(op)
    return notation.group(s) if prec < outer else s


def program(p, notation: Notation = LATEX, outer: int = 0) -> str:
    """A hybrid program; choices inside sequences are braced."""
    w, kind = notation.words, type(p).__name__
    prec = _PROGRAM_PREC.get(kind, 3)
    if kind == "Assign":
        s = f"{term(p.target, notation)} := {term(p.value, notation)}"
    elif kind == "Havoc":
        s = f"{term(p.target, notation)} := *"
    elif kind == "Test":
        s = w["test"] + term(p.cond, notation, _PREC["not"])
    elif kind == "ODE":
        eqs = ", ".join(f"{notation.name(v.payload)}{w['prime']} = {term(f, notation)}" for v, f in p.eqs)
        s = notation.block(eqs + ("" if p.domain.op == "true" else w["domain"] + term(p.domain, notation)))
    elif kind == "Seq":
        s = w["seq"].join(program(q, notation, prec + 1) for q in p.parts)
    elif kind == "Choice":
        s = w["cup"].join(program(q, notation, prec + 1) for q in p.alternatives)
    elif kind == "Loop":
        s = notation.block(program(p.body, notation)) + w["star"]
    else:  # pragma: no cover - programs are built from the classes above
        raise AssertionError(kind)
    return notation.block(s) if prec < outer else s


def claim(assumptions: Node, prog, guarantee: Node, notation: Notation = LATEX) -> str:
    """`assumptions → [program] guarantee`, as one formula."""
    w = notation.words
    return (term(assumptions, notation, _PREC["implies"] + 1) + w["implies"] + w["["]
            + program(prog, notation) + w["]"] + term(guarantee, notation, _PREC["box"]))


def _number(f: Fraction, notation: Notation) -> str:
    if f.denominator == 1:
        return str(f.numerator)
    return ("-" if f < 0 else "") + notation.fraction(abs(f.numerator), f.denominator)
