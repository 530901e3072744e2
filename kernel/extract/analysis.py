"""Reading the model: which part of the program is the control step. `split` finds the
control loop's plant (one ODE, a choice of ODE modes, or none for an algorithm) and the
statements before or after it, with what the plant, the invariant and the guarantee read;
`step_outputs` picks the values the step must return; `controller` gives the step as a program.
Also the syntax queries both code emitters share: conjuncts, reads, `for`-loop shapes, family
index sorts, and the choice of plant modes rewritten as a choice of rate assignments."""

from __future__ import annotations

from dataclasses import dataclass, field

from certiloop.kernel.extract import environment as declared
from certiloop.kernel.extract.errors import ExtractError, brief, refuse
from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import BOOL, INT, REAL, Node, Var, free_vars
from certiloop.models.lang.theorem import Theorem


def conjuncts(f: Node) -> list[Node]:
    if f.op == "and":
        return [a for x in f.args for a in conjuncts(x)]
    return [f]


def mentions(atom: Node, name: str) -> bool:
    if atom.op == "var":
        return atom.payload == name
    if atom.op == "select":
        return atom.args[0].payload == name or any(mentions(a, name) for a in atom.args[1:])
    return any(mentions(a, name) for a in atom.args)


def is_index_sort(sort) -> bool:
    return not sort.is_numeric and sort != BOOL and not sort.is_array


def seq_parts(p: Program) -> list[Program]:
    return list(p.parts) if isinstance(p, Seq) else [p]


def for_range_at(parts: list[Program], k: int) -> tuple[str, Node, Node, list[Program]] | None:
    """`i := lo; {?i < hi; body; i := i + 1}*; ?i >= hi` at parts[k]: (i, lo, hi, body)."""
    if k + 2 >= len(parts):
        return None
    init, loop, exit_ = parts[k: k + 3]
    if not (isinstance(init, Assign) and init.target.op == "var" and init.target.sort == INT
            and isinstance(loop, Loop) and isinstance(exit_, Test) and isinstance(loop.body, Seq)):
        return None
    var = init.target
    steps = loop.body.parts
    first, last = steps[0], steps[-1]
    if not (isinstance(first, Test) and first.cond.op == "cmp" and first.cond.payload == "<"
            and first.cond.args[0].key == var.key):
        return None
    hi = first.cond.args[1]
    if not (isinstance(last, Assign) and last.target.key == var.key and last.value.key == (var + 1).key):
        return None
    if exit_.cond.key != (var >= hi).key:
        return None
    return var.payload, init.value, hi, list(steps[1:-1])


def reads_of(p: Program, skip: set[int] = frozenset()) -> set[str]:
    """Names a program reads at run time (values, tests, cell indices, ODEs)."""
    if id(p) in skip:
        return set()
    out: set[str] = set()
    if isinstance(p, (Assign, Havoc)):
        if p.target.op == "select":
            for a in p.target.args[1:]:
                out |= set(free_vars(a))
        if isinstance(p, Assign):
            out |= set(free_vars(p.value))
    elif isinstance(p, Test):
        out |= set(free_vars(p.cond))
    elif isinstance(p, ODE):
        for v, f in p.eqs:
            out |= {v.payload, *free_vars(f)}
        out |= set(free_vars(p.domain))
    elif isinstance(p, (Seq, Choice)):
        for q in p.parts if isinstance(p, Seq) else p.alternatives:
            out |= reads_of(q, skip)
    elif isinstance(p, Loop):
        out |= reads_of(p.body, skip)
    return out


