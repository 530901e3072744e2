"""Hybrid programs: x := e, x := *, ?Q, a;b, a ∪ b, a* (with invariant), ODE systems, their
constructors and static semantics (conveniences.py builds more statements from these)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from certiloop.models.lang.printing import show_program
from certiloop.models.lang.terms import (
    BOOL,
    INT,
    REAL,
    TRUE,
    ModelError,
    Node,
    formula,
    free_vars,
    term,
)


class Program:
    """Base class of hybrid programs; `a >> b` is sequence, `a | b` is choice."""

    @property
    def key(self) -> tuple:
        raise NotImplementedError

    def __rshift__(self, other: "Program") -> "Program":
        return seq(self, other)

    def __or__(self, other: "Program") -> "Program":
        return choice(self, other)

    def symbols(self) -> dict[str, Node]:
        """Every symbol the program mentions (read or written), by name."""
        return program_symbols(self)

    def __str__(self) -> str:
        return show_program(self)

    __repr__ = __str__

    def _repr_latex_(self) -> str:
        """Notebook display: the program in dL notation (annotations left out)."""
        from certiloop.models.lang import notation  # display only: not in the checker's base
        return f"${notation.program(self)}$"


def _target_root(target: Node) -> Node:
    while target.op == "select":
        target = target.args[0]
    return target


def _check_target(target: Node) -> Node:
    if not isinstance(target, Node) or (target.op != "var" and target.op != "select"):
        raise ModelError(f"cannot assign to `{target}`: only symbols and array cells are assignable")
    if target.op == "select" and target.sort.is_array:
        raise ModelError(f"cannot assign to the partial array read `{target}`; index it fully")
    if target.op == "var" and target.sort.is_array:
        raise ModelError(f"cannot assign the whole array `{target}`; assign its cells")
    return target


@dataclass(frozen=True, eq=False)
class Assign(Program):
    """x := e (or a[i] := e): build it with `assign`."""

    target: Node
    value: Node

    @property
    def key(self):
        return ("assign", self.target.key, self.value.key)


@dataclass(frozen=True, eq=False)
class Havoc(Program):
    """x := * (nondeterministic assignment)."""

    target: Node

    @property
    def key(self):
        return ("havoc", self.target.key)


@dataclass(frozen=True, eq=False)
class Test(Program):
    """?Q: continue only if Q holds (runs where it fails are discarded): build it with `test`."""

    cond: Node
    __test__ = False  # not a pytest test class

    @property
    def key(self):
        return ("test", self.cond.key)


@dataclass(frozen=True, eq=False)
class Seq(Program):
    """a; b; ...: run the parts one after another: build it with `seq` (or `a >> b`)."""

    parts: tuple[Program, ...]

    @property
    def key(self):
        return ("seq", tuple(p.key for p in self.parts))


@dataclass(frozen=True, eq=False)
class Choice(Program):
    """Nondeterministic choice; each alternative has a label used in proof paths."""

    alternatives: tuple[Program, ...]
    labels: tuple[str, ...]

    @property
    def key(self):
        return ("choice", tuple(p.key for p in self.alternatives), self.labels)


@dataclass(frozen=True)
class Each:
    """Marks a loop made by `foreach`: it visits every element of a finite family once,
    which is what lets the vacuity check conclude that the loop can always finish."""

    index: Node
    done: Node
    member: Node  # formula over `index`: the elements to visit


@dataclass(frozen=True)
class Count:
    """Marks a loop made by `for_range`: `counter` goes up by one per iteration until it
    reaches `limit`, which is what lets the vacuity check conclude that the loop finishes."""

    counter: Node
    limit: Node


@dataclass(frozen=True, eq=False)
class Loop(Program):
    """a* with an invariant annotation (None: the proof uses the postcondition)."""

    body: Program
    invariant: Node | None = None
    label: str = "loop"
    each: Each | None = None  # set by foreach; not part of the semantics
    count: Count | None = None  # set by for_range; not part of the semantics

    @property
    def key(self):
        inv = self.invariant.key if self.invariant is not None else None
        each = None if self.each is None else (self.each.index.key, self.each.done.key, self.each.member.key)
        count = None if self.count is None else (self.count.counter.key, self.count.limit.key)
        return ("loop", self.body.key, inv, self.label, each, count)


@dataclass(frozen=True, eq=False)
class ODE(Program):
    """{x1' = f1, ..., xn' = fn & domain}.

    invariants: differential invariants proved in order (each may use the earlier ones:
    a differential-cut chain). With none given, the engine solves the system when its
    solution is polynomial in time and otherwise uses differential weakening.
    """

    eqs: tuple[tuple[Node, Node], ...]
    domain: Node = TRUE
    invariants: tuple[Node, ...] = field(default=())

    @property
    def key(self):
        return (
            "ode",
            tuple((v.key, f.key) for v, f in self.eqs),
            self.domain.key,
            tuple(i.key for i in self.invariants),
        )

    @property
    def variables(self) -> tuple[Node, ...]:
        return tuple(v for v, _ in self.eqs)


# --------------------------------------------------------------------------- constructors


def assign(target: Node, value: Any) -> Assign:
    """x := e, for a symbol or an array/family cell: `assign(a, -b)`, `assign(u(i), 1)`.
    An Int target needs an Int value; a Bool target takes a formula."""
    target = _check_target(target)
    value = term(value) if target.sort != BOOL else formula(value)
    if target.sort != value.sort and not (target.sort.is_numeric and value.sort.is_numeric):
        raise ModelError(f"cannot assign `{value}` ({value.sort}) to `{target}` ({target.sort})")
    if target.sort == INT and value.sort != INT:
        raise ModelError(f"cannot assign the real term `{value}` to the integer `{target}`")
    return Assign(target, value)


def havoc(target: Node) -> Havoc:
    """x := *, a[i] := *, or a := * for a whole array or family (every entry arbitrary)."""
    if isinstance(target, Node) and target.op == "var" and target.sort.is_array:
        return Havoc(target)
    return Havoc(_check_target(target))


def test(cond: Any) -> Test:
    """?Q, a guard: runs where Q is false are discarded: `test(v >= 0)`."""
    return Test(formula(cond))


test.__test__ = False  # imported into a user's test module, it is not a pytest test


def seq(*parts: Program) -> Program:
    """a; b; c: the programs one after another (nested sequences flatten):
    `seq(ctrl, assign(t, 0), plant)`; `a >> b` is the same."""
    flat: list[Program] = []
    for p in parts:
        if not isinstance(p, Program):
            raise ModelError(f"expected a hybrid program in a sequence, got {p!r}")
        flat.extend(p.parts if isinstance(p, Seq) else (p,))
    if not flat:
        return skip()  # the empty sequence does nothing
    return flat[0] if len(flat) == 1 else Seq(tuple(flat))


def branch(label: str, *parts: Program) -> tuple[str, Program]:
    """A labelled alternative for `choice`: choice(branch('free zone', ...), ...)."""
    return (label, seq(*parts))


def choice(*alternatives: Program | tuple[str, Program]) -> Choice:
    """a ∪ b ∪ ...: nondeterministically run one alternative. Label alternatives with
    `branch` so proof paths name them: `choice(branch("brake", ...), branch("coast", ...))`;
    unlabelled ones are called "branch 1", "branch 2"; `a | b` is the same."""
    progs: list[Program] = []
    labels: list[str] = []
    for alt in alternatives:
        label, prog = alt if isinstance(alt, tuple) else (None, alt)
        if not isinstance(prog, Program):
            raise ModelError(f"expected a hybrid program in a choice, got {prog!r}")
        if label is None and isinstance(prog, Choice):
            progs.extend(prog.alternatives)
            labels.extend(prog.labels)
            continue
        progs.append(prog)
        labels.append(label or f"branch {len(labels) + 1}")
    if not progs:
        raise ModelError("a choice needs at least one alternative (a choice of none has no run at all; "
                         "write test(FALSE) for that, or skip() for a step that does nothing)")
    if len(set(labels)) != len(labels):
        labels = [f"{lab} #{i}" for i, lab in enumerate(labels, 1)]
    return Choice(tuple(progs), tuple(labels))


def loop(body: Program, invariant: Any = None, label: str = "loop") -> Loop:
    """body*: repeat body any number of times (zero included). The proof needs an
    `invariant` that holds initially, is kept by body and implies the guarantee; without
    one it uses the guarantee. `label` names the loop in proof paths:
    `loop(seq(ctrl, plant), invariant=v**2 <= 2*b*(m - p), label="control loop")`."""
    if not isinstance(body, Program):
        raise ModelError(f"expected a hybrid program as the body of a loop, got {body!r}")
    inv = formula(invariant) if invariant is not None else None
    return Loop(body, inv, label)


def ode(eqs: dict[Node, Any] | list[tuple[Node, Any]], domain: Any = TRUE,
        invariants: tuple[Any, ...] | list[Any] = ()) -> ODE:
    """{x' = f, ... & domain}: follow the ODE for any duration while the domain holds
    throughout: `ode({p: v, v: a, t: 1}, And(v >= 0, t <= eps))`. `invariants`: a chain of
    differential invariants, each proved with the earlier ones (a differential cut), for
    flows without a polynomial solution: `invariants=[v >= 0, x >= x0]`."""
    pairs = list(eqs.items()) if isinstance(eqs, dict) else list(eqs)
    seen: set[str] = set()
    out = []
    for v, f in pairs:
        if not isinstance(v, Node) or v.op != "var" or v.sort != REAL:
            what = f"the {v.sort} symbol" if isinstance(v, Node) and v.op == "var" else "the term"
            raise ModelError(f"ODE left-hand side: {what} `{v}` cannot evolve continuously; "
                             "only Real symbols can")
        if v.name in seen:
            raise ModelError(f"ODE gives {v.name}' twice; each variable needs exactly one equation")
        seen.add(v.name)
        out.append((v, term(f)))
    if not out:
        raise ModelError("an ODE system needs at least one equation")
    return ODE(tuple(out), formula(domain), tuple(formula(i) for i in invariants))


def skip() -> Test:
    """The program that does nothing (?true): `if_(c, assign(x, 0), skip())`."""
    return Test(TRUE)


# --------------------------------------------------------------------------- static semantics


def children(p: Program) -> tuple[Program, ...]:
    """The sub-programs of a compound program (none for atomic statements)."""
    if isinstance(p, Seq):
        return p.parts
    if isinstance(p, Choice):
        return p.alternatives
    if isinstance(p, Loop):
        return (p.body,)
    return ()


def written(p: Program) -> dict[str, Node]:
    """Symbols a program may change (array cells count as their array), by name."""
    out: dict[str, Node] = {}
    if isinstance(p, (Assign, Havoc)):
        root = _target_root(p.target)
        out[root.name] = root
    elif isinstance(p, ODE):
        out.update((v.name, v) for v in p.variables)
    for q in children(p):
        out.update(written(q))
    return out


def program_symbols(p: Program, annotations: bool = True) -> dict[str, Node]:
    """Every symbol a program mentions (read or written), by name; with annotations=False,
    only those its runs read or write (not the invariants, which are proof hints)."""
    out: dict[str, Node] = {}
    formulas: list[Node] = []
    if isinstance(p, Assign):
        formulas = [p.target, p.value]
    elif isinstance(p, Havoc):
        formulas = [p.target]
    elif isinstance(p, Test):
        formulas = [p.cond]
    elif isinstance(p, ODE):
        out.update((v.name, v) for v in p.variables)
        formulas = [f for _, f in p.eqs] + [p.domain, *(p.invariants if annotations else ())]
    elif isinstance(p, Loop) and p.invariant is not None and annotations:
        formulas = [p.invariant]
    for f in formulas:
        out.update(free_vars(f))
    for q in children(p):
        out.update(program_symbols(q, annotations))
    return out


def is_loop_free(p: Program) -> bool:
    return not isinstance(p, Loop) and all(is_loop_free(q) for q in children(p))
