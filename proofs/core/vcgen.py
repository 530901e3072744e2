"""Proof obligations by symbolic execution (the soundness-critical core).

A symbolic state is a path condition (facts) plus an environment mapping each program
variable to a term over *SSA symbols*. Havoc (x := *, a loop's or an ODE's writes) binds a
variable to a fresh symbol; because old symbols keep their meaning, facts learned earlier
stay true, which is exactly the dL loop/ODE rule's "keep the context of what is not
written". Every leaf emits one obligation `facts -> goal`, closed by reading its free
symbols as universally quantified.

Rules, in dL terms:
  x := e        [x:=e]P   <-> P(e)
  x := *        [x:=*]P   <-> ∀x P              (fresh symbol)
  ?Q            [?Q]P     <-> (Q -> P)          (Q joins the facts)
  a ; b         [a;b]P    <-> [a][b]P
  a ∪ b         [a∪b]P    <-> [a]P ∧ [b]P       (two paths, labelled)
  a* / inv J    init: Γ -> J;  step: J -> [a]J (written vars fresh);  use: J -> P
  ODE           solve (polynomial solution, domain along the whole flow), or a dC chain
                of dI invariants, or dW (written vars fresh, domain assumed)

A guarantee holding a loop inside a modality (models/lang/nesting.py) is taken apart by the
sequent rules before anything is emitted: ∧R (each conjunct), →R (the left joins the facts),
∨R (the other disjuncts false), ∀R (fresh symbols), ∃R (the witness term the theorem gives,
evaluated here), and [a]P by executing a from this state as above, its loops by the loop rule
with their annotation or else the box's own postcondition as invariant. A diamond <a>P there
whose program holds a loop is proved by the runs with at most DIAMOND_ITERATIONS iterations of
each loop (and a flow without a polynomial solution by its run of duration 0): <a'>P -> <a>P
for runs a' among a's, so a proof proves it; a failure is unknown (rule "unrolled"), as more
iterations may reach P. A diamond whose postcondition must itself be executed (<a>[b*]P) is
proved by the one run of a that stays put (`_stay`): assignments done, tests and domains
proved where they stand, loops run zero times.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Callable

from certiloop.models.lang.nesting import divides, has_loop_modality, loop_nesting_problem, positive_form
from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Havoc,
    Loop,
    Program,
    Seq,
    Test,
    is_loop_free,
    written,
)
from certiloop.models.lang.terms import (
    BOOL,
    FALSE,
    REAL,
    TRUE,
    And,
    Exists,
    Implies,
    ModelError,
    Node,
    Not,
    Var,
    free_vars,
    store,
    substitute,
)
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.bounded import ITERATIONS, MAX_PATHS, bounded, unrollable
from certiloop.proofs.core.odes import (
    OdeStep,
    atom_premise,
    default_chain,
    polynomial_solution,
    runs_along,
    solvable,
)
from certiloop.proofs.core.wd import defined, has_division, settled_conjuncts
from certiloop.proofs.core.wdmodal import defined_modal, may_overstate
from certiloop.proofs.core.wp import diamond, expand_modalities, unroll


@dataclass(frozen=True)
class Obligation:
    """A closed first-order formula (free symbols universally quantified) to be proved valid."""

    id: str
    path: str
    formula: Node
    model: str = ""
    abbreviations: dict[str, Node] = field(default_factory=dict, compare=False)
    kind: str = "safety"  # safety | defined (no division by zero) | vacuity (the step has a run)
    # (how, formula): formulas that imply this one by construction, worth trying first
    stronger: tuple[tuple[str, Node], ...] = field(default=(), compare=False)
    # the incomplete proof rule (dW, dI, a loop invariant, ...) this obligation depends on, if
    # any: when it is false, that rule failed to apply, which does not make the claim false.
    # A label for reports; it never changes a verdict (a failed division check past it is not
    # shown as the claim dividing by zero: the state may be one no run reaches).
    rule: str = field(default="", compare=False)
    # (ODE key, link number, "init" | "premise") for the links of an ODE's cut chain, so a
    # planner can see which link failed; a label only
    ode_step: tuple = field(default=(), compare=False)

    @property
    def text(self) -> str:
        return str(self.formula)


class Names:
    """Deterministic fresh-symbol supply: x@1, x@2, ... (users cannot write '@')."""

    def __init__(self) -> None:
        self.count = 0
        self.origin: dict[str, str] = {}  # fresh name -> what it stands for

    def fresh(self, base: Node | str, sort=None, why: str = "", event: int | None = None) -> Node:
        """A fresh symbol; symbols made by one event (one loop's or ODE's havoc) share its
        number, so `px@7, py@7` are visibly the same state."""
        if event is None:
            self.count += 1
            event = self.count
        root = base if isinstance(base, str) else base.payload
        root = root.split("@")[0]
        name = f"{root}@{event}"
        self.origin[name] = why or root
        if sort is None:
            sort = REAL if isinstance(base, str) else base.sort
        return Var(name, sort)


@dataclass
class State:
    facts: tuple[Node, ...]
    env: dict[str, Node]
    path: tuple[str, ...]
    rules: tuple[str, ...] = ()  # incomplete rules on the way here (see Obligation.rule)

    def value(self, n: Node) -> Node:
        return substitute(n, self.env)

    def assume(self, *fs: Node) -> "State":
        return State(self.facts + tuple(fs), self.env, self.path, self.rules)

    def bind(self, updates: dict[str, Node]) -> "State":
        env = dict(self.env)
        env.update(updates)
        return State(self.facts, env, self.path, self.rules)

    def at(self, label: str) -> "State":
        return State(self.facts, self.env, self.path + (label,), self.rules)

    def via(self, label: str, rule: str) -> "State":
        """`at(label)` through an incomplete rule: a false obligation past it is the rule failing."""
        return State(self.facts, self.env, self.path + (label,), self.rules + (rule,))


Emit = Callable[[State, Node, str], None]


@dataclass
class VCGen:
    theorem: Theorem
    # ODE key -> the cut chain to prove it with (from a planner outside the core: any chain
    # is sound, a bad one only fails to prove); without one, the annotated invariants
    plan: dict[tuple, tuple[OdeStep, ...]] = field(default_factory=dict)
    names: Names = field(default_factory=Names)
    obligations: list[Obligation] = field(default_factory=list)
    limit: int | None = None  # more obligations than this: TooManyObligations (a count, not a clock)
    # the postcondition of the box a nested loop sits in: its invariant when it has none
    nested_posts: list[Node] = field(default_factory=list)
    # inside a guarantee taken apart: its parts are checked in more states than the
    # left-to-right reading evaluates them in, so a division there is the proof's failure
    # (unknown), never the claim's (ill-defined)
    taking_apart: bool = False

    # ---- entry point
    def run(self) -> list[Obligation]:
        t = self.theorem
        assumptions = expand_modalities(t.assumptions, self.names)
        settled = State(settled_conjuncts(t.assumptions), {}, ())
        self.require_defined(settled, "the assumptions", t.assumptions)
        for what, condition in t.well_defined:  # a translation's side conditions (kyx square roots)
            self.emit(State((), {}, ()), condition, f"well-defined: {what}", "defined")
        for what, condition in t.defined_if:  # stricter than needed: failing shows nothing
            self.emit(State((), {}, (), ("guarded",)), condition, f"well-defined: {what}", "defined")
        start = State((assumptions,), {}, ())
        for name, fact in t.ghosts:  # fresh constants (theorem.py checks): one exists, then any
            ghost, at = free_vars(fact)[name], start.via(f"ghost {name}: {fact}", "ghost")
            self.require_defined(at, f"the fact about the ghost {name}", fact, annotation=True)
            self.emit(at, Exists((ghost,), fact), "exists")
            start = start.assume(fact)
        self.exec(t.program, start, self.postcondition)
        return self.obligations

    def postcondition(self, st: State) -> None:
        guarantee = positive_form(self.theorem.guarantee, executed)
        if executed(guarantee):
            if why := loop_nesting_problem(guarantee):
                raise ModelError(f"the guarantee holds {why}: not supported")
            self.taking_apart = True
            try:
                self.establish(st, guarantee)
            finally:
                self.taking_apart = False
            return
        self.require_defined(st, "the guarantee", guarantee)
        self.emit(st, guarantee, "postcondition")

    def establish(self, st: State, goal: Node) -> None:
        """Obligations for a goal holding loops inside modalities, by the sequent rules (see
        the module's docstring). Each part is checked defined where it is evaluated, as one
        more thing the proof needs (kind safety: these checks ignore the left-to-right
        reading, so a failing one says unknown, never ill-defined)."""
        if not executed(goal):
            self.require_defined(st, "the guarantee", goal, annotation=True)
            self.emit(st, goal, "postcondition")
            return
        op = goal.op
        if op == "and":
            for n, part in enumerate(goal.args, 1):
                self.establish(st.at(f"conjunct {n}"), part)
        elif op == "implies":
            self.establish(self._assumed(st, goal.args[0]), goal.args[1])
        elif op == "or":
            proved = [n for n, a in enumerate(goal.args) if executed(a)][-1]  # the others: assumed false
            later = goal.args[proved:] if proved < len(goal.args) - 1 else ()
            if any(divides(a) for a in later):
                raise ModelError(f"cannot take apart the disjunction `{goal}` (a division after the part "
                                 "to execute)")
            others = [a for n, a in enumerate(goal.args) if n != proved]
            assumed = others[0] if len(others) == 1 else Node("or", tuple(others), BOOL)  # as written
            self.establish(self._assumed(st, Not(assumed)), goal.args[proved])
        elif op == "forall":
            self.names.count += 1
            event = self.names.count
            st = st.bind({v.payload: self.names.fresh(v, why=f"any {v.payload}", event=event)
                          for v in goal.payload})
            self.establish(st, goal.args[0])
        elif op == "exists":
            self._exists(st, goal)
        elif op == "box":
            post = goal.args[0]
            self.nested_posts.append(TRUE if executed(post) else post)
            try:
                self.exec(goal.payload, st.at(f"[{_short(goal.payload)}]"), lambda s: self.establish(s, post))
            finally:
                self.nested_posts.pop()
        elif op == "diamond" and executed(goal.args[0]):  # <a>[b*]P: by a run of a that stays put
            st = st.via(f"<{_short(goal.payload)}> staying put", "unrolled")
            self.require_defined(st, "the guarantee", goal, annotation=True)
            self._stay(goal.payload, st, lambda s: self.establish(s, goal.args[0]))
        elif op == "diamond" and not expandable(goal.payload):  # fewer runs: see the docstring
            # a flow without a polynomial solution keeps its run of duration 0 (fewer runs again);
            # every run must be defined, not just those kept (a 4th iteration may divide by 0)
            st = st.via(f"<{_short(goal.payload)}> in at most {DIAMOND_ITERATIONS} iterations", "unrolled")
            self.require_defined(st, "the guarantee", goal, annotation=True)
            if not unrollable(goal.payload, DIAMOND_ITERATIONS):  # nested loops: too many runs to try
                self.emit(st, FALSE, f"postcondition (the unrolling has over {MAX_PATHS} paths: not tried)")
                return
            runs = unroll(goal.payload, DIAMOND_ITERATIONS)
            fewer = diamond(runs, expand_modalities(goal.args[0], self.names), self.names, unsolvable="stay")
            self.emit(st, fewer, "postcondition")
        else:  # a diamond or a negation: expanded exactly if it can be (wp.py says why not)
            self.require_defined(st, "the guarantee", goal, annotation=True)
            self.emit(st, goal, "postcondition")

    def _stay(self, p: Program, st: State, k: Callable[[State], None]) -> None:
        """<p>P by the one run of p that changes nothing but its assignments: a flow for no
        time (its domain must hold), a loop's zero iterations, every test true. That run is one
        of p's, so <p>P follows from P after it. A choice or x := * would need a witness."""
        if isinstance(p, Assign):
            k(st.bind(self._write(st, p.target, st.value(p.value))))
        elif isinstance(p, (Test, ODE)):
            cond, what = (p.cond, "the test holds") if isinstance(p, Test) else (
                p.domain, "the domain holds (a flow for no time)")
            self.emit(st, cond, what)
            k(st.assume(st.value(expand_modalities(cond, self.names))))
        elif isinstance(p, Loop):
            k(st)
        elif isinstance(p, Seq):
            self._stay_along(p.parts, st, k)
        else:
            raise ModelError(f"a diamond over `{_short(p)}` before a loop or an unsolved flow in its "
                             "postcondition is not supported (a choice or x := * needs a witness)")

    def _stay_along(self, parts: tuple[Program, ...], st: State, k: Callable[[State], None]) -> None:
        if not parts:
            k(st)
            return
        self._stay(parts[0], st, lambda s: self._stay_along(parts[1:], s, k))

    def _assumed(self, st: State, fact: Node) -> State:
        """st with fact assumed; a loop (or an unsolved flow) in its modalities bounded by
        bounded.py to a weaker fact, which is all a proof may use (rule "unrolled")."""
        self.require_defined(st, "the guarantee", fact, annotation=True)
        weaker = bounded(fact, DIAMOND_ITERATIONS, solvable)
        if weaker is not fact:
            st = st.via(f"assumed with at most {DIAMOND_ITERATIONS} iterations", "unrolled")
        return st.assume(st.value(expand_modalities(weaker, self.names, positive=False)))

    def _exists(self, st: State, goal: Node) -> None:
        """∃R: the body at the theorem's witness terms, each evaluated in this state (so a
        program in the body that writes a symbol of the term does not change it)."""
        # defined for every value of the variables, as the claim reads `\exists`, not just at the
        # witness the body is then taken apart at
        self.require_defined(st, "the guarantee", goal, annotation=True)
        chosen = dict(self.theorem.witnesses)
        missing = [v.payload for v in goal.payload if v.payload not in chosen]
        if missing:  # nothing to prove it with: an obligation that cannot be proved
            self.emit(st.via(f"∃{missing[0]}", "witness"), FALSE, f"a witness for ∃{missing[0]}")
            return
        values = {}
        for v in goal.payload:
            w = chosen[v.payload]
            if w.sort != v.sort or w.sort == BOOL:
                raise ModelError(f"the witness `{w}` for ∃{v.payload} has sort {w.sort}, not {v.sort}")
            self.require_defined(st, f"the witness for ∃{v.payload}", w, annotation=True)
            values[v.payload] = st.value(w)
        self.establish(st.bind(values).via(f"∃{','.join(values)}", "witness"), goal.args[0])

    def emit(self, st: State, goal: Node, what: str, kind: str = "safety", step: tuple = ()) -> None:
        goal = st.value(expand_modalities(goal, self.names, positive=True))
        facts = st.facts
        path = " / ".join(st.path + (what,))
        if self.limit is not None and len(self.obligations) >= self.limit:
            raise TooManyObligations(f"the proof has more than {self.limit:,} obligations (the program's "
                                     "paths multiply); none was tried")
        oid = f"o{len(self.obligations) + 1}"
        self.obligations.append(Obligation(oid, path, Implies(And(*facts), goal), self.theorem.name,
                                           self.theorem.abbreviations, kind, rule=_blamed(st.rules),
                                           ode_step=step))

    def require_defined(self, st: State, what: str, *parts: Node, annotation: bool = False) -> None:
        """An obligation that the terms and formulas `parts`, evaluated in this state, never
        divide by zero, the programs of their modalities along their runs (wdmodal.py). For
        the claim's own parts that makes the claim meaningful (kind `defined`); for an
        annotation (an invariant), or where the check asks more than the runs need, it is one
        more thing the proof needs (a failure is unknown)."""
        needed = And(*(defined_modal(f, self.names) if f.sort == BOOL else defined(f) for f in parts))
        if needed.op == "true":
            return
        overstated = any(f.sort == BOOL and may_overstate(f) for f in parts)
        self.emit(st, needed, f"well-defined: {what} (no division by 0)",
                  "safety" if annotation or self.taking_apart or overstated else "defined")

    def havoc(self, st: State, variables: dict[str, Node], why: str) -> State:
        self.names.count += 1
        event = self.names.count
        return st.bind({nm: self.names.fresh(v, why=f"{nm} {why}", event=event)
                        for nm, v in variables.items()})

    # ---- the rules
    def exec(self, p: Program, st: State, k: Callable[[State], None]) -> None:
        if isinstance(p, (Assign, Havoc, Test)):
            k(self._step(p, st))
        elif isinstance(p, Seq):
            self._seq(p.parts, st, k)
        elif isinstance(p, Choice):
            for label, alt in zip(p.labels, p.alternatives):
                self.exec(alt, st.at(label), k)
        elif isinstance(p, Loop):
            self._loop(p, st, k)
        elif isinstance(p, ODE):
            self._ode(p, st, k)
        else:  # pragma: no cover
            raise TypeError(p)

    def _step(self, p: Assign | Havoc | Test, st: State) -> State:
        """The state after a statement with exactly one successor."""
        if isinstance(p, Assign):
            self.require_defined(st, f"`{p}`", *_indices(p.target), p.value)
            return st.bind(self._write(st, p.target, st.value(p.value)))
        if isinstance(p, Havoc):
            self.require_defined(st, f"`{p}`", *_indices(p.target))
            return st.bind(self._write(st, p.target, self.names.fresh(_root(p.target).payload,
                                                                      p.target.sort, "chosen")))
        self.require_defined(st, f"`{p}`", p.cond)
        return st.assume(st.value(expand_modalities(p.cond, self.names, positive=False)))

    def _seq(self, parts: tuple[Program, ...], st: State, k: Callable[[State], None], start: int = 0) -> None:
        """Straight-line statements in a loop (no continuation frame each: a program of
        10,000 assignments does not nest 10,000 calls); a branching one continues at the next."""
        i = start
        while i < len(parts) and isinstance(parts[i], (Assign, Havoc, Test)):
            st = self._step(parts[i], st)
            i += 1
        if i == len(parts):
            k(st)
            return
        self.exec(parts[i], st, lambda s: self._seq(parts, s, k, i + 1))

    def _write(self, st: State, target: Node, value: Node) -> dict[str, Node]:
        if target.op == "var":
            return {target.payload: value}
        root = _root(target)
        indices = tuple(st.value(i) for i in _indices(target))
        return {root.payload: store(st.value(root), indices, value)}

    def _loop(self, p: Loop, st: State, k: Callable[[State], None]) -> None:
        inv = p.invariant
        if inv is None and self.nested_posts:
            inv = self.nested_posts[-1]
        elif inv is None:
            guarantee = self.theorem.guarantee
            inv = TRUE if executed(guarantee) else guarantee
        # with the guarantee as invariant, "holds initially" is exact: zero iterations are a run
        init = st.at(f"{p.label} init") if p.invariant is None else st.via(f"{p.label} init", "loop-init")
        assumed = "guarantee-as-invariant" if p.invariant is None else "loop-invariant"
        self.require_defined(init, "the invariant", inv, annotation=True)
        self.emit(init, inv, "invariant holds initially")
        inside = self.havoc(st, written(p.body), f"in {p.label}")
        inside = inside.assume(inside.value(expand_modalities(inv, self.names)))

        def preserved(s: State) -> None:
            self.require_defined(s, "the invariant", inv, annotation=True)
            self.emit(s, inv, "invariant preserved")

        self.exec(p.body, inside.via(f"{p.label} step", assumed), preserved)
        k(inside.via(f"{p.label} use", assumed))

    def _ode_region(self, p: ODE, st: State) -> None:
        """Wherever the flow may go (any values of its variables inside the domain), its
        right-hand sides are defined, and the domain everywhere. (The links of a cut chain are
        checked defined in _ode_cuts, against the links that really precede them.) A condition
        on the flow's own variables asks more than its runs need (x = 1 -> [{x' = 1, y' = 1/x}]
        never divides by 0), so its failure is unknown, not ill-defined."""
        if not any(has_division(f) for f in (p.domain, *(f for _, f in p.eqs))):
            return
        anywhere = self.havoc(st, {v.payload: v for v in p.variables}, "anywhere the ODE may go").at("ODE")
        flow = And(defined(p.domain), Implies(p.domain, And(*(defined(f) for _, f in p.eqs))))
        if flow.op != "true":
            mentioned = free_vars(flow)
            stricter = any(v.payload in mentioned for v in p.variables)
            self.emit(anywhere, flow, "well-defined: right-hand side and domain (no division by 0)",
                      "safety" if self.taking_apart or stricter else "defined")

    def _ode(self, p: ODE, st: State, k: Callable[[State], None]) -> None:
        self._ode_region(p, st)
        chain = self.plan.get(p.key)
        if chain is None and p.invariants:
            chain = default_chain(p)
        if chain is not None and (chain or p.invariants):
            self._ode_cuts(p, chain, st, k)
            return
        s = Var("s@flow")
        sol = polynomial_solution(p, s)
        if sol is None:  # differential weakening: anything inside the domain
            after = self.havoc(st, {v.payload: v for v in p.variables}, "after ODE")
            k(after.assume(after.value(p.domain)).via("ODE dW", "dW"))
            return
        tau = self.names.fresh("t", why="ODE duration")
        along = runs_along(p, sol, tau, s)
        end = {name: st.value(substitute(x, {s.name: tau})) for name, x in sol.items()}
        k(st.assume(tau >= 0, st.value(along)).bind(end).at("ODE solve"))

    def _ode_cuts(self, p: ODE, chain: tuple[OdeStep, ...], st: State, k: Callable[[State], None]) -> None:
        """dC chain: each link holds initially (where the domain does: a flow starts inside
        it) and its rule's premise holds inside the domain, assuming the earlier links only.
        A link that divides is first shown defined there, assuming the same links (so its
        denominator is nonzero all along the flow, where the link is differentiable): a plan
        may have dropped an annotation that another one's denominator relied on."""
        after = self.havoc(st, {v.payload: v for v in p.variables}, "during ODE")
        start = st.assume(st.value(p.domain))
        known = [p.domain]
        for n, step in enumerate(chain, 1):
            if has_division(step.atom):
                inside = after.assume(*(after.value(f) for f in known)).at(f"ODE {step.method} {n}")
                # kind safety, not defined: an ill-defined annotation is the proof's failure,
                # not a division in the claim itself
                self.emit(inside, defined(step.atom), "well-defined: the invariant (no division by 0)",
                          step=(p.key, n, "premise"))
            self.emit(start.via(f"ODE {step.method} {n} init", "dI-init"), step.atom, "holds initially",
                      step=(p.key, n, "init"))
            cond = atom_premise(step.atom, p, step.method, step.cofactor)
            if cond is not None:
                self.emit(after.assume(*(after.value(f) for f in known)).via(f"ODE {step.method} {n}", "dI"),
                          cond, PREMISE_NAMES.get(step.method, "derivative condition"),
                          step=(p.key, n, "premise"))
            known.append(step.atom)
        k(after.assume(*(after.value(f) for f in known)).via("ODE dC/dW", "dC"))


# what a link's premise is called in the proof tree (the nonzero rule asks no derivative)
PREMISE_NAMES = {"nonzero": "never zero in the domain"}

# which incomplete rule to blame when several lie on a path: an ODE that lost information
# explains a failure downstream better than the loop around it
BLAME_ORDER = ("dW", "dI", "dI-init", "dC", "guarantee-as-invariant", "loop-invariant", "loop-init",
               "witness", "ghost", "unrolled", "guarded")
DIAMOND_ITERATIONS = ITERATIONS  # a loop inside a diamond: the runs with at most this many iterations


def _blamed(rules: tuple[str, ...]) -> str:
    return min(rules, key=BLAME_ORDER.index, default="")


def executed(f: Node) -> bool:
    """Does f hold a modality the core executes (the sequent rules, then its program by the
    rules above) rather than expands exactly (wp.py): one holding a loop, or an ODE without a
    polynomial solution?"""
    return has_loop_modality(f) or _unsolved_modality(f)


def expandable(p: Program) -> bool:
    """Can wp.py write [p]P and <p>P exactly: no loop, and every flow solved in polynomials?"""
    return is_loop_free(p) and all(solvable(ode) for ode in _odes(p))


def _unsolved_modality(f: Node) -> bool:
    if f.op in ("box", "diamond") and any(not solvable(ode) for ode in _odes(f.payload)):
        return True
    return any(_unsolved_modality(a) for a in f.args)


def _odes(p: Program) -> list[ODE]:
    if isinstance(p, ODE):
        return [p]
    return [ode for q in (p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice)
                          else (p.body,) if isinstance(p, Loop) else ()) for ode in _odes(q)]


def _short(p: Program, width: int = 32) -> str:
    text = " ".join(re.sub(r"/\*.*?\*/", "", str(p)).split())
    return text if len(text) <= width else text[:width - 3] + "..."


def _root(target: Node) -> Node:
    while target.op == "select":
        target = target.args[0]
    return target


def _indices(target: Node) -> tuple[Node, ...]:
    idx: list[Node] = []
    while target.op == "select":
        idx[:0] = target.args[1:]
        target = target.args[0]
    return tuple(idx)


class TooManyObligations(ModelError):
    """The proof would need more obligations than the caller's limit: nothing can be proved
    (a deterministic count, so the verdict does not depend on the machine)."""


def generate(theorem: Theorem, plan: dict[tuple, tuple[OdeStep, ...]] | None = None,
             limit: int | None = None) -> list[Obligation]:
    """All proof obligations of a theorem, in proof-tree order; `plan` chooses how ODEs are
    proved (see VCGen.plan). With `limit`, TooManyObligations once there would be more."""
    return VCGen(theorem, plan=dict(plan or {}), limit=limit).run()

