"""ModelPlex-style runtime monitors generated from a proved model (`certiloop extract MODEL
--monitors`): a separate module, next to the extracted controller, with two functions.

`controller_monitor(state, command, tol=0.0) -> bool` — does `command` (a dict of the
controller's outputs) come out of some run of the model's control step from `state` (a dict
of the extracted controller's parameters: the pre-state and the measured inputs)? The step
is turned into one program whose runs are exactly the step's runs that end on the command:
    step; ?(out_1 ≈ cmd_1 ∧ ... ∧ out_n ≈ cmd_n)        (≈: |out − cmd| <= tol for reals)
wrapped in a single choice, so that the scalar emitter flattens every nested choice into a
path and tries every path (not only the first enabled one): the monitor says True iff some
path's tests, the solved roots of its equations included, hold and its outputs match. A
nondeterministic `o := *` of an output inside the step is the existential the command fixes
(`o := cmd_o`); other `x := *` are solved from the equations that pin them (every root is
a path) or, where only inequalities read them, are state the caller gives, as for the
extracted controller. tol = 0 admits exactly the model's real value, or the float the
extracted controller returns for it (the largest float at most it); tol > 0 also admits a
command within tol of the real value; Int and Bool values compare exactly (1.5 is no Int).
Guards are decided as in the extracted controller (`certiloop.kernel.decide`): the real
model's decision on the float values, so rounding never admits a command; the module carries
that runtime's source (it imports nothing of certiloop). An output the step pins by an
equation is solved from it and matched with the command like any other output.
A step over a family of boundaries (`foreach` with `k := min(k, kt)`) has its own monitor
(modelplex_family.py): the boundaries' choices are independent, so k passes iff no boundary
forces kt below k − tol and k0 or some boundary can give k within tol; its decisions are
float-sound in the same way. A step that reads
families only under `∀j` tests is scalar code with `np.all` over the arrays.
A step whose choices are all if/else (deterministic) but that has `for` loops (an algorithm
such as cfmpa.builtdr) has exactly one run: there the monitor runs the extracted controller
and compares its outputs (arrays cell by cell) with the command.

`plant_monitor(prev_state, next_state, dt, tol) -> bool` — does the observed evolution over
`dt` seconds fit the model's plant? `prev_state` holds the state when the flow starts (after
the control step: the controller's outputs, the constants the ODE reads, the evolved
variables); the plant's own initialisation (a clock reset `t := 0`) is applied here.
Checked, for one ODE or any mode of a switched plant:
  * dt >= 0, and every value finite;
  * the evolution domain holds at the start and at the end (not in between: sampled
    observations cannot show that);
  * if the ODE has a polynomial solution (the proof core's `flow_solution`, differentiated
    back there), every evolved variable given in next_state is within tol of the solution
    at dt (absolute); a variable not given (a clock) takes the solution's value;
  * otherwise an a-priori enclosure (Picard–Lindelöf) over 16 substeps of length h: from the
    interval X reached so far, a box B with X + [0, h]·F(B) ⊆ B (found by epsilon inflation,
    F evaluated in interval arithmetic rounded outwards) encloses the flow over the substep,
    and X + h·F(B) its end; every evolved variable given must lie within tol of the final
    interval (first order: wide for long or stiff steps, a coarse but sound check up to the
    float evaluation of the bounds). If no such box is found in a few inflations, the
    monitor says False (it cannot vouch for the step).
Models without a plant (algorithms, Hoare triples) have no plant monitor.

`environment_monitor(state) -> bool` — only for a model with declared roles: the environment's
values satisfy the model's tests on them (modelplex_environment.py).

Monitors come only from the model's syntax tree; nothing is written by hand per model. A shape
they cannot be generated for is refused with a one-line MonitorError naming why.
"""

from __future__ import annotations

