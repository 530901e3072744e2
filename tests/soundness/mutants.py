"""Mutants of the library's models: one small change each, the kind a slip of the pen makes.

  flip      a comparison in a test or an evolution domain turned around (< becomes >=)
  drop      one conjunct of a test left out (a guard forgotten)
  perturb   one constant in an assignment or a test changed (c becomes c + 1)

Most mutants are unsafe; some are not (a redundant guard, a constant that does not matter).
The engine is never told which: the mutation test asks the engine, and whenever it says
`proved`, an independent witness — the falsifier, which runs the interpreter and re-checks
a violation exactly — must find no violating run.
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction
from typing import Callable, Iterator

from certiloop.models.lang.programs import ODE, Assign, Choice, Loop, Program, Seq, Test
from certiloop.models.lang.terms import INT, And, Node, cmp, const, rebuild
from certiloop.models.lang.theorem import Theorem

FLIP = {"<": ">=", "<=": ">", ">": "<=", ">=": "<", "==": "!=", "!=": "=="}


def _map_program(p: Program, on_test: Callable[[Node], Node], on_domain: Callable[[Node], Node],
                 on_value: Callable[[Node], Node]) -> Program:
    again = lambda q: _map_program(q, on_test, on_domain, on_value)  # noqa: E731
    if isinstance(p, Test):
        return Test(on_test(p.cond))
    if isinstance(p, Assign):
        return Assign(p.target, on_value(p.value))
    if isinstance(p, ODE):
        return ODE(p.eqs, on_domain(p.domain), p.invariants)
    if isinstance(p, Seq):
        return Seq(tuple(again(q) for q in p.parts))
    if isinstance(p, Choice):
        return Choice(tuple(again(q) for q in p.alternatives), p.labels)
    if isinstance(p, Loop):
        return Loop(again(p.body), p.invariant, p.label, p.each, p.count)
    return p


class _Counter:
    """Rewrites the target-th site it is shown, counts all of them."""

    def __init__(self, target: int) -> None:
        self.seen, self.target, self.what = 0, target, ""

    def hit(self) -> bool:
        self.seen += 1
        return self.seen == self.target


def _flip(counter: _Counter) -> Callable[[Node], Node]:
    def walk(f: Node) -> Node:
        if f.op == "cmp" and f.args[0].sort.is_numeric:
            if counter.hit():
                counter.what = f"flip `{f}`"
                return cmp(FLIP[f.payload], *f.args)
            return f
        if f.op in ("and", "or", "not", "implies"):
            return rebuild(f, tuple(walk(a) for a in f.args))
        return f
    return walk


def _drop(counter: _Counter) -> Callable[[Node], Node]:
    def walk(f: Node) -> Node:
        if f.op == "and":
            for k, part in enumerate(f.args):
                if part.op != "cmp":
                    continue
                if counter.hit():
                    counter.what = f"drop `{part}`"
                    return And(*(a for j, a in enumerate(f.args) if j != k))
        return f
    return walk


def _perturb(counter: _Counter) -> Callable[[Node], Node]:
    def walk(t: Node) -> Node:
        if t.op == "const" and t.sort.is_numeric:
            if counter.hit():
                counter.what = f"perturb {t} to {t.payload + 1}"
                if t.sort == INT:  # keep the sort: an Int constant stays an Int
                    return const(int(t.payload) + 1)
                return const(t.payload + 1 if t.payload.denominator == 1 else t.payload * Fraction(3, 2))
            return t
        if t.args and t.op not in ("forall", "exists", "box", "diamond"):
            return rebuild(t, tuple(walk(a) for a in t.args))
        return t
    return walk


def mutants(theorem: Theorem, limit_per_kind: int | None = None) -> Iterator[tuple[str, Theorem]]:
    """(description, mutant) for every site of every kind, in a fixed order; with
    limit_per_kind, an evenly spread deterministic sample of that many per kind."""
    keep = lambda f: f  # noqa: E731
    kinds = {
        "flip": lambda c: (_flip(c), _flip(c), keep),
        "drop": lambda c: (_drop(c), keep, keep),
        "perturb": lambda c: (_perturb(c), keep, _perturb(c)),
    }
    for kind, make in kinds.items():
        probe = _Counter(0)
        _map_program(theorem.program, *make(probe))
        sites = range(1, probe.seen + 1)
        if limit_per_kind is not None and probe.seen > limit_per_kind:
            stride = probe.seen / limit_per_kind
            sites = sorted({1 + int(k * stride) for k in range(limit_per_kind)})
        for site in sites:
            counter = _Counter(site)
            program = _map_program(theorem.program, *make(counter))
            if not counter.what:
                continue
            yield (f"{kind} #{site}: {counter.what}",
                   replace(theorem, name=f"{theorem.name}~{kind}{site}", program=program, expected="proved",
                           check_nonblocking=False))
