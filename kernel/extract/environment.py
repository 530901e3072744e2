"""A model's declared roles (`Theorem(roles=Roles(environment=(al,), controls=(a,)))`) applied
to its control step: which statements are the controller's and which the environment's.

* The environment's statements are the top-level `x := *` of its variables and the test
  conjuncts that read them (`al := *; ?-B <= al & al <= A`). They leave the controller: the
  controller gets the chosen values as inputs (it senses them), and the environment monitor
  checks the tests (the model's assumptions about the world).
* In a choice of plant modes, each mode's statements before its ODE are the controller's, with
  the mode's evolution domain as a test (a mode whose domain fails at the start has no run);
  the rates are the plant's, never an output.
* The controller's outputs are exactly the declared controls.

A declaration the program does not fit is refused in one line naming the symbol and the fix.
Without a declaration none of this runs: the extraction is what it always was."""

from __future__ import annotations

from certiloop.kernel.extract.errors import ExtractError, refuse
from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Havoc,
    Program,
    Seq,
    Test,
    children,
    program_symbols,
    written,
)
from certiloop.models.lang.terms import And, Node, free_vars
from certiloop.models.lang.theorem import Theorem


def _conjuncts(f: Node) -> list[Node]:
    return [a for x in f.args for a in _conjuncts(x)] if f.op == "and" else [f]


def _flat(parts: list[Program]) -> list[Program]:
    return [r for q in parts for r in (_flat(list(q.parts)) if isinstance(q, Seq) else [q])]


def _havocs(p: Program) -> set[str]:
    if isinstance(p, Havoc):
        return {p.target.payload} if p.target.op == "var" else set()
    return set().union(*(_havocs(q) for q in children(p)))


def _first(names: set[str]) -> str:
    return sorted(names)[0]


def check_declaration(theorem: Theorem) -> None:
    """Every declared name is a symbol of the model, with the model's sort, and not a constant."""
    roles = theorem.roles
    symbols = {**free_vars(theorem.assumptions), **theorem.program.symbols(), **free_vars(theorem.guarantee)}
    constants = {c.payload for c in theorem.constants}
    for field, names in (("environment", roles.environment), ("controls", roles.controls)):
        for v in names:
            name = v.payload
            if name not in symbols:
                raise ExtractError(f"{theorem.name}: roles {field} name `{name}`, which the model does not "
                                   "mention; correct the name or remove it from Roles")
            if symbols[name].sort != v.sort:
                raise ExtractError(f"{theorem.name}: roles declare `{name}` as {v.sort}, but the model's "
                                   f"`{name}` is {symbols[name].sort}; declare the model's symbol")
            if name in constants:
                raise ExtractError(f"{theorem.name}: roles {field} name the constant `{name}`, which nobody "
                                   "chooses; remove it from Roles (constants are state)")


def separate(theorem: Theorem, parts: list[Program]) -> tuple[list[Program], list[Program]]:
    """(the controller's statements, the environment's) among a step's top-level statements."""
    env = set(theorem.roles.environment_names)
    controller: list[Program] = []
    environment: list[Program] = []
    chosen: set[str] = set()  # the environment's variables chosen so far
    seen: set[str] = set()  # what the controller's statements so far read or write
    set_by_controller: set[str] = set(theorem.roles.control_names)
    for q in _flat(parts):
        if isinstance(q, Havoc) and q.target.op == "var" and q.target.payload in env:
            name = q.target.payload
            if name in seen:
                raise refuse(q, f"the controller reads `{name}` before the environment chooses it here; put "
                             "the environment's choice before the controller's statements")
            chosen.add(name)
            environment.append(q)
            continue
        if isinstance(q, Test) and set(free_vars(q.cond)) & env:
            kept = []
            for atom in _conjuncts(q.cond):
                names = set(free_vars(atom))
                if not names & env:
                    kept.append(atom)
                    continue
                if names & set_by_controller:
                    raise refuse(atom, f"a test of the environment's `{_first(names & env)}` that reads "
                                 f"`{_first(names & set_by_controller)}`, which the controller chooses; "
                                 "state the environment's assumptions over its variables and the state")
                if (names & env) - chosen:
                    late = _first((names & env) - chosen)
                    raise refuse(atom, f"tests the environment's `{late}` before the step chooses it "
                                 f"(`{late} := *`); put the test after the choice")
                environment.append(Test(atom))
            if kept:
                controller.append(Test(And(*kept)) if len(kept) > 1 else Test(kept[0]))
            continue
        wrote = set(written(q)) & env
        nested = _havocs(q) & env
        if nested:
            name = _first(nested)
            raise refuse(q, f"the environment's `{name} := *` is inside a statement of the controller; make "
                         f"the environment's choice a statement of its own at the top of the step "
                         f"(`{name} := *; ?...`)")
        if wrote:
            name = _first(wrote)
            raise refuse(q, f"the controller sets the environment's `{name}`; only the environment chooses "
                         f"it (`{name} := *` and tests, as statements of their own in the step), or remove "
                         f"`{name}` from environment")
        controller.append(q)
        seen |= set(program_symbols(q, annotations=False))
        set_by_controller |= set(written(q))
    return controller, environment


