"""The vectorised code shape: a control step over a family of boundaries (a `foreach`, or
reads of families) becomes numpy code over every boundary at once, one mask per alternative of
each choice, `np.where` picking the first enabled alternative's value, and a min-update inside
a `foreach` becoming a reduction (`k = min(k, min of kt)`). This is the shape of the shipped
`studies/sbs/generated/ctrl2.py`; `vectorised_source` returns the whole generated module's source."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from certiloop.kernel.extract import certified
from certiloop.kernel.extract.analysis import Step, conjuncts, is_index_sort, mentions, sort_of, step_outputs
from certiloop.kernel.extract.errors import ExtractError, brief, refuse
from certiloop.kernel.extract.roots import solve
from certiloop.kernel.extract.template import (
    ENTRY,
    HEADER,
    VECTORISED,
    check_names,
    choice_tag,
    doc_text,
    power,
)
from certiloop.models.lang.programs import Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import BOOL, REAL, Node
from certiloop.models.lang.theorem import Theorem


@dataclass
class _Alternative:
    mask: list[str] = field(default_factory=list)  # conjuncts, as code
    unsure: list[list[str]] = field(default_factory=list)  # cert mode: per conjunct, its uncertainty masks
    effects: dict[str, tuple[str, str | None]] = field(default_factory=dict)  # variable -> (value, error)
    lines: list[str] = field(default_factory=list)  # helper definitions (solved values)


class _Emitter:
    """numpy code over a family: every boundary at once."""

    def __init__(self, index: str | None, mode: str = "cert") -> None:
        self.mode = mode  # "cert": floats with error bounds (certified.py); "exact": Fractions
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
        self.errors: dict[str, str | None] = {}  # cert mode: value code -> its error bound's code
        self.memo: dict[str, str] = {}  # cert mode: helper call -> the temporary holding it
        self.uncertain: dict[str, str] = {}  # cert mode: comparison mask -> where it is uncertain
        self.used: list[str] = []  # cert mode: uncertainty masks of the comparisons coded since reset
        self.flagged: set[tuple[str, tuple[str, ...]]] = set()  # cert mode: (mask, under conjuncts) in _bad

    # ---------------------------------------------------------------- expressions
    def code(self, n: Node, subst: dict[str, str] | None = None) -> str:
        subst = subst or {}
        op = n.op
        if op == "const":
            v = n.payload
            if self.mode == "exact":
                return certified.exact_constant(v)
            return certified.constant(v)[0]
        if op == "true":
            return "True"
        if op == "false":
            return "False"
        if op == "var":
            name = n.payload
            if is_index_sort(n.sort):
                raise refuse(n, "a family's index is only usable to read the family (f(i))")
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
                                   f"`{brief(n)}` reads it before a test `∀j ({name}(j) <-> ...)` pins it")
            self.families[name] = None
            return name
        if op in ("forall", "exists"):
            return self._quantified(n, subst)
        if self.mode == "cert" and op in ("+", "*", "neg", "/", "^"):
            return self.pair(n, subst)[0]
        if self.mode == "cert" and op == "cmp":
            return self._compare(n, subst)
        a = [self.code(x, subst) for x in n.args]
        if op == "+":
            return "(" + " + ".join(a) + ")"
        if op == "*":
            return "(" + " * ".join(a) + ")"
        if op == "neg":
            return f"(-{a[0]})"
        if op == "/":
            if self.mode == "exact":
                return f"{certified.HELPERS}.xdiv({a[0]}, {a[1]})"
            if n.args[1].op != "const" and not any(_reads_family(x) for x in n.args):
                return f"np.divide({a[0]}, {a[1]})"  # two Python floats: inf, not ZeroDivisionError
            return f"({a[0]} / {a[1]})"
        if op == "^":
            return power(a[0], n.payload)
        if op == "cmp":
            text = f"({a[0]} {n.payload} {a[1]})"
            if any(mentions(n, v) for v in subst):
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

    def pair(self, n: Node, subst: dict[str, str]) -> tuple[str, str | None]:
        """cert mode: (value code, error-bound code or None for exact) of an arithmetic term,
        one helper call per operation (certified.py), each in a temporary."""
        op = n.op
        if op == "const":
            return certified.constant(n.payload)
        if op not in ("+", "*", "neg", "/", "^"):
            v = self.code(n, subst)
            return v, self.errors.get(v)
        if op == "neg":
            v, e = self.pair(n.args[0], subst)
            return f"(-{v})", e
        if op == "^":
            base = self.pair(n.args[0], subst)
            if n.payload == 0:
                return "1.0", None
            args, op = [base] * n.payload, "*"
        else:
            args = [self.pair(x, subst) for x in n.args]
        if op == "*":  # a factor of exactly ±1 changes nothing but the sign: no rounding, no bound
            sign = [a for a in args if a[1] is None and a[0] in ("1.0", "-1.0")]
            args = [a for a in args if a not in sign] or [("1.0", None)]
            if sum(a[0] == "-1.0" for a in sign) % 2:
                args[0] = (f"(-{args[0][0]})", args[0][1])
        acc = args[0]
        for b in args[1:]:
            acc = self._temporary(certified.operation(op, acc, b))
        return acc

    def _temporary(self, call: str) -> tuple[str, str]:
        name = self.memo.get(call)
        if name is None:
            self.counter[0] += 1
            name = self.memo[call] = f"_v{self.counter[0]}"
            self.lines.append(f"{name}, {name}_e = {call}")
            self.errors[name] = f"{name}_e"
        return name, f"{name}_e"

    def _compare(self, n: Node, subst: dict[str, str]) -> str:
        """cert mode: the float comparison; the mask where it is NOT certain is named (once
        per pair of values) and noted in `used`, for the caller to fold into _bad where the
        decision matters (certified.py)."""
        a, b = (self.pair(x, subst) for x in n.args)
        text = f"({a[0]} {n.payload} {b[0]})"
        if text in self.shared:
            name = self.shared[text]
        else:
            name = text if any(mentions(n, v) for v in subst) else self._shared(text)
            check = certified.check(a, b)
            if check is not None:
                if f"check {check}" not in self.shared:
                    self.counter[0] += 1
                    self.shared[f"check {check}"] = f"_u{self.counter[0]}"
                    self.lines.append(f"_u{self.counter[0]} = {check}")
                self.uncertain[name] = self.shared[f"check {check}"]
        if name in self.uncertain:
            self.used.append(self.uncertain[name])
        return name

    def _flag(self, uncertain: list[str], where: str | None = None, given: tuple[str, ...] = ()) -> None:
        """Rows where a decision that matters is uncertain go to the exact path: the rows of
        `where` (the mask of the conjuncts `given`; None: every row). A mask already flagged
        under a subset of those conjuncts covers these rows too."""
        for u in dict.fromkeys(uncertain):
            if any(v == u and set(before) <= set(given) for v, before in self.flagged):
                continue
            self.flagged.add((u, tuple(given) if where is not None else ()))
            self.lines.append(f"_bad = _bad | {u}" if where is None else f"_bad = _bad | ({where} & {u})")

    def _quantified(self, n: Node, subst: dict[str, str]) -> str:
        """∀j P(j) over the family's index: P for every member at once, then np.all."""
        bound = n.payload
        if len(bound) != 1 or not is_index_sort(bound[0].sort) or self.index is not None:
            raise refuse(n, "only a quantifier over one family index, outside a foreach, is vectorised")
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
        """var has a new value: shared comparisons and temporaries that read it (directly or
        through another temporary) are stale."""
        stale = {var}
        grew = True
        while grew:
            grew = False
            for call, name in list(self.memo.items()):
                if any(re.search(rf"\b{s}\b", call) for s in stale):
                    del self.memo[call]
                    stale.add(name)
                    grew = True
        self.shared = {t: n for t, n in self.shared.items()
                       if not any(re.search(rf"\b{s}\b", t) for s in stale)}

    def test(self, atom: Node) -> str:
        """`enabled &= ...` for a test; in cert mode its uncertain rows are flagged."""
        self.used = []
        code = self.code(atom)
        self._flag(self.used)
        return self._enabled(code)

    def _enabled(self, masks: str) -> str:
        return f"enabled &= {self.skip} | {masks}" if self.skip else f"enabled &= {masks}"

    # ---------------------------------------------------------------- statements
    def statement(self, p: Program) -> None:
        if isinstance(p, Seq):
            for q in p.parts:
                self.statement(q)
        elif isinstance(p, Assign):
            name = target_name(p.target, self.index)
            value, error = self.value(p.value, {})
            self._assigned(name)
            self.lines.append(f"{name} = {value}")
            self.errors.pop(name, None)
            if error is not None:
                self.lines.append(f"{name}_e = {error}")
                self.errors[name] = f"{name}_e"
            self.local[name] = name
            self.opened.discard(name)
        elif isinstance(p, Havoc) and self.index is not None and target_name(p.target, self.index):
            # an auxiliary value (xtr(i)) that a later test pins down: open until then
            name = target_name(p.target, self.index)
            self.local.pop(name, None)
            self.opened.add(name)
        elif isinstance(p, Choice):
            self.choice(p)
        elif isinstance(p, Test):
            for atom in conjuncts(p.cond):
                if atom.op != "true":
                    self.lines.append(self.test(atom))
        else:
            raise refuse(p, "only assignments, tests, choices and min-updates are vectorised")

    def choice(self, p: Choice) -> None:
        tags = [choice_tag(label, k) for k, label in enumerate(p.labels)]
        alts = [self.alternative(q, tag) for q, tag in zip(p.alternatives, tags)]
        self.lines.append(f"# choice: {' | '.join(p.labels)}")
        for alt, tag, label in zip(alts, tags, p.labels):
            self.lines.extend(alt.lines)
            if self.mode != "cert" or not any(alt.unsure):
                self.lines.append(f"case_{tag} = {' & '.join(alt.mask) if alt.mask else 'True'}  # {label}")
                continue
            # a conjunct's uncertainty matters only where the conjuncts before it hold (the
            # first one that fails is then flagged if it is uncertain itself)
            self.lines.append(f"case_{tag} = {alt.mask[0]}  # {label}")
            self._flag(alt.unsure[0])
            for n, (mask, unsure) in enumerate(zip(alt.mask[1:], alt.unsure[1:]), 1):
                self._flag(unsure, f"case_{tag}", tuple(alt.mask[:n]))
                self.lines.append(f"case_{tag} = case_{tag} & {mask}")
        masks = [f"case_{t}" for t in tags]
        changed = list(dict.fromkeys(v for alt in alts for v in alt.effects))
        nan = "np.nan" if self.mode != "exact" else f"{certified.HELPERS}.NAN"
        for var in changed:
            current = self.local.get(var, nan)
            values = [alt.effects.get(var, (current, self.errors.get(current))) for alt in alts]
            # the first enabled alternative's value (np.where nested from the last: np.select
            # does the same ten times slower on small arrays)
            picked = nan
            for mask, (value, _) in reversed(list(zip(masks, values))):
                picked = f"np.where({mask}, {value}, {picked})"
            self._assigned(var)
            self.lines.append(f"{var} = {picked}")
            self.errors.pop(var, None)
            if any(e is not None for _, e in values):  # cert mode: the chosen value's bound too
                picked = "np.nan"
                for mask, (_, e) in reversed(list(zip(masks, values))):
                    picked = f"np.where({mask}, {e or '0.0'}, {picked})"
                self.lines.append(f"{var}_e = {picked}")
                self.errors[var] = f"{var}_e"
            self.local[var] = var
            self.opened.discard(var)
        self.lines.append(self._enabled(" | ".join(masks)))

    def value(self, n: Node, subst: dict[str, str]) -> tuple[str, str | None]:
        """(value code, error code or None): the error only in cert mode."""
        if self.mode == "cert" and n.sort.is_numeric:
            return self.pair(n, subst)
        return self.code(n, subst), None

    def alternative(self, p: Program, tag: str) -> _Alternative:
        alt = _Alternative()
        opened: list[str] = sorted(self.opened)
        subst: dict[str, str] = {}
        outer, self.lines = self.lines, alt.lines  # what the alternative computes goes with it
        try:
            for q in p.parts if isinstance(p, Seq) else (p,):
                if isinstance(q, Test):
                    for atom in conjuncts(q.cond):
                        solved = next((v for v in opened if v not in subst and mentions(atom, v)), None)
                        if solved is not None:
                            value, divisor = solve(atom, solved)
                            if divisor.op != "const":  # x*1 = 1 needs no guard
                                self.used = []
                                alt.mask.append(self.code(divisor != 0, subst))
                                alt.unsure.append(self.used)
                            v, e = self.value(value, subst)
                            if e is not None:  # cert mode: the temporary itself (shared checks)
                                alt.lines.append(f"# {solved}_{tag} = {v} from {atom}")
                                subst[solved] = v
                                alt.effects[solved] = (v, e)  # x := *; ?x = v  is  x := v
                                continue
                            name = f"{solved}_{tag}"
                            alt.lines.append(f"{name} = {v}  # from {atom}")
                            subst[solved] = name
                            alt.effects[solved] = (name, None)  # x := *; ?x = v  is  x := v
                            continue
                        if atom.op != "true":
                            self.used = []
                            alt.mask.append(self.code(atom, subst))
                            alt.unsure.append(self.used)
                elif isinstance(q, Havoc):
                    name = target_name(q.target, self.index)
                    opened.append(name)
                    subst.pop(name, None)
                elif isinstance(q, Assign):
                    name = target_name(q.target, self.index)
                    alt.effects[name] = self.value(q.value, subst)
                    subst[name] = alt.effects[name][0]
                elif isinstance(q, Choice):
                    raise refuse(q, "a choice nested in an alternative is not vectorised (flatten it "
                                  "into the outer choice)")
                else:
                    raise refuse(q, "only tests, assignments and `x := *` are vectorised inside a choice")
        finally:
            self.lines = outer
        for v in opened:
            if v not in subst and v not in self.opened:
                raise ExtractError(f"`{v} := *` is never pinned down by a test; cannot extract")
        return alt


