"""The scalar code shape: every step without a family (scalar controllers, switched plant
modes, algorithms over arrays) becomes plain Python with `if`/`elif` chains for choices (nested
choices flattened into paths, the first enabled one in the model's order taken), `for` loops,
equations solved into guarded values, and an early return when the model has no run. `python`
returns the whole generated module's source, with a docstring written for its outputs."""

from __future__ import annotations

from dataclasses import dataclass, field

from certiloop.kernel.extract.analysis import (
    Step,
    conjuncts,
    for_range_at,
    is_index_sort,
    mentions,
    mode_choice,
    reads_of,
    seq_parts,
    step_outputs,
)
from certiloop.kernel.extract.errors import ExtractError, brief, refuse
from certiloop.kernel.extract.roots import Root, solutions
from certiloop.kernel.extract.shapes import elementwise, is_annotation, latched_scalars, pins_first
from certiloop.kernel.extract.template import (
    ENTRY,
    HEADER,
    RESERVED,
    SCALAR,
    check_names,
    choice_tag,
    doc_text,
    power,
)
from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test, written
from certiloop.models.lang.terms import BOOL, INT, REAL, Node, Var, free_vars
from certiloop.models.lang.theorem import Theorem

MAX_PATHS = 512  # alternatives after flattening nested choices

BLOCKED = "return __BLOCKED__"  # replaced once the outputs are known
KIT = "_R"  # the generated step's number kit (certiloop.kernel.decide)
STEP = "_step"  # the generated one-pass function the entry runs with each kit


@dataclass
class Path:
    """One way through an alternative (nested choices flattened): its conditions and
    helper values in order, then its effects."""

    tag: str
    label: str
    items: list[tuple[str, ...]] = field(default_factory=list)  # ("if", code) | ("let", name, code)
    subst: dict[str, str | None] = field(default_factory=dict)  # variable -> code; None: open here
    effects: dict[str, str] = field(default_factory=dict)  # variable -> value code
    cells: list[tuple[str, str, str]] = field(default_factory=list)  # (array, indices, value)

    def fork(self, tag: str, label: str) -> "Path":
        return Path(tag, label, list(self.items), dict(self.subst), dict(self.effects), list(self.cells))


