"""Small statement and formula shapes the scalar emitter recognises: `{?true}*` (a lemma for
the proof, nothing at run time), the equation that pins an open `x := *` (tried before the
atoms reading x), state the step latches (read, then set), and connectives over numpy
boolean arrays (inside a `∀j` over the boundaries)."""

from __future__ import annotations

from certiloop.kernel.extract.analysis import mentions
from certiloop.models.lang.programs import Assign, Choice, Loop, Program, Seq, Test
from certiloop.models.lang.terms import Node


def elementwise(op: str, a: list[str]) -> str:
    """A connective over numpy boolean arrays (inside a `∀j` over the boundaries)."""
    if op == "and":
        return "(" + " & ".join(a) + ")" if a else "True"
    if op == "or":
        return "(" + " | ".join(a) + ")" if a else "False"
    if op == "not":
        return f"(~{a[0]})"
    if op == "implies":
        return f"((~{a[0]}) | {a[1]})"
    return f"({a[0]} == {a[1]})"


def latched_scalars(parts: list[Program], params) -> set[str]:
    """Scalars the step reads before it assigns them (`?stopped = 1 | ...; stopped := 1`):
    state carried from one step to the next, so an output."""
    assigned: set[str] = set()

    def visit(q: Program) -> None:
        if isinstance(q, Assign) and q.target.op == "var" and not q.target.sort.is_array:
            assigned.add(q.target.payload)
        for c in (q.parts if isinstance(q, Seq) else q.alternatives if isinstance(q, Choice) else
                  (q.body,) if isinstance(q, Loop) else ()):
            visit(c)

    for q in parts:
        visit(q)
    return assigned & set(params)


def is_annotation(q: Program) -> bool:
    """`{?true}*`: a loop that only carries an invariant for the proof."""
    return isinstance(q, Loop) and q.each is None and isinstance(q.body, Test) and q.body.cond.op == "true"


def pins_first(atoms: list[Node], open_names: list[str]) -> list[Node]:
    """Move an equation that pins an open `x := *` before the atoms that read x ahead of it
    (`?nrm >= 0 & nrm*nrm = n2` solves for nrm, then checks it); other atoms keep their
    order. The order of a conjunction does not change its value in the generated code: a
    division by zero gives inf/NaN, never an exception."""
    out = list(atoms)
    for name in open_names:
        readers = [k for k, a in enumerate(out) if mentions(a, name)]
        pin = next((k for k in readers if out[k].op == "cmp" and out[k].payload == "=="), None)
        if pin is not None and readers[0] < pin:
            out.insert(readers[0], out.pop(pin))
    return out
