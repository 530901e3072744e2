"""The vectorised code shape: a control step over a family of boundaries (a `foreach`, or
reads of families) becomes numpy code over every boundary at once, one mask per alternative of
each choice, `np.where` picking the first enabled alternative's value, and a min-update inside
a `foreach` becoming a reduction (`k = min(k, min of kt)`). This is the shape of the shipped
`kernel/ctrl2.py`; `_vectorised` returns the whole generated module's source."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from certiloop.kernel.extract.analysis import _conjuncts, _is_index_sort, _mentions, _outputs, _sort_of, _Step
from certiloop.kernel.extract.errors import ExtractError, _brief, _refuse
from certiloop.kernel.extract.roots import _solve
from certiloop.kernel.extract.template import ENTRY, HEADER, VECTORISED, _check_names, _power, _tag
from certiloop.models.lang.programs import Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import BOOL, REAL, Node
from certiloop.models.lang.theorem import Theorem


@dataclass
class _Alternative:
    mask: list[str] = field(default_factory=list)  # conjuncts, as code
    effects: dict[str, str] = field(default_factory=dict)  # variable -> value code
    lines: list[str] = field(default_factory=list)  # helper definitions (solved values)


class _Emitter:
    """numpy code over a family: every boundary at once."""

    def __init__(self, index: str | None) -> None:
        self.index = index  # the foreach variable inside the loop body, else None
        self.lines: list[str] = []
        self.local: dict[str, str] = {}  # model variable -> code name holding its value
        self.reads: dict[str, None] = {}  # scalars read before being assigned (parameters)
        self.families: dict[str, None] = {}
        self.opened: set[str] = set()  # `x := *` not yet pinned down by a test
        self.shared: dict[str, str] = {}  # comparison code -> the temporary holding it
        self.skip: str | None = None  # mask of the family members a foreach does not visit
        self.pending: dict[str, bool] = {}  # family `F := *` not pinned yet -> F was read before
        self.counter = [0]  # temporaries made so far (shared with nested emitters: unique names)

    # ---------------------------------------------------------------- expressions
    def code(self, n: Node, subst: dict[str, str] | None = None) -> str:
        subst = subst or {}
        op = n.op
        if op == "const":
            v = n.payload
            return repr(float(v)) if v.denominator != 1 else f"{int(v)}.0"
        if op == "true":
            return "True"
        if op == "false":
            return "False"
        if op == "var":
            name = n.payload
            if _is_index_sort(n.sort):
                raise _refuse(n, "a family's index is only usable to read the family (f(i))")
            if name in subst:
                return subst[name]
            if name in self.local:
                return self.local[name]
            self.reads[name] = None
            return name
        if op == "select":
            root, idx = n.args[0], n.args[1:]
            if len(idx) != 1 or idx[0].op != "var" or idx[0].payload != self.index:
                raise ExtractError(f"cannot vectorise the read `{n}`: only f(i) for the loop's index i")
            name = root.payload
            if name in subst:
                return subst[name]
            if name in self.local:
                return self.local[name]
            if self.pending.pop(name, False):
                raise ExtractError(f"`{name} := *` gives {name} a new value after the step read it, and "
                                   f"`{_brief(n)}` reads it before a test `∀j ({name}(j) <-> ...)` pins it")
            self.families[name] = None
            return name
        if op in ("forall", "exists"):
            return self._quantified(n, subst)
        a = [self.code(x, subst) for x in n.args]
        if op == "+":
            return "(" + " + ".join(a) + ")"
        if op == "*":
            return "(" + " * ".join(a) + ")"
        if op == "neg":
            return f"(-{a[0]})"
        if op == "/":
            if n.args[1].op != "const" and not any(_reads_family(x) for x in n.args):
                return f"np.divide({a[0]}, {a[1]})"  # two Python floats: inf, not ZeroDivisionError
            return f"({a[0]} / {a[1]})"
        if op == "^":
            return _power(a[0], n.payload)
        if op == "cmp":
            text = f"({a[0]} {n.payload} {a[1]})"
            if any(_mentions(n, v) for v in subst):
                return text  # reads a value solved inside one alternative: not shared
            return self._shared(text)
        if op == "and":
            return "(" + " & ".join(a) + ")" if a else "True"
        if op == "or":
            return "(" + " | ".join(a) + ")"
        if op == "not":
            return f"np.logical_not({a[0]})"
        if op == "implies":
            return f"(np.logical_not({a[0]}) | {a[1]})"
        if op == "iff":
            return f"({a[0]} == {a[1]})"
        raise ExtractError(f"cannot extract `{n}` into runtime code")

    def _quantified(self, n: Node, subst: dict[str, str]) -> str:
        """∀j P(j) over the family's index: P for every member at once, then np.all."""
        bound = n.payload
        if len(bound) != 1 or not _is_index_sort(bound[0].sort) or self.index is not None:
            raise _refuse(n, "only a quantifier over one family index, outside a foreach, is vectorised")
        self.index = bound[0].payload
        try:
            body = self.code(n.args[0], subst)
        finally:
            self.index = None
        return f"np.all({body})" if n.op == "forall" else f"np.any({body})"

    def _shared(self, text: str) -> str:
        """A comparison the ten cases repeat (0 <= d0, d0 <= D, ...) is computed once."""
        name = self.shared.get(text)
        if name is None:
            self.counter[0] += 1
            name = self.shared[text] = f"t{self.counter[0]}"
            self.lines.append(f"{name} = {text}")
        return name

    def _assigned(self, var: str) -> None:
        """var has a new value: shared comparisons that read it are stale."""
        self.shared = {t: n for t, n in self.shared.items() if not re.search(rf"\b{var}\b", t)}

    def _enabled(self, masks: str) -> str:
        return f"enabled &= {self.skip} | {masks}" if self.skip else f"enabled &= {masks}"

    # ---------------------------------------------------------------- statements
    def statement(self, p: Program) -> None:
        if isinstance(p, Seq):
            for q in p.parts:
                self.statement(q)
        elif isinstance(p, Assign):
            name = _target_name(p.target, self.index)
            self.lines.append(f"{name} = {self.code(p.value)}")
            self.local[name] = name
            self._assigned(name)
            self.opened.discard(name)
        elif isinstance(p, Havoc) and self.index is not None and _target_name(p.target, self.index):
            # an auxiliary value (xtr(i)) that a later test pins down: open until then
            name = _target_name(p.target, self.index)
            self.local.pop(name, None)
            self.opened.add(name)
        elif isinstance(p, Choice):
            self.choice(p)
        elif isinstance(p, Test):
            for atom in _conjuncts(p.cond):
                if atom.op != "true":
                    self.lines.append(self._enabled(self.code(atom)))
        else:
            raise _refuse(p, "only assignments, tests, choices and min-updates are vectorised")

    def choice(self, p: Choice) -> None:
        tags = [_tag(label, k) for k, label in enumerate(p.labels)]
        alts = [self.alternative(q, tag) for q, tag in zip(p.alternatives, tags)]
        self.lines.append(f"# choice: {' | '.join(p.labels)}")
        for alt, tag, label in zip(alts, tags, p.labels):
            self.lines.extend(alt.lines)
            self.lines.append(f"case_{tag} = {' & '.join(alt.mask) if alt.mask else 'True'}  # {label}")
        masks = [f"case_{t}" for t in tags]
        changed = list(dict.fromkeys(v for alt in alts for v in alt.effects))
        for var in changed:
            current = self.local.get(var, "np.nan")
            values = [alt.effects.get(var, current) for alt in alts]
            # the first enabled alternative's value (np.where nested from the last: np.select
            # does the same ten times slower on small arrays)
            picked = "np.nan"
            for mask, value in reversed(list(zip(masks, values))):
                picked = f"np.where({mask}, {value}, {picked})"
            self.lines.append(f"{var} = {picked}")
            self.local[var] = var
            self._assigned(var)
            self.opened.discard(var)
        self.lines.append(self._enabled(" | ".join(masks)))

    def alternative(self, p: Program, tag: str) -> _Alternative:
        alt = _Alternative()
        opened: list[str] = sorted(self.opened)
        subst: dict[str, str] = {}
        for q in p.parts if isinstance(p, Seq) else (p,):
            if isinstance(q, Test):
                for atom in _conjuncts(q.cond):
                    solved = next((v for v in opened if v not in subst and _mentions(atom, v)), None)
                    if solved is not None:
                        value, divisor = _solve(atom, solved)
                        name = f"{solved}_{tag}"
                        alt.lines.append(f"{name} = {self.code(value, subst)}  # from {atom}")
                        if divisor.op != "const":  # x*1 = 1 needs no guard
                            alt.mask.append(f"({self.code(divisor, subst)} != 0)")
                        subst[solved] = name
                        alt.effects[solved] = name  # x := *; ?x = v  is  x := v
                        continue
                    if atom.op != "true":
                        alt.mask.append(self.code(atom, subst))
            elif isinstance(q, Havoc):
                name = _target_name(q.target, self.index)
                opened.append(name)
                subst.pop(name, None)
            elif isinstance(q, Assign):
                name = _target_name(q.target, self.index)
                value = self.code(q.value, subst)
                alt.effects[name] = value
                subst[name] = value
            elif isinstance(q, Choice):
                raise _refuse(q, "a choice nested in an alternative is not vectorised (flatten it into "
                              "the outer choice)")
            else:
                raise _refuse(q, "only tests, assignments and `x := *` are vectorised inside a choice")
        for v in opened:
            if v not in subst and v not in self.opened:
                raise ExtractError(f"`{v} := *` is never pinned down by a test; cannot extract")
        return alt


