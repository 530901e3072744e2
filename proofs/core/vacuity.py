"""Vacuity: a proof of [ctrl*]safe says nothing if the control step can block, so prove
that every part of the program has a run from every state it can start in.

The program is read as sequences of statements split at its loops:

  * a loop-free segment S entered with facts F:       F -> <S> true
  * a loop's body B, entered from its head with facts F ∧ J (J the invariant), for a
    plain loop (the control loop: the step must run) and, for the loops that must run to
    the end, with their entry condition: a `foreach` body after the pick of an unprocessed
    member i (¬done(i) ∧ member(i)), a `for_range` body with counter < limit.

Facts flow forward: a fact survives a statement that writes none of its symbols; a
top-level test adds its condition; after a loop the facts are the survivors, J, and the
loop's exit condition (`∀j (member(j) -> done(j))`, counter >= limit). The facts at a
loop's head hold there because the safety proof shows J inductive: the verdict is
conditional on that proof, as it must be (unreachable states may block).

That a `foreach` or `for_range` loop has a finishing run is a lemma about its shape, not an
obligation: each iteration has a run from every head state (the body obligation) and
marks one more of finitely many elements done (or counts up towards a fixed limit); the
lemma needs the body not to un-mark elements, change membership, or touch the counter or
the limit, which is checked here — where it fails, the obligation is `false` with the
reason in its path. A plain loop may stop after zero iterations, so it never blocks what
follows; its body is still required to run (the step of the control loop).

Loops nested inside a choice are summarised inside the formula as [havoc its writes;
?J ∧ exit] (every state the loop can end in satisfies that, by the safety proof).

Existentials from x := * are eliminated where a test pins a Real x by a linear equation
(u*D = d0 is solvable when D ≠ 0, and then every solution must lead on): see `witnessed`.
"""

from __future__ import annotations

import sympy

from certiloop.models.lang.programs import (
    Assign,
    Choice,
    Havoc,
    Loop,
    Program,
    Seq,
    Test,
    children,
    seq,
    skip,
    written,
)
from certiloop.models.lang.terms import (
    FALSE,
    REAL,
    TRUE,
    And,
    Exists,
    ForAll,
    Implies,
    Node,
    Not,
    Or,
    cmp,
    free_vars,
    rebuild,
    substitute,
)
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.simplify import simplify
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy
from certiloop.proofs.core.vcgen import Names, Obligation
from certiloop.proofs.core.wp import diamond, expand_modalities

LABEL = "control step has a run"


class _Macro:
    """A loop with the statements around it that belong to it: foreach's prefix
    `done := *; ?∀¬done` and exit test, for_range's `counter := lo` and exit test."""

    def __init__(self, kind: str, loop: Loop, length: int, exit: Node) -> None:
        self.kind, self.loop, self.length, self.exit = kind, loop, length, exit


def _macro_at(parts: list[Program], k: int) -> _Macro | None:
    p = parts[k]
    nxt = parts[k + 1:k + 4]
    if isinstance(p, Havoc) and len(nxt) >= 3 and isinstance(nxt[0], Test) and isinstance(nxt[1], Loop) \
            and nxt[1].each is not None and nxt[1].each.done.same(p.target) and isinstance(nxt[2], Test):
        return _Macro("foreach", nxt[1], 4, nxt[2].cond)
    if isinstance(p, Assign) and len(nxt) >= 2 and isinstance(nxt[0], Loop) and nxt[0].count is not None \
            and nxt[0].count.counter.same(p.target) and isinstance(nxt[1], Test):
        return _Macro("for_range", nxt[0], 3, nxt[1].cond)
    if isinstance(p, Loop):
        return _Macro("loop", p, 1, TRUE)
    return None


