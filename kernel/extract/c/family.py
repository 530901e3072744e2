"""The C code shape for a control step over a family of boundaries (the shape `vectorised`
writes with numpy): one `for` loop over the boundaries per `foreach`, per-boundary values as
locals of the loop body, each choice an `if`/`else if` chain in the model's order (the first
enabled alternative, as numpy's nested np.where), a min-update `k := min(k, kt)` a running
minimum that keeps a NaN (as np.minimum does), a `∀j P(j)` test a loop, and a family pinned
by `∀j (F(j) <-> E(j))` read as E(i) where the loop reads F(i) (no array is allocated).

Decisions agree with the Python kernel bit for bit: every comparison is evaluated on the same
expression tree with the same IEEE operations. Where the model has no run (no enabled
alternative, a failed test) the function jumps to `blocked`: outputs NaN, return 0. The
helper values a solved test pins down (`xtr := *; ?xtr*fnp = -fn`) are written inline where
the alternative reads them, guarded by their divisor being non-zero, as in the Python."""

from __future__ import annotations

from fractions import Fraction

from certiloop.kernel.extract.analysis import (
    Step,
    conjuncts,
    is_index_sort,
    mentions,
    reads_of,
    sort_of,
    step_outputs,
)
from certiloop.kernel.extract.c.certified import cl_constant, cl_guard, cl_op
from certiloop.kernel.extract.c.syntax import c_comment
from certiloop.kernel.extract.errors import ExtractError, brief, refuse
from certiloop.kernel.extract.roots import solve
from certiloop.kernel.extract.vectorised import family_pin, min_update, scalars_written, target_name
from certiloop.models.lang.programs import Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import BOOL, REAL, Node, const, free_vars
from certiloop.models.lang.theorem import Theorem

BLOCK = "goto blocked;"
MAX_COPIES = 4  # split: at most this many copies of a foreach body's code


def local_type(sort) -> str:
    """A model value in the generated C: a certified real, or a three-valued Bool."""
    return "int" if sort == BOOL else "cl_real"