def mode_choice(plant: Choice, symbols: dict[str, Node]) -> tuple[Choice, list[str]]:
    """The choice of plant modes as a choice of rate assignments: each mode's domain is its
    test, its right-hand sides the rates `x_dot` (of the variables the modes set differently)."""
    odes = [seq_parts(alt)[-1] for alt in plant.alternatives]
    names = [tuple(v.payload for v in ode.variables) for ode in odes]
    if len(set(map(frozenset, names))) != 1:
        raise refuse(plant, "its modes evolve different variables")
    rhs = [{v.payload: f for v, f in ode.eqs} for ode in odes]
    varying = [v for v in names[0] if len({r[v].key for r in rhs}) > 1] or list(names[0])
    rates = {v: f"{v}_dot" for v in varying}
    for r in rates.values():
        if r in symbols:
            raise ExtractError(f"the rate name `{r}` is a symbol of the model; cannot extract")
    alts = []
    for alt, ode, r in zip(plant.alternatives, odes, rhs):
        pre = seq_parts(alt)[:-1]
        alts.append(Seq((*pre, Test(ode.domain), *(Assign(Var(rates[v], REAL), r[v]) for v in varying))))
    return Choice(tuple(alts), plant.labels), list(rates.values())


@dataclass
class Step:
    parts: list[Program]  # the step's statements
    where: str  # "before" | "after" | "modes" (the plant) | "algorithm" (no plant)
    plant: Program | None  # the ODE, the choice of modes, or None
    reads: set[str]  # what the plant, the loop invariant and the guarantee read
    plant_reads: set[str]  # what the plant alone reads
    # with declared roles (theorem.roles): the environment's statements (its `x := *` and the
    # tests on them), out of the step; and what the plant's mode initialisation sets
    environment: list[Program] = field(default_factory=list)
    plant_init: set[str] = field(default_factory=set)


def _has_ode(p: Program) -> bool:
    if isinstance(p, ODE):
        return True
    parts = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else \
        (p.body,) if isinstance(p, Loop) else ()
    return any(_has_ode(q) for q in parts)


def _is_modes(p: Program) -> bool:
    """A choice whose every alternative ends in an ODE (with no other ODE): plant modes."""
    if not isinstance(p, Choice):
        return False
    for alt in p.alternatives:
        parts = seq_parts(alt)
        if not isinstance(parts[-1], ODE) or any(_has_ode(q) for q in parts[:-1]):
            return False
    return True


def split(theorem: Theorem) -> Step:
    """The control step; with declared roles, the controller's part of it (`roles`)."""
    if theorem.roles is None:
        return _split(theorem)
    declared.check_declaration(theorem)
    step = _split(theorem)
    declared.check_chosen(theorem, step.environment)
    step.reads |= set(theorem.roles.control_names)  # the outputs: every path's value is kept
    return step


def _split(theorem: Theorem) -> Step:
    p = theorem.program
    guarantee = set(free_vars(theorem.guarantee))
    if not _has_ode(p):
        if isinstance(p, Loop):
            raise refuse(p, "a loop with no plant and no exit test repeats any number of times: there is "
                          "no control step or algorithm result to extract")
        if theorem.roles is not None:
            parts, environment = declared.separate(theorem, seq_parts(p))
            return Step(parts, "algorithm", None, guarantee, set(), environment)
        return Step(seq_parts(p), "algorithm", None, guarantee, set())
    if not isinstance(p, Loop):
        raise ExtractError(f"cannot extract `{brief(p)}`: the program has a plant ODE but is not a control "
                           "loop `{step; plant}*`")
    body = seq_parts(p.body)
    plants = [k for k, q in enumerate(body) if isinstance(q, ODE) or _is_modes(q)]
    if len(plants) != 1:
        nested = next((q for q in body if _has_ode(q) and not (isinstance(q, ODE) or _is_modes(q))), None)
        if nested is not None:
            raise refuse(nested, "the plant ODE is nested in this statement; only `{step; plant}*`, "
                          "`{plant; step}*` and a choice of ODE modes are extracted")
        raise ExtractError(f"cannot extract `{brief(p)}`: the control loop has {len(plants)} plant ODEs; "
                           "expected one")
    k = plants[0]
    before, after, plant = list(body[:k]), list(body[k + 1:]), body[k]
    if any(_has_ode(q) for q in before + after):
        second = next(q for q in before + after if _has_ode(q))
        raise refuse(second, "a second plant ODE in the control loop")
    environment: list[Program] = []
    if theorem.roles is not None:  # the environment's choices leave the step
        before, env_before = declared.separate(theorem, before)
        after, env_after = declared.separate(theorem, after)
        environment = env_before + env_after
    if isinstance(plant, ODE):
        # the plant's initialisation (clock resets t := 0) right before the ODE belongs to it
        flows = {v.payload for v in plant.variables}
        while before and isinstance(before[-1], Assign) and before[-1].target.op == "var" \
                and before[-1].target.payload in flows:
            before.pop()
    plant_reads = reads_of(plant)
    if isinstance(plant, ODE):
        plant_reads |= {v.payload for v in plant.variables}
    reads = plant_reads | guarantee
    if p.invariant is not None:
        reads |= set(free_vars(p.invariant))
    if _is_modes(plant):
        if after:
            raise refuse(after[0], "statements after a choice of plant modes")
        if theorem.roles is not None:  # the controller picks a mode and sets the controls
            modes, init = declared.switched_controller(theorem, plant)
            odes = [seq_parts(alt)[-1] for alt in plant.alternatives]
            flow_reads = set().union(*(reads_of(ode) | {v.payload for v in ode.variables} for ode in odes))
            return Step([*before, modes], "switched", plant, reads, flow_reads, environment, init)
        return Step(before, "modes", plant, reads, plant_reads)
    if before and after:
        raise refuse(after[0], "discrete statements both before and after the plant ODE: which state the "
                      "step reads is ambiguous")
    if not before and not after:
        raise ExtractError(f"cannot extract `{brief(p)}`: the control loop has no discrete step, only the "
                           "plant")
    return Step(before or after, "before" if before else "after", plant, reads, plant_reads, environment)