from certiloop.kernel.extract.analysis import (
    Step,
    families_only_tested,
    mode_choice,
    reads_of,
    seq_parts,
    split,
    step_outputs,
    uses_families,
)
from certiloop.kernel.extract.errors import ExtractError, brief
from certiloop.kernel.extract.generate import extract
from certiloop.kernel.extract.modelplex_environment import environment_monitor
from certiloop.kernel.extract.modelplex_family import family_controller_monitor
from certiloop.kernel.extract.monitor_terms import (
    MonitorError,
    fresh,
    numpy_conversion,
    term,
    theorem_symbols,
)
from certiloop.kernel.extract.scalar import KIT, STEP, Python
from certiloop.kernel.extract.shapes import latched_scalars
from certiloop.kernel.extract.template import doc_text
from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test, written
from certiloop.models.lang.terms import BOOL, INT, REAL, And, ModelError, Node, Var, free_vars
from certiloop.models.lang.theorem import Theorem

HEADER = '''"""Generated by `certiloop extract {model} --monitors` — do not edit; re-extract instead.

ModelPlex-style monitors of `{model}` ({description}), generated from the model's syntax tree
(see certiloop/kernel/extract/modelplex.py for exactly what each one checks):
  controller_monitor(state, command, tol=0.0) -> bool: some run of the control step from
      `state` (keys STATE) ends with `command` (keys COMMAND; reals within tol);
  plant_monitor(prev_state, next_state, dt, tol) -> bool: the observed evolution fits the
      plant ODE: domain at both ends, {plant_how}.
{environment_doc}"""

import math
import types

import numpy as np

MODEL = {model_name!r}
MODEL_HASH = {hash!r}  # the model's content hash when this code was generated
STATE = {state!r}
COMMAND = {command!r}
PLANT_STATE = {plant_state!r}  # evolved variables (plant_monitor)
PLANT_PARAMS = {plant_params!r}  # values the plant reads that it does not evolve
{environment_header}'''

ENVIRONMENT_DOC = """  environment_monitor(state) -> bool: the environment's values in `state` (keys
      ENVIRONMENT_STATE) satisfy the model's assumptions about them (ENVIRONMENT_ASSUMPTIONS).
"""


def monitors(theorem: Theorem) -> str:
    """Python source of the monitor module of a model whose controller extracts (a symbol named
    like a Python keyword or a generated name is renamed as in the controller: names.py)."""
    from certiloop.kernel.extract.names import generate_renamed, python_unsafe

    return generate_renamed(theorem, python_unsafe, _monitors)


def _monitors(theorem: Theorem) -> str:
    try:
        step = split(theorem)
        src_controller = extract(theorem)
        state, command, ctrl_code = _controller_monitor(theorem, step, src_controller)
        plant_state, plant_params, plant_code, plant_how = _plant_monitor(theorem, step)
        env_header, env_code = "", ""
        if theorem.roles is not None:
            _, env_header, env_code = environment_monitor(theorem, step)
    except ModelError as exc:  # ExtractError, MonitorError: one line that names the model
        message = " ".join(str(exc).split())
        if not message.startswith(f"{theorem.name}:"):
            message = f"{theorem.name}: {message}"
        raise (MonitorError if isinstance(exc, MonitorError) else ExtractError)(message) from None
    src = HEADER.format(model=doc_text(theorem.name), model_name=theorem.name,
                        description=doc_text(theorem.description), hash=theorem.content_hash,
                        state=state, command=command, plant_state=plant_state, plant_params=plant_params,
                        plant_how=plant_how, environment_doc=ENVIRONMENT_DOC if env_code else "",
                        environment_header=env_header)
    runtime = RUNTIME + (_decide_runtime() if "_decide." in ctrl_code + env_code else "")
    env_code = env_code and env_code + "\n"
    return src + "\n" + ctrl_code + "\n" + env_code + plant_code + "\n" + runtime


def _decide_runtime() -> str:
    """The float-sound decisions' runtime (certiloop.kernel.decide: numpy and the standard
    library only), carried in the monitor module so that it imports nothing of certiloop."""
    import inspect

    from certiloop.kernel import decide

    source = inspect.getsource(decide)
    assert "'''" not in source and "\\" not in source  # it fits in a raw triple-quoted string
    return ("\n\n# certiloop.kernel.decide, the runtime of the controller monitor's decisions\n"
            "_DECIDE_SOURCE = r'''" + source + "'''\n"
            "_decide = types.ModuleType('_decide')\n"
            "exec(compile(_DECIDE_SOURCE, '<certiloop.kernel.decide>', 'exec'), _decide.__dict__)\n")