class _CFamily:
    def __init__(self, theorem: Theorem) -> None:
        self.theorem = theorem
        self.lines: list[str] = []
        self.depth = 1
        self.index: str | None = None  # the loop (or quantifier) index being emitted
        self.params: dict[str, object] = {}  # scalars read before assigned: name -> sort
        self.families: dict[str, object] = {}  # family parameters: name -> sort
        self.sizes: dict[str, str] = {}  # index sort -> its length parameter
        self.declared: list[set[str]] = [set()]  # locals per C scope
        self.pins: dict[str, tuple[Node, str]] = {}  # family -> (E, bound variable) of its pin
        self.pending: dict[str, bool] = {}  # family `F := *` not pinned yet -> F was read before
        self.assigned: dict[str, None] = {}  # top-level values the step computes
        self.blocks = False
        self.reduced: set[str] = set()  # min-reductions done: a lower bound, not a value to decide on
        self.loop_heads: list[tuple[int, str]] = []  # (line of a foreach's `for`, its index)
        self.in_foreach = False
        self.outside_reads = False  # a family read outside a foreach (a quantifier, a pinned output)
        self.known: dict[str, Fraction] = {}  # locals that hold a constant on this copy of the code (split)
        self.copies = 1  # copies of the code being written (split)
        self.flags = 0  # split's flags so far

    # ------------------------------------------------------------------ expressions
    def line(self, text: str) -> None:
        self.lines.append("    " * self.depth + text)

    def is_local(self, name: str) -> bool:
        return any(name in scope for scope in self.declared)

    def size_of(self, sort) -> str:
        dom = sort.domain[0] if sort.is_array else sort
        if dom not in self.sizes:
            self.sizes[dom] = "n_" + "".join(ch if ch.isalnum() else "_" for ch in str(dom))
        return self.sizes[dom]

    def code(self, n: Node, subst: dict[str, str] | None = None) -> str:
        subst = subst or {}
        op = n.op
        if op == "const":
            return cl_constant(n)
        if op in ("true", "false"):
            return "1" if op == "true" else "0"
        if op == "var":
            name = n.payload
            if is_index_sort(n.sort):
                raise refuse(n, "a family's index is only usable to read the family (f(i))")
            if name in subst:
                return subst[name]
            if self.held(n) is not None:
                return cl_constant(const(self.known[name]))
            if name in self.reduced:
                raise refuse(n, "a min over the boundaries read after the loop (C returns it, rounded "
                              "down, but does not decide on it)")
            if self.is_local(name):
                return f"cl_{name}"
            if n.sort.is_array:
                raise refuse(n, "a whole family outside f(i)")
            self.params.setdefault(name, n.sort)
            return f"({name} != 0)" if n.sort == BOOL else f"cl_{name}"
        if op == "select":
            root, idx = n.args[0], n.args[1:]
            if len(idx) != 1 or idx[0].op != "var" or idx[0].payload != self.index:
                raise ExtractError(f"cannot vectorise the read `{n}`: only f(i) for the loop's index i")
            name = root.payload
            if name in subst:
                return subst[name]
            if self.held(n) is not None:
                return cl_constant(const(self.known[name]))
            if self.is_local(name):
                return f"cl_{name}"
            if name in self.pins:
                value, bound = self.pins[name]
                return self.code(_rename(value, bound, self.index), subst)
            if self.pending.get(name):
                raise ExtractError(f"`{name} := *` gives {name} a new value after the step read it, and "
                                   f"`{brief(n)}` reads it before a test `∀j ({name}(j) <-> ...)` pins it")
            self.families.setdefault(name, root.sort)
            self.size_of(root.sort)
            if not self.in_foreach:
                self.outside_reads = True
            cell = f"{name}[{self.index}]"
            return f"({cell} != 0)" if root.sort.range == BOOL else f"cl_exact({cell})"
        if op in ("forall", "exists"):
            raise refuse(n, "a quantifier inside a term; only a test `?∀j P(j)` is written in C")
        args = [self.code(x, subst) for x in n.args]
        held = [self.held(x) if self.held(x) not in subst else None for x in n.args]
        if op == "*" and any(held):
            # a known constant factor of ±1 is dropped as a literal one is (no rounding, no bound)
            n = Node("*", tuple(const(self.known[h]) if h else x for x, h in zip(n.args, held)), n.sort,
                     n.payload)
        return cl_op(n, args)

    # ------------------------------------------------------------------ statements
    def assign(self, name: str, value: str, sort) -> None:
        if self.is_local(name):
            self.line(f"cl_{name} = {value};")
        else:
            self.line(f"{local_type(sort)} cl_{name} = {value};")
            self.declared[-1].add(name)

    def test(self, atom: Node) -> None:
        if atom.op == "true":
            return
        self.blocks = True
        if atom.op in ("forall", "exists"):
            bound = atom.payload
            if len(bound) != 1 or not is_index_sort(bound[0].sort) or self.index is not None:
                raise refuse(atom, "only a quantifier over one family index, outside a foreach, is written "
                              "in C")
            j = bound[0].payload
            size = self.size_of(bound[0].sort)
            self.index = j
            try:
                body = self.code(atom.args[0])
            finally:
                self.index = None
            if atom.op == "forall":
                self.line(f"for (size_t {j} = 0; {j} < {size}; {j}++) {c_comment(brief(atom, 70))}")
                self.line(f"    CL_TEST({body});")
            else:
                self.line(f"{{ {c_comment(brief(atom, 70))}")
                self.line("    int cl_found = 0;")
                self.line(f"    for (size_t {j} = 0; {j} < {size}; {j}++)")
                self.line(f"        cl_found = cl_or(cl_found, {body});")
                self.line("    CL_TEST(cl_found);")
                self.line("}")
            return
        self.line(f"CL_TEST({self.code(atom)});")

    def choice(self, p: Choice, flag: tuple[str, set[int]] | None = None) -> None:
        """`if`/`else if` over the alternatives in the model's order; none enabled: blocked.
        With a flag (see `split`): the alternatives in its set set it to 1, and the values the
        choice changes are left for the caller to widen."""
        self.line(c_comment("choice: " + " | ".join(p.labels)))
        alts = [self.alternative(q) for q in p.alternatives]
        changed = list(dict.fromkeys(v for _, effects, _ in alts for v in effects))
        for v in changed:  # declared before the chain, so every branch assigns the same local
            if not self.is_local(v):
                sort = sort_of(self.theorem, v, REAL)
                sort = sort.range if sort.is_array else sort
                init = "0" if sort == BOOL else "cl_approx(NAN, NAN, careful)"
                self.line(f"{local_type(sort)} cl_{v} = {init};")
                self.declared[-1].add(v)
        self.blocks = True
        # the first alternative that holds; one the floats cannot decide before it: CL_UNSURE
        for k, ((mask, effects, _), label) in enumerate(zip(alts, p.labels)):
            head = "if" if k == 0 else "} else if"
            self.line(f"{head} ({cl_guard(mask)}) {{ {c_comment(label)}")
            self.line("    if (cl_t < 0) CL_UNSURE;")
            for v, value in effects.items():
                self.line(f"    cl_{v} = {value};")
            if flag is not None and k in flag[1]:
                self.line(f"    {flag[0]} = 1;")
        self.line(f"}} else {{ {c_comment('no alternative is enabled: the model has no run')}")
        self.line(f"    {BLOCK}")
        self.line("}")
        if flag is None:
            self.widen(p, changed)

    def widen(self, p: Choice, changed: list[str] | None = None) -> None:
        """One static shape whatever branch set a value: the code after folds (cl_widen)."""
        if changed is None:
            changed = list(dict.fromkeys(v for q in p.alternatives for v in self.alternative(q)[1]))
        for v in changed:
            sort = sort_of(self.theorem, v, REAL)
            if (sort.range if sort.is_array else sort) == REAL:
                self.line(f"cl_{v} = cl_widen(cl_{v}, careful);")

    def alternative(self, p: Program) -> tuple[list[str], dict[str, str], dict[str, Fraction | None]]:
        """(its conditions, the values it gives the variables it writes, and which of these
        are constants -- a constant, or a variable known to hold one: see `split` -- or None)."""
        mask: list[str] = []
        effects: dict[str, str] = {}
        consts: dict[str, Fraction | None] = {}
        opened: list[str] = sorted(self.opened)
        subst: dict[str, str] = {}
        for q in p.parts if isinstance(p, Seq) else (p,):
            if isinstance(q, Test):
                for atom in conjuncts(q.cond):
                    solved = next((v for v in opened if v not in subst and mentions(atom, v)), None)
                    if solved is not None:
                        value, divisor = solve(atom, solved)
                        if divisor.op != "const":
                            mask.append(f"cl_ne({self.code(divisor, subst)}, cl_exact(0.0))")
                        subst[solved] = effects[solved] = self.code(value, subst)
                        consts[solved] = self.constant_of(value, consts)
                        continue
                    if atom.op != "true":
                        mask.append(self.code(atom, subst))
            elif isinstance(q, Havoc):
                name = target_name(q.target, self.index)
                opened.append(name)
                subst.pop(name, None)
                consts.pop(name, None)
            elif isinstance(q, Assign):
                name = target_name(q.target, self.index)
                subst[name] = effects[name] = self.code(q.value, subst)
                consts[name] = self.constant_of(q.value, consts)
            elif isinstance(q, Choice):
                raise refuse(q, "a choice nested in an alternative is not vectorised (flatten it into "
                              "the outer choice)")
            else:
                raise refuse(q, "only tests, assignments and `x := *` are vectorised inside a choice")
        for v in opened:
            if v not in subst and v not in self.opened:
                raise ExtractError(f"`{v} := *` is never pinned down by a test; cannot extract")
        # an opened value the alternative does not pin keeps no value: the Python reads NaN
        kept = [v for v in effects if v not in self.opened or v in subst]
        return mask, {v: effects[v] for v in kept}, {v: consts.get(v) for v in kept}

    def held(self, n: Node) -> str | None:
        """The name of a local known to hold a constant (see `split`) that n reads, else None."""
        if n.op == "var":
            name = n.payload
        elif n.op == "select" and len(n.args) == 2 and n.args[1].op == "var" \
                and n.args[1].payload == self.index:
            name = n.args[0].payload
        else:
            return None
        return name if name in self.known else None

    def constant_of(self, value: Node, consts: dict[str, Fraction | None]) -> Fraction | None:
        """value's constant, where it is one on this copy of the code (consts: the values the
        alternative set before), else None."""
        if value.op == "const":
            return Fraction(value.payload)
        name = value.payload if value.op == "var" else self.held(value)
        if name is not None and name in consts:
            return consts[name]
        return self.known.get(name) if name is not None else None


    def statement(self, p: Program) -> None:
        if isinstance(p, Seq):
            for q in p.parts:
                self.statement(q)
        elif isinstance(p, Assign):
            name = target_name(p.target, self.index)
            sort = p.target.sort
            self.assign(name, self.code(p.value), sort)
            self.opened.discard(name)
        elif isinstance(p, Havoc) and self.index is not None and target_name(p.target, self.index):
            self.opened.add(target_name(p.target, self.index))
        elif isinstance(p, Choice):
            self.choice(p)
        elif isinstance(p, Test):
            for atom in conjuncts(p.cond):
                self.test(atom)
        else:
            raise refuse(p, "only assignments, tests, choices and min-updates are vectorised")

    def foreach(self, loop: Loop, outer: set[str]) -> list[str]:
        """The loop over boundaries, its min-updates as running minima. Returns the reduced
        variables."""
        steps = list(loop.body.parts) if isinstance(loop.body, Seq) else []
        if loop.each is None or len(steps) < 3:
            raise ExtractError(f"cannot extract the loop `{loop.label}`: only a foreach over a family is "
                               "extracted")
        index_havoc, _guard, *inner, _mark_done = steps
        if not isinstance(index_havoc, Havoc) or index_havoc.target.op != "var":
            raise ExtractError(f"{loop.label}: expected `i := *` first")
        index = index_havoc.target.payload
        size = self.size_of(index_havoc.target.sort)
        self.line(f"for (size_t {index} = 0; {index} < {size}; {index}++) {{ {c_comment(loop.label)}")
        self.loop_heads.append((len(self.lines) - 1, index))
        self.depth += 1
        self.index = index
        self.in_foreach = True
        self.declared.append(set())
        self.opened = set()
        if loop.each.member.op != "true":
            member = self.code(loop.each.member)
            self.line(f"{{ int cl_m = {member}; {c_comment('boundaries the loop visits')}")
            self.line("    if (cl_m < 0) CL_UNSURE;")
            self.line("    if (!cl_m) continue; }")
        reduced: list[str] = []
        self.body(inner, outer, loop.label, reduced)
        self.declared.pop()
        self.index = None
        self.in_foreach = False
        self.depth -= 1
        self.line("}")
        self.reduced.update(reduced)
        return reduced

    def body(self, inner: list[Program], outer: set[str], label: str, reduced: list[str]) -> None:
        """The statements of a foreach's body (or the part of it after a choice whose code is
        duplicated: see `split`)."""
        for n, s in enumerate(inner):
            red = min_update(s)
            if red is not None:
                var, value = red
                if var not in outer:
                    raise refuse(s, f"`{var}` is folded over the boundaries but has no value before the "
                                  "loop")
                v = self.code(value)
                self.line(f"{{ cl_real cl_v = {v}; "
                          + c_comment(f"{var} := min({var}, {brief(value, 40)}), rounded down"))
                self.line("    if (!cl_tight(cl_v)) CL_UNSURE;")
                self.line(f"    if (cl_lower_below(cl_v, cl_{var}.v)) "
                          f"cl_{var} = cl_exact(cl_lower(cl_v)); }}")
                if var not in reduced:
                    reduced.append(var)
                continue
            for v in scalars_written(s, self.index):
                if v in outer or v in self.params:
                    raise ExtractError(f"{label}: `{v}` is overwritten for every boundary (the last "
                                       "one wins); only k := min(k, ...) folds over boundaries")
            if isinstance(s, Choice) and self.split(s, inner[n + 1:], outer, label, reduced):
                return
            self.statement(s)

    def split(self, p: Choice, tail: list[Program], outer: set[str], label: str, reduced: list[str]) -> bool:
        """A choice inside a foreach whose alternatives mostly give the values the rest of the
        body reads the same constants (sbs.ctrl2: `u := 1` in 5 of its 10 alternatives, `kt :=
        u` in 4 of 7): the rest of the body is written twice, once for those alternatives with
        the values as the constants they are (exact: the code after folds, with the filter's
        tightest bounds) and once, as before, for the others after cl_widen. The careful pass
        takes the second copy (cl_widen keeps its values as they are). The same values, the
        same decisions in the reals: only the filter's bounds are tighter on the first copy.
        Written only where the copies stay few (MAX_COPIES) and something after reads them."""
        if self.copies * 2 > MAX_COPIES or not tail:
            return False
        live = set().union(*(reads_of(q) for q in tail))
        written_later = {v for q in tail for v in _written_names(q)} | {
            v for q in tail for v in scalars_written(q, self.index)}
        sets = [self.alternative(q)[2] for q in p.alternatives]
        changed = [v for v in dict.fromkeys(v for c in sets for v in c) if v in live]
        if not changed:
            return False
        groups: dict[tuple, list[int]] = {}
        for k, c in enumerate(sets):
            if all(c.get(v) is not None for v in changed):
                groups.setdefault(tuple(c[v] for v in changed), []).append(k)
        if not groups:
            return False
        values, taken = max(groups.items(), key=lambda item: len(item[1]))  # the first of the largest
        flag = f"cl_c{self.flags}"
        self.flags += 1
        known = dict(zip(changed, values))
        what = ", ".join(f"{v} := {value}" for v, value in known.items())
        self.line(f"int {flag} = 0; {c_comment(f'1: the alternative taken sets {what}')}")
        self.choice(p, flag=(flag, set(taken)))
        saved = dict(self.known), set(self.opened)
        self.copies *= 2
        note = f"{what}: the rest of the body with these constants"
        self.line(f"if (!careful && {flag}) {{ {c_comment(note)}")
        self.depth += 1
        self.declared.append(set())
        for v, value in known.items():
            self.line(f"cl_{v} = {cl_constant(const(value))};")
            if v not in written_later:
                self.known[v] = value
        self.body(tail, outer, label, reduced)
        self.declared.pop()
        self.known, self.opened = dict(saved[0]), set(saved[1])
        self.depth -= 1
        self.line(f"}} else {{ {c_comment('the other alternatives, and the careful pass')}")
        self.depth += 1
        self.declared.append(set())
        self.widen(p)
        self.body(tail, outer, label, reduced)
        self.declared.pop()
        self.known, self.opened = saved
        self.depth -= 1
        self.line("}")
        self.copies //= 2
        return True