def step_outputs(theorem: Theorem, step: Step, assigned: list[str], inputs: list[str],
             tested: set[str], latches: set[str] = frozenset()) -> list[str]:
    """What the step computes that the plant reads, then what only the invariant or the
    guarantee read; failing that, the commands it admits (inputs the plant reads and a
    test checks). With declared roles: exactly the declared controls."""
    if theorem.roles is not None:
        return declared.checked_outputs(theorem, step.plant_reads, step.plant_init, assigned, inputs, latches)
    outputs = [v for v in assigned if v in step.plant_reads]
    outputs += [v for v in assigned if v in step.reads and v not in outputs]
    if not outputs:
        outputs = [v for v in inputs if v in step.plant_reads and v in tested]
    if not outputs:
        what = "algorithm" if step.where == "algorithm" else "control step"
        raise ExtractError(f"{theorem.name}: the {what} "
                           "computes nothing the plant, the invariant or the guarantee reads; nothing to "
                           "extract")
    return outputs


def sort_of(theorem: Theorem, name: str, default):
    symbols = {**free_vars(theorem.assumptions), **theorem.program.symbols(), **free_vars(theorem.guarantee)}
    return symbols[name].sort if name in symbols else default


def uses_families(parts: list[Program]) -> bool:
    if any(isinstance(q, Loop) and q.each is not None for q in parts):
        return True
    symbols = Seq(tuple(parts)).symbols() if parts else {}
    return any(s.sort.is_array and any(is_index_sort(d) for d in s.sort.domain) for s in symbols.values())


def families_only_tested(parts: list[Program]) -> bool:
    """No foreach and no family written: the families are only read, under `∀j` in tests
    (raven.deviation_stop_3d); the scalar code evaluates those over numpy arrays."""
    from certiloop.models.lang.programs import written

    if any(isinstance(q, Loop) and q.each is not None for q in parts):
        return False
    step = Seq(tuple(parts))
    return not any(s.sort.is_array and any(is_index_sort(d) for d in s.sort.domain)
                   for s in written(step).values())


def controller(theorem: Theorem, inputs: bool = True) -> Program:
    """The control step as a program: the control loop's statements before the plant (after
    it, for a loop that runs its plant first; with the choice of modes, for a switched
    plant; the whole program, for an algorithm); without the statements that read its
    scalar inputs (`fxp := *`) if inputs is False."""
    from certiloop.models.lang.programs import seq

    step = split(theorem)
    body = list(step.parts) + ([step.plant] if step.where == "modes" else [])
    if not inputs:
        body = [q for q in body if not (isinstance(q, Havoc) and q.target.op == "var"
                                        and not q.target.sort.is_array)]
    return seq(*body)