class Python:
    """Plain scalar Python: `if`/`elif` for choices, `for` loops, early return when the
    model has no run."""

    def __init__(self, symbols: dict[str, Node], live: set[str], step: Program) -> None:
        self.symbols = dict(symbols)
        self.live = set(live)  # read by the plant, the invariant or the guarantee
        self.step = step  # for what later statements read
        self.lines: list[str] = []
        self.depth = 2
        self.params: dict[str, None] = {}  # read before assigned, in order
        self.defined: set[str] = set()  # names holding a value in the generated code
        self.assigned: dict[str, None] = {}  # names the step computes, in order
        self.opened: dict[str, None] = {}  # top-level `x := *` not yet read or pinned
        self.inputs: dict[str, None] = {}  # `x := *` read as they are: parameters
        self.pinned: set[str] = set()  # `x := *` solved for somewhere
        self.admitted: dict[str, None] = {}  # `x := *` in an alternative, only tested: parameters
        self.tested: set[str] = set()  # names some test reads
        self.array_reads: set[str] = set()
        self.array_writes: dict[str, list[tuple[Node, ...] | None]] = {}  # array -> loop bounds per write
        self.loops: list[tuple[str, Node, Node]] = []  # enclosing for loops (counter, lo, hi)
        self.taken: set[str] = set(symbols) | RESERVED
        self.elementwise: str | None = None  # the bound index inside a `∀j` over the boundaries
        # the number kit the reals are written over (certiloop.kernel.decide: a float filter with
        # error bounds, then exact rationals); None: plain float64
        self.kit: str | None = None
        # comparisons `o - c <= tol` a monitor writes as `kit.close(o, c, tol)` (key -> (o, c, tol))
        self.closes: dict = {}

    def line(self, text: str) -> None:
        self.lines.append("    " * self.depth + text)

    def fresh(self, base: str) -> str:
        name, n = base, 2
        while name in self.taken:
            name, n = f"{base}{n}", n + 1
        self.taken.add(name)
        return name

    def read(self, name: str) -> str:
        if name in self.opened:
            if name in self.defined:
                raise ExtractError(f"`{name} := *` gives {name} a new value after the step read it, and no "
                                   "test pins it down: it would need a second parameter")
            del self.opened[name]
            self.inputs[name] = None
        if name not in self.defined:
            self.params[name] = None
            self.defined.add(name)
        return name

    # ---------------------------------------------------------------- expressions
    def code(self, n: Node, subst: dict[str, str | None] | None = None, real: bool = False) -> str:
        subst = subst if subst is not None else {}
        op = n.op
        if op == "const":
            v = n.payload
            if v.denominator == 1 and n.sort == INT and not real:
                return str(int(v))
            if self.kit is not None:  # an exact rational, whatever float it is nearest to
                return f"{self.kit}.c({v.numerator})" if v.denominator == 1 else \
                    f"{self.kit}.c({v.numerator}, {v.denominator})"
            return repr(float(v)) if v.denominator != 1 else f"{int(v)}.0"
        if op == "true":
            return "True"
        if op == "false":
            return "False"
        if op == "var":
            name = n.payload
            if n.sort.is_array or is_index_sort(n.sort):
                raise refuse(n, "a whole array or a family index in a scalar step")
            if name in subst:
                if subst[name] is None:
                    raise ExtractError(f"`{name} := *` is read before a test pins it down; cannot extract")
                return subst[name]
            return self.read(name)
        if op == "select":
            root = n.args[0].payload
            if f"[{root}]" in subst:
                raise refuse(n, f"reads {root} after the same alternative wrote one of its cells")
            if self.elementwise is not None and len(n.args) == 2 and n.args[1].op == "var" \
                    and n.args[1].payload == self.elementwise:
                self.read(root)  # the whole family, as a numpy array over the boundaries
                return root
            if any(is_index_sort(s) for s in n.args[0].sort.domain):
                raise refuse(n, "a family over an index sort needs the vectorised form (a foreach)")
            idx = [self.code(a, subst) for a in n.args[1:]]
            self.array_reads.add(root)
            self.read(root)
            return f"{root}[{', '.join(idx)}]"
        if op == "cmp" and n.key in self.closes:
            o, c, tol = (self.code(x, subst, True) for x in self.closes[n.key])
            return f"{self.kit}.close({o}, {c}, {tol})"
        if op == "cmp":
            r = any(a.sort == REAL for a in n.args)
            a = [self.code(x, subst, r) for x in n.args]
            return f"({a[0]} {n.payload} {a[1]})"
        if op in ("+", "*", "neg", "/", "^"):
            r = real or n.sort == REAL or op == "/"
            a = [self.code(x, subst, r) for x in n.args]
            if op == "+":
                return "(" + " + ".join(a) + ")"
            if op == "*":
                return "(" + " * ".join(a) + ")"
            if op == "neg":
                return f"(-{a[0]})"
            if op == "/":
                return f"{self.kit}.div({a[0]}, {a[1]})" if self.kit else f"({a[0]} / {a[1]})"
            return power(a[0], n.payload)
        if op == "forall" and self.elementwise is None and len(n.payload) == 1 \
                and is_index_sort(n.payload[0].sort):
            return self.over_family(n, subst)
        a = [self.code(x, subst) for x in n.args]
        if self.elementwise is not None and op in ("and", "or", "not", "implies", "iff"):
            return elementwise(op, a) if self.kit is None else _logical(op, a)
        if op == "and":
            return "(" + " and ".join(a) + ")" if a else "True"
        if op == "or":
            return "(" + " or ".join(a) + ")" if a else "False"
        if op == "not":
            return f"(not {a[0]})"
        if op == "implies":
            return f"((not {a[0]}) or {a[1]})"
        if op == "iff":
            return f"({a[0]} == {a[1]})"
        raise refuse(n, "not an arithmetic term or a quantifier-free formula")

    def over_family(self, n: Node, subst: dict[str, str | None] | None) -> str:
        """`∀j φ(j)` over the boundaries: φ elementwise over the families as numpy arrays
        (True for an empty family)."""
        self.elementwise = n.payload[0].payload
        try:
            return f"bool(np.all({self.code(n.args[0], subst)}))"
        finally:
            self.elementwise = None

    def test_code(self, atom: Node, subst: dict[str, str | None] | None = None) -> str:
        self.tested.update(free_vars(atom))
        return self.code(atom, subst)

    def root_code(self, root: Root, subst: dict[str, str | None]) -> str:
        c = [self.code(p, subst, True) for p in root.parts]
        if root.kind == "value":
            return c[0]
        if self.kit is not None:
            k = self.kit
            if root.kind == "sqrt+":
                return f"{k}.sqrt({c[0]})"
            if root.kind == "sqrt-":
                return f"(-{k}.sqrt({c[0]}))"
            sign = "+" if root.kind == "quad+" else "-"
            return f"{k}.div(((-{c[0]}) {sign} {k}.sqrt({c[1]})), ({k}.c(2) * {c[2]}))"
        if root.kind == "sqrt+":
            return f"np.sqrt({c[0]})"
        if root.kind == "sqrt-":
            return f"(-np.sqrt({c[0]}))"
        sign = "+" if root.kind == "quad+" else "-"
        return f"(((-{c[0]}) {sign} np.sqrt({c[1]})) / (2.0 * {c[2]}))"

    # ---------------------------------------------------------------- statements
    def block(self, parts: list[Program] | tuple[Program, ...]) -> None:
        parts = list(parts)
        k = 0
        while k < len(parts):
            loop = for_range_at(parts, k)
            if loop is not None:
                self.for_loop(parts[k: k + 3], *loop)
                k += 3
                continue
            self.statement(parts[k])
            k += 1

    def statement(self, q: Program) -> None:
        if isinstance(q, Seq):
            self.block(q.parts)
        elif isinstance(q, Assign) and q.target.op == "var":
            name = q.target.payload
            value = self.code(q.value, real=q.target.sort == REAL)
            self.opened.pop(name, None)
            self.line(f"{name} = {value}")
            self.defined.add(name)
            self.assigned[name] = None
        elif isinstance(q, Assign):
            root = q.target.args[0].payload
            idx = ", ".join(self.code(a) for a in q.target.args[1:])
            value = self.code(q.value, real=q.target.sort == REAL)
            self.array_write(root, q.target)
            self.line(f"{root}[{idx}] = {value}")
        elif isinstance(q, Havoc) and q.target.op == "var" and not q.target.sort.is_array:
            self.opened[q.target.payload] = None
        elif isinstance(q, Havoc):
            raise refuse(q, "an array's or a cell's `:= *` is only extracted in a foreach")
        elif isinstance(q, Test):
            self.test(q)
        elif isinstance(q, Choice):
            self.choice(q)
        elif is_annotation(q):
            pass  # `{?true}*` carries an invariant for the proof; it does nothing at run time
        elif isinstance(q, Loop):
            raise refuse(q, "only `for` loops (`i := lo; {?i < hi; ...; i := i + 1}*; ?i >= hi`) are "
                          "extracted: a loop with no exit test repeats any number of times")
        elif isinstance(q, ODE):
            raise refuse(q, "a second ODE inside the control step")
        else:
            raise refuse(q, "unknown statement")

    def array_write(self, root: str, target: Node) -> None:
        """Note the loop bounds that index a cell write (to allocate a write-only array)."""
        bounds: list[Node] | None = []
        counters = {c: (lo, hi) for c, lo, hi in self.loops}
        for a in target.args[1:]:
            lo_hi = counters.get(a.payload) if a.op == "var" else None
            if lo_hi is None or lo_hi[0].op != "const" or lo_hi[0].payload < 0:
                bounds = None
                break
            bounds.append(lo_hi[1])
        self.array_writes.setdefault(root, []).append(tuple(bounds) if bounds is not None else None)
        self.defined.add(root)
        self.assigned[root] = None

    def test(self, q: Test) -> None:
        for atom in pins_first(conjuncts(q.cond), list(self.opened)):
            if atom.op == "true":
                continue
            target = next((v for v in self.opened if mentions(atom, v)), None)
            if target is not None and atom.op == "cmp" and atom.payload == "==":
                roots = solutions(atom, target)
                if len(roots) != 1:
                    raise refuse(atom, f"a quadratic equation pins `{target}` outside a choice: which root "
                                  "to take depends on what follows; put it in a choice's alternative")
                for g in roots[0].guards:
                    self.line(f"if not {self.test_code(g)}:")
                    self.line(f"    {BLOCKED}")
                self.line(f"{target} = {self.root_code(roots[0], {})}  # from {brief(atom)}")
                del self.opened[target]
                self.pinned.add(target)
                self.defined.add(target)
                self.assigned[target] = None
                continue
            self.line(f"if not {self.test_code(atom)}:")
            self.line(f"    {BLOCKED}")

    def for_loop(self, statements: list[Program], var: str, lo: Node, hi: Node, body: list[Program]) -> None:
        changed = written(Seq(tuple(body))) if body else {}
        if lo.sort != INT or hi.sort != INT:
            raise refuse(statements[1], "a `for` loop's bounds must be Int terms")
        for name in [var, *free_vars(lo), *free_vars(hi)]:
            if name in changed:
                raise refuse(statements[1], f"the loop's body writes `{name}`, which its counter or bounds "
                              "read")
        lo_code, hi_code = self.code(lo), self.code(hi)
        later = reads_of(self.step, skip={id(s) for s in statements})
        for name, sym in changed.items():  # a value for the case the loop runs zero times
            if not sym.sort.is_array and name not in self.defined and name in (later | self.live):
                self.read(name)
        self.line(f"for {var} in range({lo_code}, {hi_code}):")
        self.depth += 1
        self.defined.add(var)
        self.assigned[var] = None
        self.loops.append((var, lo, hi))
        before = len(self.lines)
        self.block(body)
        if len(self.lines) == before:
            self.line("pass")
        self.loops.pop()
        self.depth -= 1
        if var in later or var in self.live:
            self.line(f"{var} = max({lo_code}, {hi_code})")

    # ---------------------------------------------------------------- choices
    def choice(self, p: Choice) -> None:
        paths: list[Path] = []
        for k, (alt, label) in enumerate(zip(p.alternatives, p.labels)):
            paths += self.walk(seq_parts(alt), [Path(choice_tag(label, k), label)])
            if len(paths) > MAX_PATHS:
                raise refuse(p, f"more than {MAX_PATHS} ways through its nested choices")
        live = self.live | reads_of(self.step, skip={id(p)})
        for path in paths:
            for v, s in path.subst.items():
                if s is None and v in live and not v.startswith("["):
                    raise refuse(p, f"`{v} := *` in `{path.label}` is never pinned down but read later")
        commits: list[list[str]] = []
        changed: dict[str, None] = {}
        for path in paths:
            lines = [f"{v} = {value}" for v, value in path.effects.items() if v in live]
            changed.update((v, None) for v in path.effects if v in live)
            for root, idx, value in path.cells:
                lines.append(f"{root}[{idx}] = {value}")
            commits.append(lines)
        for v in changed:  # left as it was by some alternative: its value before the choice
            if v not in self.defined and any(v not in path.effects for path in paths):
                self.read(v)
        self.line(f"# choice: {' | '.join(p.labels)}")
        if all(item[0] == "if" for path in paths for item in path.items):
            self._elif_chain(paths, commits)
        else:
            self._attempts(paths, commits)
        for v in changed:
            self.defined.add(v)
            self.assigned[v] = None
        for path in paths:
            for root, _, _ in path.cells:
                self.defined.add(root)
                self.assigned[root] = None

    def _elif_chain(self, paths: list[Path], commits: list[list[str]]) -> None:
        for n, (path, body) in enumerate(zip(paths, commits)):
            conds = [item[1] for item in path.items if item[1] != "True"]
            if not conds:  # always enabled: the alternatives after it are never tried
                if n + 1 < len(paths):
                    self.line(f"# never tried: {' | '.join(q.label for q in paths[n + 1:])} "
                              f"(`{path.label}` is always enabled)")
                if n == 0:
                    self.line(f"# {path.label}")
                    for text in body:
                        self.line(text)
                else:
                    self.line(f"else:  # {path.label}")
                    for text in body or ["pass"]:
                        self.line(f"    {text}")
                return
            self.line(f"{'if' if n == 0 else 'elif'} {' and '.join(conds)}:  # {path.label}")
            for text in body or ["pass"]:
                self.line(f"    {text}")
        self.line("else:  # no alternative is enabled: the model has no run")
        self.line(f"    {BLOCKED}")

    def _attempts(self, paths: list[Path], commits: list[list[str]]) -> None:
        """Alternatives whose conditions need helper values (a solved `x := *`): each tried
        in turn, nested ifs so that every value is computed only where its guard holds."""
        self.line("taken = False")
        for path, body in zip(paths, commits):
            self.line(f"# {path.label}")
            depth = self.depth
            pending = ["not taken"]
            for item in path.items:
                if item[0] == "if":
                    if item[1] != "True":
                        pending.append(item[1])
                    continue
                if pending:
                    self.line(f"if {' and '.join(pending)}:")
                    self.depth += 1
                    pending = []
                self.line(f"{item[1]} = {item[2]}")
            if pending:
                self.line(f"if {' and '.join(pending)}:")
                self.depth += 1
            for text in body:
                self.line(text)
            self.line("taken = True")
            self.depth = depth
        self.line("if not taken:  # no alternative is enabled: the model has no run")
        self.line(f"    {BLOCKED}")

    def walk(self, statements: list[Program], paths: list[Path]) -> list[Path]:
        for q in statements:
            paths = [r for path in paths for r in self.in_path(q, path)]
            if len(paths) > MAX_PATHS:
                raise refuse(q, f"more than {MAX_PATHS} ways through nested choices")
        return paths

    def in_path(self, q: Program, path: Path) -> list[Path]:
        if isinstance(q, Seq):
            return self.walk(list(q.parts), [path])
        if isinstance(q, Choice):
            out: list[Path] = []
            for k, (alt, label) in enumerate(zip(q.alternatives, q.labels)):
                sub = path.fork(f"{path.tag}_{choice_tag(label, k)}", f"{path.label} / {label}")
                out += self.walk(seq_parts(alt), [sub])
            return out
        if is_annotation(q):
            return [path]
        if isinstance(q, Test):
            paths = [path]
            for atom in pins_first(conjuncts(q.cond), [v for v, s in path.subst.items() if s is None]):
                if atom.op != "true":
                    paths = [r for p in paths for r in self.atom_in_path(atom, p)]
            return paths
        if isinstance(q, Havoc) and q.target.op == "var" and not q.target.sort.is_array:
            path.subst[q.target.payload] = None
            path.effects.pop(q.target.payload, None)
            return [path]
        if isinstance(q, Assign) and q.target.op == "var":
            name = q.target.payload
            value = self.code(q.value, path.subst, q.target.sort == REAL)
            path.subst[name] = value
            path.effects[name] = value
            return [path]
        if isinstance(q, Assign):
            root = q.target.args[0].payload
            idx = ", ".join(self.code(a, path.subst) for a in q.target.args[1:])
            path.cells.append((root, idx, self.code(q.value, path.subst, q.target.sort == REAL)))
            path.subst[f"[{root}]"] = None
            self.array_write(root, q.target)
            return [path]
        raise refuse(q, "only tests, assignments, `x := *` and choices are extracted inside a choice")

    def atom_in_path(self, atom: Node, path: Path) -> list[Path]:
        target = next((v for v, s in path.subst.items() if s is None and not v.startswith("[")
                       and mentions(atom, v)), None)
        if target is None:
            target = next((v for v in self.opened if v not in path.subst and mentions(atom, v)
                           and atom.op == "cmp" and atom.payload == "=="), None)
        if target is None:
            path.items.append(("if", self.test_code(atom, path.subst)))
            return [path]
        if not (atom.op == "cmp" and atom.payload == "==") and target in path.subst \
                and (target not in self.defined or target in self.admitted) and target not in self.pinned:
            # `u := *; ?|u| <= U` with nothing pinning u: the value is an input, admitted as given
            for v in [v for v, s in path.subst.items() if s is None and not v.startswith("[")
                      and mentions(atom, v)]:
                if v in self.defined and v not in self.admitted or v in self.pinned:
                    raise refuse(atom, f"`{v} := *` gets a new value after the step read or solved it")
                self.inputs[v] = self.admitted[v] = None
                path.subst[v] = self.read(v)
            path.items.append(("if", self.test_code(atom, path.subst)))
            return [path]
        roots = solutions(atom, target)
        out = []
        for root in roots:
            r = path if len(roots) == 1 else path.fork(path.tag, path.label + root.note)
            for g in root.guards:
                r.items.append(("if", self.test_code(g, r.subst)))
            name = self.fresh(f"{target}_{r.tag}")
            r.items.append(("let", name, f"{self.root_code(root, r.subst)}  # from {brief(atom)}"))
            r.subst[target] = name
            r.effects[target] = name
            self.pinned.add(target)
            out.append(r)
        return out


