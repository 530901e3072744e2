"""Conveniences for writing models: the statements `if_`, `assign_min`, `for_range` and
`foreach`, each expanding to the core constructs of programs.py, and the terms `dot` and
`Ite`, expanding to sums and implications; the prover, the checker and the interpreter only
ever see the core constructs."""

from __future__ import annotations

from typing import Any, Callable, Iterable

from certiloop.models.lang.programs import (
    Choice,
    Count,
    Each,
    Loop,
    Program,
    assign,
    branch,
    choice,
    havoc,
    loop,
    seq,
    skip,
    test,
)
from certiloop.models.lang.terms import (
    BOOL,
    INT,
    TRUE,
    And,
    ForAll,
    Implies,
    ModelError,
    Node,
    Not,
    Var,
    add,
    formula,
    free_vars,
    mul,
    term,
)


def if_(cond: Any, then: Program, otherwise: Program | None = None,
        labels: tuple[str, str] = ("then", "else")) -> Choice:
    """if cond then `then` else `otherwise` (default: skip), as the choice
    `?cond; then ∪ ?!cond; otherwise` with the two branches labelled `labels`:
    `if_(h == 0, assign(v, -c * v), labels=("bounce", "in the air"))`."""
    c = formula(cond)
    return choice(branch(labels[0], test(c), then), branch(labels[1], test(Not(c)), otherwise or skip()))


def assign_min(target: Node, a: Any, b: Any) -> Choice:
    """target := min(a, b), as the two-case choice the proof will split on."""
    a, b = term(a), term(b)
    return choice(
        branch(f"{b} >= {a}", test(b >= a), assign(target, a)),
        branch(f"{b} < {a}", test(b < a), assign(target, b)),
    )


def for_range(var: Node, lo: Any, hi: Any, body: Program, invariant: Any,
              label: str | None = None) -> Program:
    """for var in [lo, hi): body — a bounded loop; the invariant may mention `var`.

    Expands to  var := lo; (?var < hi; body; var := var + 1)*; ?var >= hi,
    with invariant `lo <= var <= hi ∧ invariant` so users only state what the body keeps.
    """
    if var.sort != INT:
        raise ModelError(f"the loop counter `{var}` must be an Int symbol")
    lo, hi = term(lo), term(hi)
    inv = And(lo <= var, var <= hi, formula(invariant))
    step = seq(test(var < hi), body, assign(var, var + 1))
    counted = Loop(step, inv, label or f"for {var.name}", count=Count(var, hi))
    return seq(assign(var, lo), counted, test(var >= hi))


def foreach(index: Node, done: Node, body: Program, invariant: Any,
            where: Callable[[Node], Node] | None = None, label: str | None = None) -> Program:
    """Run `body` once for every element `index` of a finite family (in any order).

    `done` is a Bool family over the index sort that the invariant may mention: it marks
    the elements processed so far. `where(j)` restricts the family (e.g. active boundaries).
    Expands to
        done := *; ?∀j ¬done(j);
        (index := *; ?¬done(index) ∧ where(index); body; done(index) := true)*  {invariant}
        ?∀j (where(j) -> done(j))
    The proof never needs the family's size: the invariant is quantified over it.
    """
    if index.op != "var" or index.sort.is_array or index.sort.is_numeric or index.sort == BOOL:
        raise ModelError(f"foreach needs a symbol of an index sort, got `{index}`")
    if done.op != "var" or done.sort.domain != (index.sort,) or done.sort.range != BOOL:
        raise ModelError(f"foreach: `{done}` must be a Bool family over {index.sort}")
    member = where or (lambda _j: TRUE)
    # the bound variable of the entry and exit tests: a name the user's `where` does not use
    taken = set(free_vars(formula(member(index)))) | set(free_vars(done(index))) | {index.name}
    suffix = 1
    while f"{index.name}_{suffix}" in taken:
        suffix += 1
    other = Var(f"{index.name}_{suffix}", index.sort)
    step = seq(havoc(index), test(And(Not(done(index)), member(index))), body,
               assign(done(index), TRUE))
    body = loop(step, invariant, label or f"foreach {index.name}")
    body = Loop(body.body, body.invariant, body.label, Each(index, done, formula(member(index))))
    return seq(
        havoc(done),
        test(ForAll(other, Not(done(other)))),
        body,
        test(ForAll(other, Implies(member(other), done(other)))),
    )


def Ite(cond: Any, then: Any, other: Any) -> Node:
    """Formula-level if-then-else (for postconditions such as P = (collide ? 1 : 0)):
    `Ite(collide, P == 1, P == 0)` is `(collide -> P = 1) & (!collide -> P = 0)`."""
    c = formula(cond)
    return And(Implies(c, then), Implies(Not(c), other))


def dot(u: Iterable[Any], v: Iterable[Any]) -> Node:
    """Dot product of two equal-length vectors of terms: `dot((px, py), (nx(i), ny(i)))`."""
    u, v = list(u), list(v)
    if len(u) != len(v):
        raise ModelError(f"dot product of vectors of length {len(u)} and {len(v)}")
    return add(*(mul(a, b) for a, b in zip(u, v)))