def _rename(value: Node, bound: str, index: str) -> Node:
    """E(j) read at the loop's index: the pin's bound variable renamed."""
    from certiloop.models.lang.terms import Var, substitute

    if bound == index or bound not in free_vars(value):
        return value
    return substitute(value, {bound: Var(index, free_vars(value)[bound].sort)})


def c_family(theorem: Theorem, step: Step) -> tuple[list[str], dict, dict, list[tuple[str, object]], str]:
    """The C body of a step over families: (lines, scalar params, family params, outputs with
    their sorts, the index-sort length parameters)."""
    em = _CFamily(theorem)
    em.opened = set()
    done = {q.each.done.payload for q in step.parts if isinstance(q, Loop) and q.each is not None}
    havocs: dict[str, Havoc] = {}
    for q in step.parts:
        if isinstance(q, Havoc) and q.target.op == "var" and q.target.sort.is_array:
            name = q.target.payload
            if name in done:
                continue  # foreach's bookkeeping
            if name in em.pins:
                raise refuse(q, "the step pinned this family before; a second value needs an array")
            havocs[name] = q
            # read before: the parameter holds the old value, so only a test can give the new one
            em.pending[name] = name in em.families
        elif isinstance(q, Havoc) and q.target.op == "var":
            continue  # an input: a parameter where the step reads it
        elif isinstance(q, Havoc):
            raise refuse(q, "a single cell's `:= *` outside a foreach is not vectorised")
        elif isinstance(q, Test):
            if any(mentions(q.cond, f) for f in done):
                continue  # foreach's "none done yet" / "all done" tests
            for atom in conjuncts(q.cond):
                pin = family_pin(atom, em.pending)
                if pin is None:
                    em.test(atom)
                    continue
                name, value, var = pin
                changed = {v for later in step.parts[step.parts.index(q) + 1:]
                           for v in _written_names(later)}
                if changed & set(free_vars(value)):
                    raise refuse(atom, "the pinned family reads values the step changes later; C reads "
                                  "it where the loop does, without an array")
                em.pins[name] = (value, var)
                del em.pending[name]
                em.assigned[name] = None
        elif isinstance(q, Assign):
            if q.target.op != "var":
                raise refuse(q, "a family cell assigned outside a foreach")
            em.statement(q)
            em.assigned[q.target.payload] = None
        elif isinstance(q, Loop):
            outer = {v for scope in em.declared for v in scope}
            for v in em.foreach(q, outer):
                em.assigned[v] = None
        elif isinstance(q, Choice):
            em.choice(q)
            for alt in q.alternatives:
                for v in scalars_written(alt, ""):
                    em.assigned[v] = None
        else:
            raise refuse(q, "not a statement of a vectorised controller")
    unpinned = [name for name, was_read in em.pending.items() if was_read]
    if unpinned:
        raise refuse(havocs[unpinned[0]], "the step read this family before, and no test "
                      f"`∀j ({unpinned[0]}(j) <-> ...)` pins its new value down")
    outputs = step_outputs(theorem, step, list(em.assigned), [], set())
    result = []
    for v in outputs:
        sort = sort_of(theorem, v, REAL)
        if sort.is_array and v not in em.pins:
            raise ExtractError(f"the family `{v}` is an output the step computes cell by cell; C writes only "
                               "scalar outputs and pinned families")
        result.append((v, sort))
    return em.lines, em.params, em.families, result, em


def _written_names(p: Program) -> set[str]:
    from certiloop.models.lang.programs import written

    return set(written(p))


def pinned_output(em: _CFamily, name: str, sort) -> list[str]:
    """Writes a pinned family to its output array, element by element."""
    value, bound = em.pins[name]
    em.index = bound
    try:
        code = em.code(value)
    finally:
        em.index = None
    size = em.size_of(sort)
    if sort.range == BOOL:
        return [f"for (size_t {bound} = 0; {bound} < {size}; {bound}++) {{",
                f"    int cl_o = {code};",
                "    if (cl_o < 0) CL_UNSURE;",
                f"    out_{name}[{bound}] = (unsigned char)cl_o;",
                "}"]
    return [f"for (size_t {bound} = 0; {bound} < {size}; {bound}++) {{",
            f"    cl_real cl_o = {code};",
            "    if (!cl_tight(cl_o)) CL_UNSURE;",
            f"    out_{name}[{bound}] = cl_lower(cl_o);",
            "}"]