def _logical(op: str, a: list[str]) -> str:
    """A connective over numpy arrays of truth values (object arrays where the kit's values
    compare elementwise: `~` would be the integer inversion of a Python bool there)."""
    if op == "and":
        return "(" + " & ".join(f"np.asarray({x}, dtype=bool)" for x in a) + ")" if a else "True"
    if op == "or":
        return "(" + " | ".join(f"np.asarray({x}, dtype=bool)" for x in a) + ")" if a else "False"
    if op == "not":
        return f"np.logical_not(np.asarray({a[0]}, dtype=bool))"
    if op == "implies":
        return f"(np.logical_not(np.asarray({a[0]}, dtype=bool)) | np.asarray({a[1]}, dtype=bool))"
    return f"(np.asarray({a[0]}, dtype=bool) == np.asarray({a[1]}, dtype=bool))"


def python(theorem: Theorem, step: "Step") -> str:
    parts = list(step.parts)
    symbols = {**free_vars(theorem.assumptions), **theorem.program.symbols(), **free_vars(theorem.guarantee)}
    live = set(step.reads)
    rates: list[str] = []
    if step.where == "modes":
        modes, rates = mode_choice(step.plant, symbols)
        parts.append(modes)
        live |= set(rates)
        symbols.update((r, Var(r, REAL)) for r in rates)
    py = Python(symbols, live, Seq(tuple(parts)) if parts else Test(Node("true", (), BOOL)))
    py.kit = KIT
    py.block(parts)
    latches = latched_scalars(parts, py.params) if step.where in ("before", "after") else set()
    if latches - live:  # a value the step reads and sets (`stopped := 1`): the next step needs it
        live |= latches
        py = Python(symbols, live, Seq(tuple(parts)))
        py.kit = KIT
        py.block(parts)
    if py.pinned & set(py.inputs):
        both = sorted(py.pinned & set(py.inputs))
        raise ExtractError(f"`{both[0]} := *` is pinned by an equation on some paths and read as an input "
                           "on others; cannot extract")
    outputs = rates or step_outputs(theorem, step, list(py.assigned), list(py.inputs), py.tested, latches)
    outputs += [v for v in py.assigned if v in latches and v not in outputs]
    params = list(py.params)
    check_names(theorem, [*params, *py.assigned])
    sort = lambda v: symbols[v].sort  # noqa: E731
    scalars = [v for v in params if not sort(v).is_array]
    arrays = [v for v in params if sort(v).is_array]
    allocated: dict[str, str] = {}
    changed = written(theorem.program)
    for name, writes in py.array_writes.items():
        if name in params or name in py.array_reads or name in free_vars(theorem.assumptions):
            continue
        if None in writes or len({tuple(b.key for b in w) for w in writes}) != 1 \
                or any(v in changed for b in writes[0] for v in free_vars(b)):
            arrays.append(name)  # cells it does not write keep the caller's values
            params.append(name)
            continue
        dims = [f"max({py.code(b)}, 0)" for b in writes[0]]
        allocated[name] = f"({dims[0]},)" if len(dims) == 1 else f"({', '.join(dims)})"
    params = scalars + arrays  # scalars first, then arrays
    what = "algorithm" if step.where == "algorithm" else "discrete controller"
    imports = "import numpy as np\n\nfrom certiloop.kernel import decide as _decide"
    if any(sort(v) == INT for v in scalars):
        imports = "import operator\n\n" + imports
    src = HEADER.format(model=doc_text(theorem.name), model_name=theorem.name,
                        description=doc_text(theorem.description), hash=theorem.content_hash,
                        inputs=scalars, families=arrays, what=what, how=SCALAR[step.where], imports=imports)
    src += f"\n\ndef {ENTRY}({', '.join(params)}):\n"
    admitted = not rates and all(v in py.inputs for v in outputs)
    src += _python_doc(outputs, step.where, admitted, scalars, sort, allocated,
                       [a for a in arrays if a in py.array_writes], _roles_note(theorem, params))
    blocked = ", ".join(["np.nan"] * len(outputs) + ["False"])
    src += f"    return _decide.run({STEP}, ({blocked}){''.join(', ' + p for p in params)})\n"
    src += f"\n\ndef {STEP}({', '.join([KIT, *params])}):\n"
    src += (f'    """One pass of the step over the number kit {KIT}: the float filter (raises '
            'Undecided where\n    a decision is not certain) or exact rationals."""\n')
    for v in scalars:
        s = sort(v)
        conv = f"{KIT}.real" if s == REAL else "operator.index" if s == INT else "bool"
        src += f"    {v} = {conv}({v})\n"
    for v in arrays:
        if sort(v).range == REAL:
            src += f"    {v} = {KIT}.array({v})\n"
            continue
        make = "np.array" if v in py.array_writes else "np.asarray"  # a copy where the step writes
        src += f"    {v} = {make}({v}, dtype={_dtype(sort(v).range)})\n"
    for v, shape in allocated.items():
        if sort(v).range == REAL:
            src += f"    {v} = {KIT}.zeros({shape})\n"
        else:
            src += f"    {v} = np.zeros({shape}, dtype={_dtype(sort(v).range)})\n"
    body = py.lines or ["        pass"]
    src += "    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):\n"
    for line in body:
        src += line.replace("__BLOCKED__", blocked) + "\n"
    values = []
    for v in outputs:
        s = sort(v)
        if s.is_array:
            values.append(f"{KIT}.out_array({v})" if s.range == REAL else v)
        else:
            values.append(f"{KIT}.out({v})" if s == REAL else f"{'int' if s == INT else 'bool'}({v})")
    src += "    # a real output: the largest float <= its real value (none beyond the float range: no run)\n"
    src += f"    return {', '.join(values)}, True\n"
    return src