def _reads_family(n: Node) -> bool:
    return n.op == "select" or any(_reads_family(a) for a in n.args)


def _target_name(target: Node, index: str | None) -> str:
    if target.op == "var":
        return target.payload
    if target.op == "select" and len(target.args) == 2 and target.args[1].op == "var" \
            and target.args[1].payload == index:
        return target.args[0].payload
    raise ExtractError(f"cannot vectorise the assignment to `{target}`")


def _vectorised(theorem: Theorem, step: "_Step") -> str:
    em = _Emitter(None)
    done = {q.each.done.payload for q in step.parts if isinstance(q, Loop) and q.each is not None}
    pending: dict[str, Havoc] = {}  # family `F := *` not yet pinned down by a test
    reductions: dict[str, None] = {}
    for q in step.parts:
        if isinstance(q, Havoc) and q.target.op == "var" and q.target.sort.is_array:
            name = q.target.payload
            if name in done:
                continue  # foreach's bookkeeping
            pending[name] = q
            # read before: the parameter holds the old value, so only a test can give the new one
            em.pending[name] = name in em.families or name in em.local
        elif isinstance(q, Havoc) and q.target.op == "var":
            continue  # an input: a parameter where the step reads it
        elif isinstance(q, Havoc):
            raise _refuse(q, "a single cell's `:= *` outside a foreach is not vectorised")
        elif isinstance(q, Test):
            if any(_mentions(q.cond, f) for f in done):
                continue  # foreach's "none done yet" / "all done" tests
            for atom in _conjuncts(q.cond):
                pin = _family_pin(atom, pending)
                if pin is None:
                    if atom.op != "true":
                        em.lines.append(f"enabled &= {em.code(atom)}")
                    continue
                name, value, var = pin
                em.index = var
                try:
                    code = em.code(value)
                finally:
                    em.index = None
                dtype = "bool" if pending[name].target.sort.range == BOOL else "float"
                em.lines.append(f"{name} = np.array({code}, dtype={dtype})  # from {_brief(atom)}")
                em.local[name] = name
                em._assigned(name)
                del pending[name]
                em.pending.pop(name, None)
        elif isinstance(q, Assign):
            em.statement(q)
        elif isinstance(q, Loop):
            reductions.update(dict.fromkeys(_foreach(em, q)))
        elif isinstance(q, Choice):
            em.choice(q)
        else:
            raise _refuse(q, "not a statement of a vectorised controller")
    unpinned = [name for name, was_read in em.pending.items() if was_read]
    if unpinned:
        raise _refuse(pending[unpinned[0]], "the step read this family before, and no test "
                      f"`∀j ({unpinned[0]}(j) <-> ...)` pins its new value down")
    assigned = [v for v in em.local if em.local[v] == v]
    outputs = _outputs(theorem, step, assigned, [], set())
    body = _without_dead(em.lines, keep={*outputs, "enabled", "skipped"})
    params = list(em.reads)
    families = list(em.families)
    _check_names(theorem, [*params, *families, *assigned], vectorised=True)
    src = HEADER.format(model=theorem.name, description=theorem.description, hash=theorem.content_hash,
                        inputs=params, families=families, what="discrete controller", how=VECTORISED,
                        imports="import numpy as np")
    args = ", ".join([*params, *families])
    src += f"\n\ndef {ENTRY}({args}):\n"
    if outputs == ["k"] and "k" in reductions:
        src += ('    """The gain the proof allows, and whether the model has a run at all (if not,\n'
                '    the caller must fall back). Families are 1-D arrays over the boundaries."""\n')
    else:
        returns = ", ".join(outputs)
        src += (f'    """Returns ({returns}, enabled): the values the proof allows, and whether the\n'
                '    model has a run at all (if not, the caller must fall back; the other values are then\n'
                '    meaningless). Families are 1-D numpy arrays over the boundaries (Bool families:\n'
                '    arrays of bool)."""\n')
    src += "    enabled = True\n"
    src += "    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):\n"
    for line in body:
        src += f"        {line}\n"
    finite = ""
    for v in outputs:
        sort = _sort_of(theorem, v, REAL)
        if sort == REAL:
            finite += f" and bool(np.isfinite({v}))"
        elif sort.is_array and sort.range == REAL:
            finite += f" and bool(np.all(np.isfinite({v})))"
    src += "    # floating-point overflow (1/(G fn²) for fn = 1e-160) is no run the proof covers\n"
    src += f"    return {', '.join(outputs)}, bool(np.all(enabled)){finite}\n"
    return src