def _reads_family(n: Node) -> bool:
    return n.op == "select" or any(_reads_family(a) for a in n.args)


def target_name(target: Node, index: str | None) -> str:
    if target.op == "var":
        return target.payload
    if target.op == "select" and len(target.args) == 2 and target.args[1].op == "var" \
            and target.args[1].payload == index:
        return target.args[0].payload
    raise ExtractError(f"cannot vectorise the assignment to `{target}`")


def _emit(step: "Step", mode: str) -> tuple[_Emitter, list[str]]:
    """The step's statements as numpy code in one mode; returns the emitter and the
    variables reduced by a min over a family."""
    em = _Emitter(None, mode)
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
            raise refuse(q, "a single cell's `:= *` outside a foreach is not vectorised")
        elif isinstance(q, Test):
            if any(mentions(q.cond, f) for f in done):
                continue  # foreach's "none done yet" / "all done" tests
            for atom in conjuncts(q.cond):
                pin = family_pin(atom, pending)
                if pin is None:
                    if atom.op != "true":
                        em.lines.append(em.test(atom))
                    continue
                name, value, var = pin
                em.index = var
                try:
                    code, error = em.value(value, {})
                finally:
                    em.index = None
                dtype = "bool" if pending[name].target.sort.range == BOOL else "float"
                em._assigned(name)
                em.lines.append(f"{name} = np.array({code}, dtype={dtype})  # from {brief(atom)}")
                if error is not None:
                    em.lines.append(f"{name}_e = {error}")
                    em.errors[name] = f"{name}_e"
                em.local[name] = name
                del pending[name]
                em.pending.pop(name, None)
        elif isinstance(q, Assign):
            em.statement(q)
        elif isinstance(q, Loop):
            reductions.update(dict.fromkeys(_foreach(em, q)))
        elif isinstance(q, Choice):
            em.choice(q)
        else:
            raise refuse(q, "not a statement of a vectorised controller")
    unpinned = [name for name, was_read in em.pending.items() if was_read]
    if unpinned:
        raise refuse(pending[unpinned[0]], "the step read this family before, and no test "
                      f"`∀j ({unpinned[0]}(j) <-> ...)` pins its new value down")
    return em, list(reductions)