# --------------------------------------------------------------------------- controller monitor


def _assigned_names(p: Program) -> set[str]:
    out: set[str] = set()
    if isinstance(p, Assign):
        out.add(p.target.payload if p.target.op == "var" else p.target.args[0].payload)
    for q in (p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else
              (p.body,) if isinstance(p, Loop) else ()):
        out |= _assigned_names(q)
    return out


def _scalar_outputs(theorem: Theorem, step: Step) -> tuple[list[Program], list[str], dict[str, Node]]:
    """The step's statements (with the mode choice for a switched plant), its outputs as the
    extracted controller returns them, and the symbols (rates included)."""
    parts = list(step.parts)
    symbols = theorem_symbols(theorem)
    live = set(step.reads)
    if step.where == "modes":
        modes, rates = mode_choice(step.plant, symbols)
        symbols.update((r, Var(r, REAL)) for r in rates)
        return parts + [modes], rates, symbols
    py = Python(symbols, live, Seq(tuple(parts)) if parts else Test(Node("true", (), BOOL)))
    py.block(parts)
    latches = latched_scalars(parts, py.params) if step.where in ("before", "after") else set()
    if latches - live:
        live |= latches
        py = Python(symbols, live, Seq(tuple(parts)))
        py.block(parts)
    outputs = step_outputs(theorem, step, list(py.assigned), list(py.inputs), py.tested, latches)
    outputs += [v for v in py.assigned if v in latches and v not in outputs]
    return parts, outputs, symbols


def _has_loop(p: Program) -> bool:
    if isinstance(p, Loop):
        return not (isinstance(p.body, Test) and p.body.cond.op == "true")
    parts = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else ()
    return any(_has_loop(q) for q in parts)


def _deterministic(p: Program, top: bool = True) -> bool:
    """Every choice an if/else (`?c; a ∪ ?¬c; b`), no `x := *` but top-level inputs."""
    if isinstance(p, Havoc):
        return top and p.target.op == "var" and not p.target.sort.is_array
    if isinstance(p, Choice):
        if len(p.alternatives) != 2:
            return False
        first = [seq_parts(a)[0] for a in p.alternatives]
        if not all(isinstance(f, Test) for f in first):
            return False
        c0, c1 = first[0].cond, first[1].cond
        if not (c1.op == "not" and c1.args[0].key == c0.key or c0.op == "not" and c0.args[0].key == c1.key):
            return False
        return all(_deterministic(a, False) for a in p.alternatives)
    if isinstance(p, Seq):
        return all(_deterministic(q, top) for q in p.parts)
    if isinstance(p, Loop):
        return _deterministic(p.body, False)
    return True


