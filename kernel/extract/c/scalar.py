"""The C code shape for a step without a family (scalar controllers, switched plant modes):
the walk of `scalar._Python` (paths through nested choices, equations solved into guarded
values, `for` loops) with C syntax. A choice is an `if`/`else if` chain, or, where an
alternative needs a solved value before its later conditions, attempts in turn with nested
blocks (`taken`); where the model has no run the function jumps to `blocked`. Every local is
declared at the top of the function (NaN until set), solved values where they are computed.
Arrays (the Hoare-triple algorithms over arrays) are not written in C yet and are refused."""

from __future__ import annotations

from certiloop.kernel.extract.c.certified import cl_all, cl_constant, cl_op
from certiloop.kernel.extract.c.family import local_type
from certiloop.kernel.extract.c.syntax import c_comment
from certiloop.kernel.extract.errors import ExtractError, brief, refuse
from certiloop.kernel.extract.roots import Root, solutions
from certiloop.kernel.extract.scalar import Path, Python
from certiloop.models.lang.programs import Assign, Program, Seq, Test, written
from certiloop.models.lang.terms import INT, REAL, Node, free_vars

BLOCK = "goto blocked;"


class _CScalar(Python):
    def __init__(self, *args) -> None:
        super().__init__(*args)
        self.depth = 1
        self.uses_taken = False
        self.uses_t = False
        self.blocks = False

    # ------------------------------------------------------------------ expressions
    def code(self, n: Node, subst: dict[str, str | None] | None = None, real: bool = False) -> str:
        """Terms as certified values (cl_real), formulas three-valued (see c_certified)."""
        subst = subst if subst is not None else {}
        op = n.op
        if op == "const":
            return cl_constant(n)  # an Int constant too: every constant is an exact rational
        if op in ("true", "false"):
            return "1" if op == "true" else "0"
        if op == "var":
            name = n.payload
            if n.sort.is_array:
                raise refuse(n, "arrays in a scalar step are not written in C (only in Python)")
            if n.sort == INT:
                raise refuse(n, "Int arithmetic is not written in certified C")
            if name in subst:
                if subst[name] is None:
                    raise ExtractError(f"`{name} := *` is read before a test pins it down; cannot extract")
                return subst[name]
            self.read(name)
            return f"cl_{name}"
        if op == "select":
            raise refuse(n, "arrays in a scalar step are not written in C (only in Python)")
        if op in ("forall", "exists"):
            raise refuse(n, "not an arithmetic term or a quantifier-free formula")
        return cl_op(n, [self.code(x, subst) for x in n.args])

    def root_code(self, root: Root, subst: dict[str, str | None]) -> str:
        c = [self.code(p, subst, True) for p in root.parts]
        if root.kind == "value":
            return c[0]
        if root.kind == "sqrt+":
            return f"cl_sqrt({c[0]}, careful)"
        if root.kind == "sqrt-":
            return f"cl_neg(cl_sqrt({c[0]}, careful))"
        sign = "cl_add" if root.kind == "quad+" else "cl_add"
        root_ = f"cl_sqrt({c[1]}, careful)" if root.kind == "quad+" else f"cl_neg(cl_sqrt({c[1]}, careful))"
        return (f"cl_div({sign}(cl_neg({c[0]}), {root_}, careful), cl_mul(cl_exact(2.0), {c[2]}, careful), "
                "careful)")

    # ------------------------------------------------------------------ statements
    def statement(self, q: Program) -> None:
        if isinstance(q, Assign) and q.target.op == "var":
            name = q.target.payload
            value = self.code(q.value, real=q.target.sort == REAL)
            self.opened.pop(name, None)
            self.line(f"cl_{name} = {value};")
            self.defined.add(name)
            self.assigned[name] = None
        elif isinstance(q, Assign):
            raise refuse(q, "arrays in a scalar step are not written in C (only in Python)")
        else:
            super().statement(q)

    def blocked(self, cond: str) -> None:
        self.blocks = True
        self.line(f"CL_TEST({cond});")

    def test(self, q: Test) -> None:
        from certiloop.kernel.extract.analysis import conjuncts, mentions

        for atom in conjuncts(q.cond):
            if atom.op == "true":
                continue
            target = next((v for v in self.opened if mentions(atom, v)), None)
            if target is not None and atom.op == "cmp" and atom.payload == "==":
                roots = solutions(atom, target)
                if len(roots) != 1:
                    raise refuse(atom, f"a quadratic equation pins `{target}` outside a choice: which root "
                                  "to take depends on what follows; put it in a choice's alternative")
                for g in roots[0].guards:
                    self.blocked(self.test_code(g))
                value = self.root_code(roots[0], {})
                self.line(f"cl_{target} = {value}; {c_comment('from ' + brief(atom))}")
                del self.opened[target]
                self.pinned.add(target)
                self.defined.add(target)
                self.assigned[target] = None
                continue
            self.blocked(self.test_code(atom))

    def for_loop(self, statements: list[Program], var: str, lo: Node, hi: Node, body: list[Program]) -> None:
        from certiloop.kernel.extract.analysis import reads_of

        changed = written(Seq(tuple(body))) if body else {}
        if lo.sort != INT or hi.sort != INT:
            raise refuse(statements[1], "a `for` loop's bounds must be Int terms")
        for name in [var, *free_vars(lo), *free_vars(hi)]:
            if name in changed:
                raise refuse(statements[1], f"the loop's body writes `{name}`, which its counter or bounds "
                              "read")
        lo_code, hi_code = self.code(lo), self.code(hi)
        later = reads_of(self.step, skip={id(s) for s in statements})
        for name, sym in changed.items():
            if not sym.sort.is_array and name not in self.defined and name in (later | self.live):
                self.read(name)
        self.line(f"for ({var} = {lo_code}; {var} < {hi_code}; {var}++) {{")
        self.depth += 1
        self.defined.add(var)
        self.assigned[var] = None
        self.loops.append((var, lo, hi))
        self.block(body)
        self.loops.pop()
        self.depth -= 1
        self.line("}")
        if var in later or var in self.live:
            self.line(f"{var} = ({lo_code}) > ({hi_code}) ? ({lo_code}) : ({hi_code});")

    # ------------------------------------------------------------------ choices
    def in_path(self, q: Program, path: Path) -> list[Path]:
        if isinstance(q, Assign) and q.target.op != "var":
            raise refuse(q, "arrays in a scalar step are not written in C (only in Python)")
        return super().in_path(q, path)

    def choice(self, p) -> None:
        from certiloop.kernel.extract.analysis import reads_of, seq_parts
        from certiloop.kernel.extract.scalar import MAX_PATHS
        from certiloop.kernel.extract.template import choice_tag

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
            commits.append([f"cl_{v} = {value};" for v, value in path.effects.items() if v in live])
            changed.update((v, None) for v in path.effects if v in live)
        for v in changed:
            if v not in self.defined and any(v not in path.effects for path in paths):
                self.read(v)
        self.line(c_comment("choice: " + " | ".join(p.labels)))
        self.blocks = True
        if all(item[0] == "if" for path in paths for item in path.items):
            self._elif_chain(paths, commits)
        else:
            self._attempts(paths, commits)
        for v in changed:
            self.defined.add(v)
            self.assigned[v] = None

    def _elif_chain(self, paths: list[Path], commits: list[list[str]]) -> None:
        """The first alternative that holds; one the floats cannot decide before it: CL_UNSURE."""
        self.uses_t = True
        for n, (path, body) in enumerate(zip(paths, commits)):
            cond = cl_all([item[1] for item in path.items])
            if cond == "1":  # always enabled: the alternatives after it are never tried
                if n + 1 < len(paths):
                    self.line(c_comment(f"never tried: {' | '.join(q.label for q in paths[n + 1:])} "
                                        f"(`{path.label}` is always enabled)"))
                self.line(("{ " if n == 0 else "} else { ") + c_comment(path.label))
                for text in body:
                    self.line(f"    {text}")
                self.line("}")
                return
            self.line(f"{'if' if n == 0 else '} else if'} ((cl_t = {cond}) != 0) {{ {c_comment(path.label)}")
            self.line("    if (cl_t < 0) CL_UNSURE;")
            for text in body:
                self.line(f"    {text}")
        self.line(f"}} else {{ {c_comment('no alternative is enabled: the model has no run')}")
        self.line(f"    {BLOCK}")
        self.line("}")

    def _attempts(self, paths: list[Path], commits: list[list[str]]) -> None:
        """Alternatives whose conditions need solved values: each tried in turn, every value
        computed only where its guard holds; a guard the floats cannot decide: CL_UNSURE."""
        self.uses_taken = self.uses_t = True
        self.line("taken = 0;")
        for path, body in zip(paths, commits):
            self.line(c_comment(path.label))
            opened = 0
            pending: list[str] = []
            first = True
            for item in path.items:
                if item[0] == "if":
                    pending.append(item[1])
                    continue
                opened += self.guard(pending, first)
                first, pending = False, []
                value, _, note = item[2].partition("  # ")
                self.line(f"cl_real {item[1]} = {value};" + (f" {c_comment(note)}" if note else ""))
            opened += self.guard(pending, first)
            for text in body:
                self.line(text)
            self.line("taken = 1;")
            for _ in range(opened):
                self.depth -= 1
                self.line("}")
        self.line(f"if (!taken) {BLOCK} {c_comment('no alternative is enabled: the model has no run')}")

    def guard(self, conds: list[str], first: bool) -> int:
        """Open the blocks entered where the conditions hold (and, first, where no earlier path
        was taken); returns how many it opened."""
        cond = cl_all(conds)
        self.line("if (!taken) {" if first else "{")
        self.depth += 1
        if cond == "1":
            return 1
        self.line(f"cl_t = {cond};")
        self.line("if (cl_t < 0) CL_UNSURE;")
        self.line("if (cl_t) {")
        self.depth += 1
        return 2