def _roles_note(theorem: Theorem, params: list[str]) -> str:
    """With declared roles: where the environment's values went."""
    if theorem.roles is None:
        return ""
    env = theorem.roles.environment_names
    read = [v for v in env if v in params]
    unread = [v for v in env if v not in params]
    said = ([f"{', '.join(read)} as sensed this period (inputs)"] if read else []) + \
        ([f"{', '.join(unread)}, which the controller does not read"] if unread else [])
    return (f"Roles declared by the model: the outputs are its controls; the environment chooses "
            f"{' and '.join(said)}. The environment's choices are not part of this function: "
            "environment_monitor (`certiloop extract --monitors`) checks the model's assumptions about them.")


def _python_doc(outputs: list[str], where: str, admitted: bool, scalars: list[str], sort,
                allocated: dict[str, str], copied: list[str], roles_note: str = "") -> str:
    if where == "modes":
        what = "the rates of the first mode, in the model's order, whose evolution domain holds in this state"
    elif where == "algorithm":
        what = "the values the verified algorithm leaves"
    elif admitted:
        what = "the command as given, when the verified model admits it"
    else:
        what = ("the values the verified model computes for this state (where several alternatives of a "
                "choice are enabled, the first in the model's order)")
    paras = [f"Returns ({', '.join(outputs)}, enabled): {what}, and whether the model has a run at all. "
             "enabled is False when no alternative of a choice (or a test) admits the state"
             + (", or the arithmetic overflowed" if any(sort(v) == REAL for v in scalars) else "")
             + "; the other values are then NaN and the caller must fall back."]
    conversions = []
    if any(sort(v) == REAL for v in scalars):
        conversions.append("Every decision is the real model's on the float inputs (exact rationals): "
                           "taken in floats with a rigorous error bound, and with exact rationals where "
                           "the bound cannot decide. A non-finite input, a division by zero the model "
                           "does not guard, or a real output beyond the float range is no run "
                           "(enabled = False), never an exception.")
    if any(sort(v) == INT for v in scalars):
        conversions.append("Int parameters must be integers.")
    if conversions:
        paras.append(" ".join(conversions))
    arrays = []
    for v, shape in allocated.items():
        arrays.append(f"{v} is allocated with zeros of shape {shape}: the algorithm writes all its cells.")
    for v in copied:
        arrays.append(f"{v} is copied; cells the algorithm does not write keep the values passed in.")
    if allocated or copied or any(sort(v).is_array for v in outputs):
        arrays.append("Arrays are numpy arrays indexed from 0; an index outside an array is the caller's "
                      "error (IndexError).")
    if arrays:
        paras.append(" ".join(arrays))
    if roles_note:
        paras.append(roles_note)
    return '    """' + "\n\n".join(_wrap(para, 4) for para in paras).lstrip() + '\n    """\n'


def _wrap(text: str, indent: int, width: int = 96) -> str:
    rows, row = [], ""
    for word in text.split():
        if row and indent + len(row) + 1 + len(word) > width:
            rows.append(row)
            row = word
        else:
            row = f"{row} {word}" if row else word
    rows.append(row)
    return "\n".join(" " * indent + r for r in rows)


def _dtype(sort) -> str:
    return "float" if sort == REAL else "int" if sort == INT else "bool"