def _controller_monitor(theorem: Theorem, step: Step, controller_src: str) -> tuple[list, list, str]:
    if uses_families(step.parts) and not families_only_tested(step.parts):
        return family_controller_monitor(theorem, step, controller_src)
    parts, outputs, symbols = _scalar_outputs(theorem, step)
    if _has_loop(Seq(tuple(parts))):
        if not _deterministic(Seq(tuple(parts))):
            raise MonitorError("the step has loops and nondeterministic choices: no monitor")
        return _rerun_monitor(controller_src, outputs)
    taken = set(symbols) | {"tol", "state", "command", "math", "np", KIT, "_decide", "_controller_monitor"}
    tol = fresh(taken, "tol")
    cmd = {o: fresh(taken, f"cmd_{o}") for o in outputs}
    # leading `x := *` that no earlier statement touches: the controller's inputs (hoisted)
    hoisted, rest, touched = [], [], set()
    assigned_anywhere = _assigned_names(Seq(tuple(parts)))
    for q in parts:
        if isinstance(q, Havoc) and q.target.op == "var" and not q.target.sort.is_array \
                and q.target.payload not in touched:
            name = q.target.payload
            if name in cmd and name not in assigned_anywhere and not _pinned(Seq(tuple(parts)), name):
                rest.append(Assign(q.target, Var(cmd[name], q.target.sort)))  # fixed by the output
            elif name in cmd and name not in assigned_anywhere:
                rest.append(q)  # solved from its equation, then matched with the command
            else:
                hoisted.append(q)
            continue
        rest.append(_fix_output_havocs(q, {o: c for o, c in cmd.items()
                                           if not _pinned(Seq(tuple(parts)), o)}))
        touched |= set(written(q)) | reads_of(q)
    match, closes = [], {}
    for o in outputs:
        s = symbols[o].sort
        if s.is_array:
            raise MonitorError(f"the output `{o}` is an array and the step is not deterministic: no monitor")
        o_var, c_var = Var(o, s), Var(cmd[o], s)
        if s == REAL:  # |o - c| <= tol in the reals, or c the float the controller returns for o
            atom = o_var - c_var <= Var(tol, REAL)
            closes[atom.key] = (o_var, c_var, Var(tol, REAL))
            match.append(atom)
        else:
            match.append(o_var == c_var)
    body = Seq((*rest, Test(And(*match))))
    program = [*hoisted, Choice((body,), ("step",))]
    live = set(outputs) | {"__ok"}
    py = Python({**symbols, tol: Var(tol, REAL), **{c: Var(c, symbols[o].sort) for o, c in cmd.items()}},
                 live, Seq(tuple(program)))
    py.kit, py.closes = KIT, closes
    try:
        py.block(program)
    except ExtractError as exc:
        raise MonitorError(f"no controller monitor: {exc}") from None
    state = [p for p in py.params if p not in cmd.values() and p != tol]
    lines = ["def controller_monitor(state, command, tol=0.0):",
             '    """True iff some run of the control step from `state` ends with `command` (reals',
             "    within tol in the reals, or the float the extracted controller returns). state: a dict",
             "    with the keys STATE; command: a dict with the keys COMMAND. Every decision is the real",
             "    model's on these float values (exact rationals): floats with a rigorous error bound,",
             '    exact rationals where the bound cannot decide; undecidable there: False."""',
             "    return _decide.run(_controller_monitor, False, state, command, tol)",
             "",
             "",
             f"def _controller_monitor({KIT}, state, command, tol):",
             f"    {tol} = {KIT}.real(tol)",
             f"    if not ({tol} >= {KIT}.c(0)):",
             "        return False"]
    entries = [(v, f"state[{v!r}]", symbols[v].sort) for v in state]
    entries += [(c, f"command[{o!r}]", symbols[o].sort) for o, c in cmd.items()]
    for v, source, sort in entries:
        if sort in (INT, BOOL):  # exactly an integer (a truth value): 1.5 is no Int command
            lines.append(f"    {v} = _exact({source}, {'int' if sort == INT else 'bool'})")
            lines.append(f"    if {v} is None:")
            lines.append("        return False")
            continue
        # a non-finite real is outside the model's domain: no run, False
        real = sort == REAL or sort.is_array and sort.range == REAL
        conv = (KIT + ".real" if sort == REAL else KIT + ".array") if real else numpy_conversion(sort)
        lines.append(f"    {v} = {conv}({source})")
    lines.append("    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):")
    blocked = "return False"
    for text in py.lines:
        lines.append(text.replace("return __BLOCKED__", blocked))
    lines.append("    return True")
    return state, outputs, "\n".join(lines) + "\n"


def _pinned(p: Program, name: str) -> bool:
    """Some test of the step pins `name` by an equation (`?x = th + u*dt`): its value is solved
    from it (exactly, in the reals), and the command is matched with that value within tol."""
    from certiloop.kernel.extract.analysis import conjuncts, mentions

    if isinstance(p, Test):
        return any(a.op == "cmp" and a.payload == "==" and mentions(a, name) for a in conjuncts(p.cond))
    parts = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else ()
    return any(_pinned(q, name) for q in parts)