def check_chosen(theorem: Theorem, environment: list[Program]) -> None:
    """Every declared environment variable is chosen by the step (`x := *`)."""
    chosen = {q.target.payload for q in environment if isinstance(q, Havoc)}
    for name in theorem.roles.environment_names:
        if name not in chosen:
            raise ExtractError(f"{theorem.name}: roles name `{name}` in environment, but the control step "
                               f"never chooses it (`{name} := *`); it is state the controller reads: remove "
                               "it from environment")


def switched_controller(theorem: Theorem, plant: Choice) -> tuple[Choice, set[str]]:
    """The controller's part of a choice of plant modes: each mode's statements before its ODE,
    then the mode's evolution domain as a test; and the names its plant initialisation sets
    (the assignments to evolved variables right before an ODE, such as a clock reset)."""
    env = set(theorem.roles.environment_names)
    alternatives, init = [], set()
    for alt in plant.alternatives:
        parts = list(alt.parts) if isinstance(alt, Seq) else [alt]
        ode = parts[-1]
        assert isinstance(ode, ODE)
        pre = parts[:-1]
        for q in pre:
            if set(written(q)) & env:
                raise refuse(q, f"a plant mode sets the environment's `{_first(set(written(q)) & env)}`; put "
                             "the environment's choice before the choice of modes")
        flows = {v.payload for v in ode.variables}
        k = len(pre)
        while k and isinstance(pre[k - 1], Assign) and pre[k - 1].target.op == "var" \
                and pre[k - 1].target.payload in flows:
            k -= 1
            init.add(pre[k].target.payload)
        alternatives.append(Seq((*pre, Test(ode.domain))) if pre else Test(ode.domain))
    return Choice(tuple(alternatives), plant.labels), init


def checked_outputs(theorem: Theorem, plant_reads: set[str], plant_init: set[str], assigned: list[str],
                    inputs: list[str], latches: set[str] = frozenset()) -> list[str]:
    """The declared controls, once each is set by the step and nothing else the plant or the next
    step reads is."""
    controls = list(theorem.roles.control_names)
    for name in controls:
        if name not in assigned and name not in inputs:
            raise ExtractError(f"{theorem.name}: roles name `{name}` in controls, but the control step never "
                               f"sets it; set it in the step (`{name} := ...`) or remove it from controls")
    for name in inputs:  # `x := *` in the step that nothing pins down: a choice nobody declared
        if name not in controls and name in plant_reads:
            raise ExtractError(f"{theorem.name}: the control step chooses `{name} := *`, which the plant "
                               f"reads, but roles do not say who chooses it; add `{name}` to environment "
                               "(the world chooses it) or to controls")
    for name in assigned:
        if name in controls or name in plant_init:
            continue
        if name in plant_reads or name in latches:
            who = "the plant" if name in plant_reads else "the next step"
            raise ExtractError(f"{theorem.name}: the control step sets `{name}`, which {who} reads, but "
                               f"roles do not name it a control; add `{name}` to controls")
    return controls