def _separable(step: "Step", outputs: list[str], reductions: list[str]) -> bool:
    """Rows independent: scalar set-up, then foreach loops over every member whose min-
    reductions are the outputs (ctrl2). The exact path then redoes only uncertain rows."""
    for q in step.parts:
        if isinstance(q, Assign) and (q.target.op != "var" or _reads_family(q.value)):
            return False
        if isinstance(q, Loop) and (q.each is None or q.each.member.op != "true"):
            return False
        if isinstance(q, Choice):
            return False
        if isinstance(q, Havoc) and q.target.sort.is_array and not any(
                isinstance(x, Loop) and x.each is not None and x.each.done.payload == q.target.payload
                for x in step.parts):
            return False
        if isinstance(q, Test) and not any(mentions(q.cond, x.each.done.payload) for x in step.parts
                                           if isinstance(x, Loop) and x.each is not None):
            return False
    return set(outputs) <= set(reductions)


def vectorised_source(theorem: Theorem, step: "Step") -> str:
    em, reductions = _emit(step, "cert")
    exact_em, _ = _emit(step, "exact")
    assigned = [v for v in em.local if em.local[v] == v]
    outputs = step_outputs(theorem, step, assigned, [], set())
    params = list(em.reads)
    families = list(em.families)
    check_names(theorem, [*params, *families, *assigned], vectorised=True)
    imports = f"{certified.IMPORT_EXACT}\n\nimport numpy as np\n\n{certified.IMPORT}"
    src = HEADER.format(model=doc_text(theorem.name), model_name=theorem.name,
                        description=doc_text(theorem.description), hash=theorem.content_hash,
                        inputs=params, families=families, what="discrete controller", how=VECTORISED,
                        imports=imports)
    args = ", ".join([*params, *families])
    src += f"\n\ndef {ENTRY}({args}):\n"
    if outputs == ["k"] and "k" in reductions:
        src += ('    """The gain the proof allows, and whether the model has a run at all (if not,\n'
                '    the caller must fall back). Families are 1-D arrays over the boundaries.\n\n'
                '    Every decision is the real-valued model\'s on these inputs, and k is <= its real\n'
                '    value (rounded down): see certiloop.kernel.extract.certified."""\n')
    else:
        returns = ", ".join(outputs)
        src += (f'    """Returns ({returns}, enabled): the values the proof allows, and whether the\n'
                '    model has a run at all (if not, the caller must fall back; the other values are then\n'
                '    meaningless). Families are 1-D numpy arrays over the boundaries (Bool families:\n'
                '    arrays of bool). Every decision is the real-valued model\'s on these inputs, and\n'
                '    real outputs are rounded down: see certiloop.kernel.extract.certified."""\n')
    sorts = {v: sort_of(theorem, v, REAL) for v in [*params, *families, *outputs]}
    src += "    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):\n"
    src += f"        *values, enabled, ok = _filtered({args})  # {', '.join(outputs)}\n"
    src += "    if np.all(ok):\n"
    src += "        return *values, bool(np.all(enabled))\n"
    src += "    # near-ties, or values the floats could not bound: decided exactly, in rationals\n"
    src += f"    if not {certified.HELPERS}.finite({args}):\n"
    src += f"        return {', '.join('np.nan' for _ in outputs)}, False  # not a real state\n"

    def exact_args(rows: str | None) -> str:
        out = []
        for v in params:
            out.append(f"{certified.HELPERS}.exact({v})" if sorts[v] == REAL else v)
        for v in families:
            real = sorts[v].range == REAL
            cut = f"np.asarray({v}, dtype={'float' if real else 'bool'})" + (f"[{rows}]" if rows else "")
            out.append(f"{certified.HELPERS}.exact({cut})" if real else cut)
        return ", ".join(out)

    floor = f"{certified.HELPERS}.floor"
    whole = (f"    *exact, enabled = _exact({exact_args(None)})\n"
             f"    return *({floor}(v) for v in exact), enabled\n")
    if _separable(step, outputs, reductions):
        src += "    if np.ndim(ok) == 0:  # a scalar test was uncertain: the whole step exactly\n"
        src += "".join("    " + line + "\n" for line in whole.splitlines())
        src += "    rows = np.flatnonzero(np.logical_not(ok))  # only those rows: they are independent\n"
        src += f"    *exact, enabled_x = _exact({exact_args('rows')})\n"
        src += (f"    return *(min(v, {floor}(x)) for v, x in zip(values, exact)), "
                "bool(np.all(np.where(ok, enabled, True))) and enabled_x\n")
    else:
        src += whole

    body = _without_dead(em.lines, keep={*outputs, "enabled", "skipped", "_bad"})
    src += f"\n\ndef _filtered({args}):\n"
    src += ('    """Floats with error bounds: the outputs (real ones rounded down) over the rows where\n'
            '    every decision is certain, enabled, and ok: where they are (False: redo exactly)."""\n')
    src += "    enabled = True\n    _bad = False\n"
    for line in body:
        src += f"    {line}\n"
    src += f"    return {', '.join(outputs)}, enabled, np.logical_not(_bad)\n"

    body = _without_dead(exact_em.lines, keep={*outputs, "enabled", "skipped"})
    src += f"\n\ndef _exact({args}):\n"
    src += ('    """The same statements in exact rationals (object arrays of Fractions): the real\n'
            '    model\'s decisions and outputs."""\n')
    src += "    enabled = True\n"
    for line in body:
        src += f"    {line}\n"
    src += f"    return {', '.join(outputs)}, bool(np.all(enabled))\n"
    return src