class _Vacuity:
    def __init__(self, theorem: Theorem) -> None:
        self.theorem = theorem
        self.names = Names()
        self.out: list[Obligation] = []

    # ---------------------------------------------------------------- obligations
    def emit(self, path: str, facts: list[Node], goal: Node, stronger: tuple = ()) -> None:
        self.out.append(Obligation(f"v{len(self.out) + 1}", f"{LABEL} / {path}", Implies(And(*facts), goal),
                                   self.theorem.name, self.theorem.abbreviations, "vacuity", stronger))

    def cannot(self, path: str, why: str) -> None:
        self.emit(f"{path}: {why}", [], FALSE)

    def sequence(self, parts: list[Program], facts: list[Node], where: str) -> list[Node]:
        """Obligations that the statements `parts` have a run from every state satisfying
        `facts`; returns the facts that hold after them."""
        segment: list[Program] = []
        k = 0
        while k < len(parts):
            macro = _macro_at(parts, k)
            if macro is None:
                segment.append(parts[k])
                k += 1
                continue
            facts = self.segment(segment, facts, where)
            segment = []
            facts = self.loop(macro, facts, parts[k:k + macro.length])
            k += macro.length
        return self.segment(segment, facts, where)

    def segment(self, segment: list[Program], facts: list[Node], where: str) -> list[Node]:
        if not segment:
            return facts
        body = seq(*segment)
        runs = simplify(read_over_write(self.runs(body, TRUE)))
        strong = simplify(witnessed(runs, self.names, every_input=True))
        self.emit(f"{where}{_describe(segment)}", facts, simplify(witnessed(runs, self.names)),
                  stronger=(("every input", Implies(And(*facts), strong)),))
        after = _surviving(facts, body)
        for p in segment:  # a test at the top of the segment holds after it, if nothing later undoes it
            if isinstance(p, Test):
                later = seq(*segment[segment.index(p) + 1:]) if p is not segment[-1] else None
                if later is None or not set(free_vars(p.cond)) & set(written(later)):
                    after.append(p.cond)
        return after

    def loop(self, macro: _Macro, facts: list[Node], statements: list[Program]) -> list[Node]:
        loop = macro.loop
        invariant = loop.invariant if loop.invariant is not None else self.theorem.guarantee
        head = _surviving(facts, seq(*statements)) + _conjuncts(invariant)
        label = loop.label
        body = list(loop.body.parts) if isinstance(loop.body, Seq) else [loop.body]
        if macro.kind == "foreach":
            each = loop.each
            pick, rest = body[:2], body[2:]
            inner = seq(*rest[:-1]) if len(rest) > 1 else skip()
            protected = {each.done.payload, each.index.payload} | set(free_vars(each.member))
            touched = set(written(inner)) & protected
            if len(pick) < 2 or not isinstance(pick[0], Havoc) or not isinstance(pick[1], Test):
                self.cannot(f"{label} body", "a foreach body without its pick")
            elif touched:
                self.cannot(f"{label} body", f"the body writes {', '.join(sorted(touched))}, so the loop "
                            "may not finish (it must not un-mark elements or change which are members)")
            else:
                self.sequence(rest, head + [Not(each.done(each.index)), each.member], f"{label} body / ")
        elif macro.kind == "for_range":
            count = loop.count
            inner = seq(*body[1:-1]) if len(body) > 2 else skip()
            touched = set(written(inner)) & ({count.counter.payload} | set(free_vars(count.limit)))
            if touched:
                self.cannot(f"{label} body", f"the body writes {', '.join(sorted(touched))}, so the "
                            "counter may never reach its limit")
            else:
                self.sequence(body[1:], head + [count.counter < count.limit], f"{label} body / ")
        else:
            self.sequence(body, head, f"{label} step / ")
        return head + _conjuncts(macro.exit)

    # ---------------------------------------------------------------- <p>post, loops summarised
    def runs(self, p: Program, post: Node) -> Node:
        if isinstance(p, Seq):
            parts = list(p.parts)
            k = len(parts)
            while k > 0:
                macro = next((m for j in range(max(0, k - 4), k) if (m := _macro_at(parts, j)) is not None
                              and j + m.length == k), None)
                if macro is not None:
                    post = self.summary(macro, parts[k - macro.length:k], post)
                    k -= macro.length
                else:
                    post = self.runs(parts[k - 1], post)
                    k -= 1
            return post
        if isinstance(p, Choice):
            return Or(*(self.runs(q, post) for q in p.alternatives))
        if isinstance(p, Loop):  # a plain loop nested in a choice: zero iterations is a run
            self.loop(_Macro("loop", p, 1, TRUE), [], [p])
            return post
        return diamond(p, post, self.names, unsolvable="stay", family_witnesses=True)

    def summary(self, macro: _Macro, statements: list[Program], post: Node) -> Node:
        """[havoc what the loop writes; ?J ∧ exit] post, with its body obligations emitted
        (for a loop not at the top of a sequence: only the theorem's stable facts known)."""
        if macro.kind == "loop":
            self.loop(macro, self.stable(), statements)
            return post  # zero iterations
        self.loop(macro, self.stable(), statements)
        loop = macro.loop
        invariant = loop.invariant if loop.invariant is not None else self.theorem.guarantee
        changed = written(seq(*statements))
        self.names.count += 1
        fresh = {n: self.names.fresh(v, event=self.names.count) for n, v in changed.items()}
        end = And(invariant, macro.exit)
        return ForAll(tuple(fresh.values()), Implies(substitute(end, fresh), substitute(post, fresh)))

    def stable(self) -> list[Node]:
        return _surviving(_conjuncts(expand_modalities(self.theorem.assumptions, self.names)),
                          self.theorem.program)