def c_scalar(theorem, step) -> tuple[list[str], dict, list[tuple[str, object]], list[str]]:
    """The C body of a scalar step: (lines, scalar params with sorts, outputs with sorts, the
    declarations of its locals)."""
    from certiloop.kernel.extract.analysis import mode_choice, step_outputs
    from certiloop.models.lang.terms import BOOL, Var

    parts = list(step.parts)
    symbols = {**free_vars(theorem.assumptions), **theorem.program.symbols(), **free_vars(theorem.guarantee)}
    live = set(step.reads)
    rates: list[str] = []
    if step.where == "modes":
        modes, rates = mode_choice(step.plant, symbols)
        parts.append(modes)
        live |= set(rates)
        symbols.update((r, Var(r, REAL)) for r in rates)
    em = _CScalar(symbols, live, Seq(tuple(parts)) if parts else Test(Node("true", (), BOOL)))
    em.block(parts)
    if em.pinned & set(em.inputs):
        both = sorted(em.pinned & set(em.inputs))
        raise ExtractError(f"`{both[0]} := *` is pinned by an equation on some paths and read as an input "
                           "on others; cannot extract")
    outputs = rates or step_outputs(theorem, step, list(em.assigned), list(em.inputs), em.tested)
    sort = lambda v: symbols[v].sort  # noqa: E731
    params = {v: sort(v) for v in em.params}
    if any(s.is_array for s in params.values()):
        raise ExtractError("arrays in a scalar step are not written in C (only in Python)")
    local = [v for v in em.assigned if v not in params]
    decls = [f"{local_type(sort(v))} cl_{v} = {'0' if sort(v) == BOOL else 'cl_approx(NAN, NAN, careful)'};"
             for v in local]
    if em.uses_taken:
        decls.append("int taken;")
    if local:
        decls.append(" ".join(f"(void)cl_{v};" for v in local) + " " + c_comment("some are only set"))
    return em.lines, params, [(v, sort(v)) for v in outputs], decls, em.blocks