def _fix_output_havocs(p: Program, cmd: dict[str, str]) -> Program:
    """`o := *` of an output inside the step becomes `o := cmd_o`: the existential the command
    fixes (a particular value of it: if the run passes, it is a run of the model)."""
    if isinstance(p, Havoc) and p.target.op == "var" and p.target.payload in cmd:
        return Assign(p.target, Var(cmd[p.target.payload], p.target.sort))
    if isinstance(p, Seq):
        return Seq(tuple(_fix_output_havocs(q, cmd) for q in p.parts))
    if isinstance(p, Choice):
        return Choice(tuple(_fix_output_havocs(q, cmd) for q in p.alternatives), p.labels)
    return p


def _rerun_monitor(controller_src: str, outputs: list[str]) -> tuple[list, list, str]:
    """A deterministic step with loops: one run, the extracted controller's."""
    import ast

    tree = ast.parse(controller_src)
    fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "controller")
    params = [a.arg for a in fn.args.args]
    source = ast.get_source_segment(controller_src, fn)
    for helper in tree.body:  # the one pass the entry runs with each number kit
        if isinstance(helper, ast.FunctionDef) and helper.name == STEP:
            source += "\n\n\n" + ast.get_source_segment(controller_src, helper)
    imports = "import operator\n\n" if "operator." in source else ""
    lines = [imports + source.replace("def controller(", "def _controller(", 1), "",
             "def controller_monitor(state, command, tol=0.0):",
             '    """True iff the command is what the (deterministic) step computes from state: its',
             "    only run. Reals and arrays of reals within tol, the rest exactly.\"\"\"",
             f"    *values, enabled = _controller(*[state[k] for k in {params!r}])",
             "    if not enabled or not (tol >= 0.0):",
             "        return False",
             f"    for name, value in zip({outputs!r}, values):",
             "        if not _close(value, command[name], tol):",
             "            return False",
             "    return True"]
    return params, outputs, "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- plant monitor


def _plant_modes(theorem: Theorem, step: Step) -> list[tuple[list[Assign], ODE]]:
    """Each mode of the plant: its initialisation (clock resets) and its ODE."""
    if step.plant is None:
        return []
    if isinstance(step.plant, ODE):
        body = seq_parts(theorem.program.body)
        k = body.index(step.plant)
        flows = {v.payload for v in step.plant.variables}
        init: list[Assign] = []
        j = k - 1
        while j >= 0 and isinstance(body[j], Assign) and body[j].target.op == "var" \
                and body[j].target.payload in flows:
            init.insert(0, body[j])
            j -= 1
        return [(init, step.plant)]
    modes = []
    for alt in step.plant.alternatives:
        parts = seq_parts(alt)
        pre = parts[:-1]
        if step.where == "switched":  # the controller's statements are its; the plant's: clock resets
            flows = {v.payload for v in parts[-1].variables}
            k = len(pre)
            while k and isinstance(pre[k - 1], Assign) and pre[k - 1].target.op == "var" \
                    and pre[k - 1].target.payload in flows:
                k -= 1
            pre = pre[k:]
        if any(not (isinstance(q, Assign) and q.target.op == "var") for q in pre):
            raise MonitorError(f"the plant mode `{brief(alt)}` does more than initialise its ODE")
        modes.append((list(pre), parts[-1]))
    return modes