def nonblocking_obligations(theorem: Theorem) -> list[Obligation]:
    """The obligations whose validity shows that the theorem's program — and the body of
    every loop in it — has a run from every state it can start in (given the safety proof)."""
    v = _Vacuity(theorem)
    program = theorem.program
    parts = list(program.parts) if isinstance(program, Seq) else [program]
    v.sequence(parts, _conjuncts(expand_modalities(theorem.assumptions, v.names)), "")
    return v.out


def _surviving(facts: list[Node], p: Program) -> list[Node]:
    changed = set(written(p))
    return [f for f in facts if not set(free_vars(f)) & changed]


def _describe(segment: list[Program]) -> str:
    text = str(seq(*segment)).split("\n")[0].strip().rstrip(";")
    return f"statements from `{text}`" if len(segment) > 1 else f"`{text}`"


def _conjuncts(f: Node) -> list[Node]:
    if f.op == "and":
        return [c for a in f.args for c in _conjuncts(a)]
    return [] if f.op == "true" else [f]


def loops_in(p: Program) -> list[Loop]:
    out = [p] if isinstance(p, Loop) else []
    for q in children(p):
        out += loops_in(q)
    return out


# --------------------------------------------------------------------------- witnesses


def read_over_write(f: Node) -> Node:
    """a{i := v}[i] -> v (same index written and read), so that u{i := u@3}[i]*D = d0 is
    seen as the linear equation u@3*D = d0 it is."""
    if not f.args:
        return f
    f = rebuild(f, tuple(read_over_write(a) for a in f.args))
    if f.op == "select" and f.args[0].op == "store":
        stored = f.args[0].args
        read, written_at = f.args[1:], stored[1:-1]
        if len(read) == len(written_at) and all(a.same(b) for a, b in zip(read, written_at)):
            return stored[-1]
    return f


