"""Which initial values a program reads: the refuter searches only those (the others cannot
change a run)."""

from __future__ import annotations

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import Node, free_vars
from certiloop.proofs.core.wp import root_name


def read_first(p: Program) -> dict[str, Node]:
    """Symbols whose value at the start of `p` some run may read: those read before every
    assignment to them on some path. The others' initial values cannot matter. An array
    counts as read whenever a cell of it is (one cell's assignment does not define it)."""
    reads: dict[str, Node] = {}

    def note(f: Node, defined: frozenset) -> None:
        reads.update((n, v) for n, v in free_vars(f).items() if n not in defined)

    def walk(q: Program, defined: frozenset) -> frozenset:
        if isinstance(q, (Assign, Havoc)):
            target = q.target
            for index in target.args[1:] if target.op == "select" else ():
                note(index, defined)
            if isinstance(q, Assign):
                note(q.value, defined)
            if target.op == "var":
                return defined | {target.payload}
            note(root_name(target), defined)  # the other cells keep their values
            return defined
        if isinstance(q, Test):
            note(q.cond, defined)
            return defined
        if isinstance(q, ODE):
            for v, f in q.eqs:
                note(v, defined)
                note(f, defined)
            note(q.domain, defined)
            return defined
        if isinstance(q, Seq):
            for part in q.parts:
                defined = walk(part, defined)
            return defined
        if isinstance(q, Choice):
            after = [walk(a, defined) for a in q.alternatives]
            return frozenset.intersection(*after) if after else defined
        if isinstance(q, Loop):
            if q.invariant is not None:
                note(q.invariant, defined)
            walk(q.body, defined)
            return defined  # the body may run zero times
        raise TypeError(q)

    walk(p, frozenset())
    return reads