def _family_pin(atom: Node, pending: dict[str, Havoc]) -> tuple[str, Node, str] | None:
    """`∀j (F(j) <-> E(j))` (or `F(j) = E(j)`) for an open family F: (F, E, j), else None."""
    if atom.op != "forall" or len(atom.payload) != 1:
        return None
    j = atom.payload[0].payload
    body = atom.args[0]
    if not (body.op == "iff" or (body.op == "cmp" and body.payload == "==")):
        return None
    for side, other in ((body.args[0], body.args[1]), (body.args[1], body.args[0])):
        if side.op == "select" and side.args[0].payload in pending and len(side.args) == 2 \
                and side.args[1].op == "var" and side.args[1].payload == j \
                and not _mentions(other, side.args[0].payload):
            return side.args[0].payload, other, j
    return None


def _without_dead(lines: list[str], keep: set[str]) -> list[str]:
    """Drop assignments whose variable nothing later reads (e.g. the auxiliary tmp and
    xtr once the gain is computed): they cannot change the result."""
    out: list[str] = []
    for line in reversed(lines):
        m = re.match(r"^(\w+) = ", line)
        if m and m.group(1) not in keep and not any(re.search(rf"\b{m.group(1)}\b", later) for later in out):
            continue
        out.append(line)
    return list(reversed(out))