def witnessed(f: Node, names: Names, every_input: bool = False) -> Node:
    """A quantifier-lighter formula that implies f: ∃x (a·x + b = 0 ∧ ψ), for a Real x and a
    free of x, becomes  a ≠ 0 ∧ (a·x' + b = 0 -> ψ[x'])  with x' a new symbol left free (so
    universally quantified when the obligation is closed). That is sound because x' appears
    nowhere else (a fresh name per occurrence: a symbol shared by two disjuncts would let
    each disjunct pick the other's solution), it sits in positive position (∀ passes
    through ∧, ∨ and the right of ->), and a ≠ 0 makes the equation solvable: taking x' its
    solution gives ψ. But x is only freed when its equation mentions no variable that stays
    existential around it: ∀x' ∃y (eq(x', y) -> ...) would let y dodge the equation, so
    such an x stays existential too (∃y ∃x, the original). No division appears, so the
    arithmetic stays polynomial.

    every_input: also free (read as ∀) the values chosen by `x := *` that no equation pins
    — the controller's inputs. ∀x ψ implies ∃x ψ, so this is a strengthening too, and the
    stronger claim is the one an engineer wants: the step runs whatever the inputs are."""
    return _witnessed(f, names, frozenset(), every_input)


def _witnessed(f: Node, names: Names, kept: frozenset[str], every_input: bool) -> Node:
    """`kept`: the existential variables that stay quantified around f."""
    if f.op == "exists":
        return _exists(list(f.payload), f.args[0], names, kept, every_input)
    if f.op in ("and", "or"):
        return (And if f.op == "and" else Or)(*(_witnessed(a, names, kept, every_input) for a in f.args))
    return f


def _exists(variables: list[Node], body: Node, names: Names, kept: frozenset[str], every_input: bool) -> Node:
    if body.op == "or":  # ∃x (a ∨ b)  ≡  ∃x a ∨ ∃x b
        return Or(*(_exists(variables, d, names, kept, every_input) for d in body.args))
    own = [x for x in variables if x.payload in free_vars(body)]
    slopes = {x.payload: _linear_slope(x, body) for x in own}
    inputs = {x.payload for x in own if every_input and slopes[x.payload] is None
              and names.origin.get(x.payload) == "chosen"}
    stay = {x.payload for x in own if slopes[x.payload] is None} - inputs
    changed = True
    while changed:  # an equation over a variable that stays keeps its own variable too
        changed = False
        for x in own:
            slope = slopes[x.payload]
            if x.payload in stay or slope is None:
                continue
            deps = (set(free_vars(slope[1])) | set(free_vars(slope[0]))) - {x.payload}
            if deps & (stay | kept):
                stay.add(x.payload)
                changed = True
    body = _witnessed(body, names, kept | stay, every_input)
    renamed: dict[str, Node] = {}
    for x in own:
        if x.payload in stay:
            continue
        if x.payload not in inputs:
            a, equation = slopes[x.payload]
            body = And(cmp("!=", a, 0), Implies(equation, body))
        renamed[x.payload] = names.fresh(x, x.sort, "witness")
    # all at once (the fresh names are new, so renaming in one pass or one by one agrees)
    body = substitute(body, renamed)
    left = tuple(x for x in own if x.payload in stay)
    return Exists(left, body) if left else body


def _linear_slope(x: Node, body: Node) -> tuple[Node, Node] | None:
    """(a, the equation) for a conjunct equation a·x + b = 0 with a free of x, x Real."""
    if x.sort != REAL:
        return None  # an integer solution of a·x + b = 0 need not exist
    for c in _conjuncts(body):
        if c.op == "cmp" and c.payload == "==" and x.payload in free_vars(c):
            table = SympyTable()
            try:
                expr = sympy.expand(to_sympy(c.args[0], table) - to_sympy(c.args[1], table))
            except TypeError:
                continue
            xs = table.symbol(x)
            if expr.is_polynomial(xs) and sympy.degree(expr, xs) == 1:
                slope = expr.coeff(xs, 1)
                if xs not in slope.free_symbols and not _has_denominator(slope):
                    return from_sympy(slope, table), c
    return None


def _has_denominator(e) -> bool:
    """A denominator that is not a constant (1/2 is fine; 1/x would need x ≠ 0). Without a
    negative power of a non-constant there is none, and `together` (a third of building
    the vacuity obligations) is not needed to say so."""
    if not any(p.is_Pow and p.exp.is_negative and not p.base.is_number for p in sympy.preorder_traversal(e)):
        return False
    return not sympy.fraction(sympy.together(e))[1].is_number