def family_pin(atom: Node, pending: dict[str, Havoc]) -> tuple[str, Node, str] | None:
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
                and not mentions(other, side.args[0].payload):
            return side.args[0].payload, other, j
    return None


def _without_dead(lines: list[str], keep: set[str]) -> list[str]:
    """Drop assignments whose variable nothing later reads (e.g. the auxiliary tmp and
    xtr once the gain is computed): they cannot change the result."""
    out: list[str] = []
    for line in reversed(lines):
        m = re.match(r"^(\w+)(?:, (\w+))? = ", line)
        names = [g for g in (m.groups() if m else ()) if g]
        if names and not any(n in keep or any(re.search(rf"\b{n}\b", later) for later in out) for n in names):
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
    inner_em = _Emitter(index, em.mode)
    inner_em.local.update({k: v for k, v in em.local.items()})
    inner_em.counter, inner_em.errors, inner_em.memo = em.counter, em.errors, dict(em.memo)
    inner_em.flagged = em.flagged
    if loop.each.member.op != "true":
        inner_em.skip = "skipped"
        inner_em.lines.append(f"skipped = np.logical_not({inner_em.code(loop.each.member)})  "
                              f"# boundaries the loop does not visit")
    reductions: list[tuple[str, str]] = []
    for s in inner:
        red = min_update(s)
        if red is not None:
            var, value = red
            v, e = inner_em.value(value, {})
            if e is not None:  # cert mode: a lower bound, from floats where it is tight
                loose = f"{certified.HELPERS}.loose({v}, {e})"
                inner_em._flag([loose], "np.logical_not(skipped)" if inner_em.skip else None)
                v = f"{certified.HELPERS}.lower({v}, {e})"
            if em.mode == "cert":
                v = f"np.where(_bad, np.inf, {v})"  # the rows the exact path redoes
            reductions.append((var, v))
            continue
        inner_em.statement(s)
        for v in scalars_written(s, inner_em.index):
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


def min_update(p: Program) -> tuple[str, Node] | None:
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


def scalars_written(p: Program, index: str) -> list[str]:
    if isinstance(p, Assign) and p.target.op == "var":
        return [p.target.payload]
    if isinstance(p, (Seq, Choice)):
        parts = p.parts if isinstance(p, Seq) else p.alternatives
        return [v for q in parts for v in scalars_written(q, index)]
    return []