def _plant_monitor(theorem: Theorem, step: Step) -> tuple[list, list, str, str]:
    from certiloop.proofs.core.wp import flow_solution

    modes = _plant_modes(theorem, step)
    if not modes:
        code = ("def plant_monitor(prev_state, next_state, dt, tol):\n"
                '    """The model has no plant (a Hoare triple): no evolution to check."""\n'
                "    raise NotImplementedError(MODEL + ' has no plant ODE')\n")
        return [], [], code, "none (the model has no plant)"
    evolved: dict[str, None] = {}
    params: dict[str, None] = {}
    mode_fns, hows = [], set()
    for n, (init, ode) in enumerate(modes):
        names = [v.payload for v in ode.variables]
        evolved.update(dict.fromkeys(names))
        reads = set()
        for _, f in ode.eqs:
            reads |= set(free_vars(f))
        reads |= set(free_vars(ode.domain))
        for a in init:
            reads |= set(free_vars(a.value))
        params.update(dict.fromkeys(sorted(r for r in reads if r not in names)))
        s, sol = flow_solution(ode)
        lines = [f"def _mode{n}(x0, x1, dt, tol):",
                 f'    """{brief(ode, 86)}"""',
                 "    s0 = dict(x0)"]
        for a in init:
            lines.append(f"    s0[{a.target.payload!r}] = {term(a.value, 's0')}")
        lines.append(f"    if not {term(ode.domain, 's0')}:")
        lines.append("        return False")
        lines.append("    s1 = dict(s0)")
        if sol is not None:
            hows.add("closed-form solution within tol")
            env = "e"
            lines.append(f"    {env} = dict(s0)")
            lines.append(f"    {env}[{s.payload!r}] = dt")
            for name in names:
                lines.append(f"    want = {term(sol[name], env)}")
                lines.append(f"    if {name!r} in x1:")
                lines.append(f"        if not (abs(float(x1[{name!r}]) - want) <= tol):")
                lines.append("            return False")
                lines.append(f"        s1[{name!r}] = float(x1[{name!r}])")
                lines.append("    else:")
                lines.append(f"        s1[{name!r}] = want")
        else:
            hows.add("interval enclosure (16 substeps) within tol")
            lines.append(f"    names = {names!r}")
            lines.append("    def rates(box):")
            lines.append("        b = {k: (v, v) for k, v in s0.items()}")
            lines.append("        b.update(box)")
            rates = ", ".join(f"{v.payload!r}: {_iterm(f, 'b')}" for v, f in ode.eqs)
            lines.append("        return {" + rates + "}")
            lines.append("    reach = _enclosure(s0, names, rates, dt)")
            lines.append("    if reach is None:")
            lines.append("        return False")
            lines.append("    for name in names:")
            lines.append("        lo, hi = reach[name]")
            lines.append("        if name in x1:")
            lines.append("            got = float(x1[name])")
            lines.append("            if not (lo - tol <= got <= hi + tol):")
            lines.append("                return False")
            lines.append("            s1[name] = got")
            lines.append("        elif hi - lo <= 1e-12 * (1.0 + abs(lo)):  # a clock: its rate is exact")
            lines.append("            s1[name] = 0.5 * (lo + hi)")
            lines.append("        else:")
            lines.append("            return False  # a variable the observation lacks and the enclosure "
                         "cannot pin")
        lines.append(f"    return bool({term(ode.domain, 's1')})")
        mode_fns.append("\n".join(lines) + "\n")
    calls = " or ".join(f"_mode{n}(prev_state, next_state, dt, tol)" for n in range(len(modes)))
    code = "\n\n".join(mode_fns) + "\n\n" + "\n".join([
        "def plant_monitor(prev_state, next_state, dt, tol):",
        '    """True iff evolving prev_state for dt seconds can give next_state (evolved values',
        "    within tol) in " + ("some mode of the plant" if len(modes) > 1 else "the plant ODE") + ". "
        "prev_state: PLANT_STATE and PLANT_PARAMS;",
        '    next_state: the evolved variables observed (a clock may be left out)."""',
        "    if not (dt >= 0.0 and tol >= 0.0) or not all(math.isfinite(float(v)) for v in "
        "(*prev_state.values(), *next_state.values())):",
        "        return False",
        "    prev_state = {k: float(v) for k, v in prev_state.items()}",
        "    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):",
        f"        return bool({calls})",
    ]) + "\n"
    return list(evolved), list(params), code, " or ".join(sorted(hows))