def _foreach(em: _Emitter, loop: Loop) -> list[str]:
    """The loop over boundaries: its body vectorised, its min-updates as reductions.
    Returns the reduced variables."""
    steps = list(loop.body.parts) if isinstance(loop.body, Seq) else []
    if loop.each is None or len(steps) < 3:
        raise ExtractError(f"cannot extract the loop `{loop.label}`: only a foreach over a family (or a "
                           "`for` loop in a scalar step) is extracted")
    index_havoc, guard, *inner, mark_done = steps
    if not isinstance(index_havoc, Havoc) or index_havoc.target.op != "var":
        raise ExtractError(f"{loop.label}: expected `i := *` first")
    index = index_havoc.target.payload
    inner_em = _Emitter(index)
    inner_em.local.update({k: v for k, v in em.local.items()})
    inner_em.counter = em.counter
    if loop.each.member.op != "true":
        inner_em.skip = "skipped"
        inner_em.lines.append(f"skipped = np.logical_not({inner_em.code(loop.each.member)})  "
                              f"# boundaries the loop does not visit")
    reductions: list[tuple[str, str]] = []
    for s in inner:
        red = _min_update(s)
        if red is not None:
            var, value = red
            reductions.append((var, inner_em.code(value)))
            continue
        inner_em.statement(s)
        for v in _scalars_written(s, inner_em.index):
            if v in em.local:
                raise ExtractError(f"{loop.label}: `{v}` is overwritten for every boundary (the last "
                                   "one wins); only k := min(k, ...) folds over boundaries")
    em.lines.append(f"# {loop.label}: every boundary at once")
    em.lines.extend(inner_em.lines)
    for var, value in reductions:
        if inner_em.skip:
            value = f"np.where(skipped, np.inf, {value})"
        em.lines.append(f"{var} = np.minimum({em.local.get(var, var)}, np.min({value}, initial=np.inf))")
        em.local[var] = var
    em.reads.update(inner_em.reads)
    em.families.update(inner_em.families)
    return [var for var, _ in reductions]


def _min_update(p: Program) -> tuple[str, Node] | None:
    """`?a >= k; k := k ∪ ?a < k; k := a` is k := min(k, a): (k, a), else None."""
    if not isinstance(p, Choice) or len(p.alternatives) != 2:
        return None
    keep, lower = p.alternatives
    if not all(isinstance(a, Seq) and len(a.parts) == 2 for a in (keep, lower)):
        return None
    (t1, a1), (t2, a2) = keep.parts, lower.parts
    if not all(isinstance(x, Test) for x in (t1, t2)) or not all(isinstance(x, Assign) for x in (a1, a2)):
        return None
    k = a1.target
    if k.op != "var" or a1.value.key != k.key or a2.target.key != k.key:
        return None
    a = a2.value
    if t1.cond.key != (a >= k).key or t2.cond.key != (a < k).key:
        return None
    return k.payload, a


def _scalars_written(p: Program, index: str) -> list[str]:
    if isinstance(p, Assign) and p.target.op == "var":
        return [p.target.payload]
    if isinstance(p, (Seq, Choice)):
        parts = p.parts if isinstance(p, Seq) else p.alternatives
        return [v for q in parts for v in _scalars_written(q, index)]
    return []