def _iterm(n: Node, env: str) -> str:
    """A real term in interval arithmetic (rounded outwards) over the dict of intervals `env`."""
    op = n.op
    if op == "const":
        v = float(n.payload)
        return f"_iconst({v!r})" if float(n.payload) != n.payload else f"({v!r}, {v!r})"
    if op == "var":
        return f"{env}[{n.payload!r}]"
    a = [_iterm(x, env) for x in n.args]
    if op == "+":
        out = a[0]
        for x in a[1:]:
            out = f"_iadd({out}, {x})"
        return out
    if op == "*":
        out = a[0]
        for x in a[1:]:
            out = f"_imul({out}, {x})"
        return out
    if op == "neg":
        return f"_ineg({a[0]})"
    if op == "/":
        return f"_idiv({a[0]}, {a[1]})"
    if op == "^":
        return f"_ipow({a[0]}, {n.payload})"
    raise MonitorError(f"cannot enclose `{brief(n)}`: not an arithmetic term")


# helpers every generated monitor module carries (plain Python + numpy: no certiloop import)
RUNTIME = '''
def _exact(x, kind):
    """x as an int (bool) if it is exactly one, else None."""
    if isinstance(x, (bool, np.bool_)):
        return bool(x) if kind is bool else None
    try:
        f = float(x)
    except (TypeError, ValueError):
        return None
    if not f.is_integer() or (kind is bool and f not in (0.0, 1.0)):
        return None
    return kind(int(f))


def _div(a, b):
    return a / b if b != 0 else math.nan


def _close(value, want, tol):
    value, want = np.asarray(value), np.asarray(want)
    if value.shape != want.shape:
        return False
    if value.dtype.kind == "f" or want.dtype.kind == "f":
        return bool(np.all(np.abs(value.astype(float) - want.astype(float)) <= tol))
    return bool(np.array_equal(value, want))


def _down(x):
    return math.nextafter(float(x), -math.inf)


def _up(x):
    return math.nextafter(float(x), math.inf)


def _iconst(v):
    return (_down(v), _up(v))


def _iadd(a, b):
    return (_down(a[0] + b[0]), _up(a[1] + b[1]))


def _ineg(a):
    return (-a[1], -a[0])


def _imul(a, b):
    ps = [a[0] * b[0], a[0] * b[1], a[1] * b[0], a[1] * b[1]]
    if any(math.isnan(p) for p in ps):
        return (-math.inf, math.inf)
    return (_down(min(ps)), _up(max(ps)))


def _idiv(a, b):
    if b[0] <= 0.0 <= b[1]:
        return (-math.inf, math.inf)
    return _imul(a, (_down(1.0 / b[1]), _up(1.0 / b[0])))


def _ipow(a, n):
    out = (1.0, 1.0)
    for _ in range(n):
        out = _imul(out, a)
    if n % 2 == 0 and out[0] < 0.0:
        out = (0.0, out[1])
    return out


def _enclosure(s0, names, rates, dt, steps=16, tries=12):
    """x(dt) for all solutions from s0: an interval per evolved variable, or None. Over each of
    `steps` substeps of length h, a box B with X + [0, h]*F(B) inside B encloses the flow from
    the interval X (Picard-Lindelof), and X + h*F(B) the state at its end."""
    h = (_down(dt / steps), _up(dt / steps))  # contains the true dt/steps
    x = {n: (s0[n], s0[n]) for n in names}
    for _ in range(steps):
        box = {n: (lo - 1e-12 * (1.0 + abs(lo)), hi + 1e-12 * (1.0 + abs(hi))) for n, (lo, hi) in x.items()}
        for _ in range(tries):
            f = rates(box)
            reach = {n: _iadd(x[n], _imul((0.0, h[1]), f[n])) for n in names}
            if all(box[n][0] <= reach[n][0] and reach[n][1] <= box[n][1] for n in names):
                break
            # the next candidate: what this box reached, widened by a tenth (epsilon inflation)
            box = {n: (lo - 0.1 * (hi - lo) - 1e-12 * (1.0 + abs(lo)),
                       hi + 0.1 * (hi - lo) + 1e-12 * (1.0 + abs(hi))) for n, (lo, hi) in reach.items()}
            if not all(math.isfinite(v) for b in box.values() for v in b):
                return None
        else:
            return None
        # x(t + h) = x(t) + integral of f over the substep, and f stays in F(B)
        x = {n: _iadd(x[n], _imul(h, f[n])) for n in names}
    return x
'''
