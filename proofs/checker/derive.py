"""The checker's own proof obligations: a theorem's proof tree re-derived from the theorem and
the recorded rule choices, by symbolic execution (dL's rules, read backwards).

A state is a path condition (facts), an environment (each program variable's current value as
a term over fresh symbols x@n) and the path of step labels taken. Rules:
  x := e      [x:=e]P <-> P(e)                 x := *   fresh symbol, any value
  ?Q          Q joins the facts                a; b     [a][b]P
  a ∪ b       each alternative, its label on the path
  ghost g: F  ∃g F holds under the assumptions; then F is assumed (g is fresh: the claim and
              the program never mention it, so the proof holds whatever g is)
  a* inv J    J holds initially; J -> [a]J (written variables fresh); J -> what follows
  ODE solve   a recorded solution x(s), checked by differentiation; fresh duration t >= 0 with
              the domain along [0, t]; variables take their values at t
  ODE dW      variables fresh, the domain assumed
  ODE dC      each recorded link: holds initially (domain assumed), its rule's premise inside
              the domain after the earlier links; then variables fresh, domain and links assumed
Each leaf is `facts -> goal` with its free symbols read universally. Anything outside this
fragment raises NotCheckable.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test, written
from certiloop.models.lang.terms import REAL, And, Exists, Implies, Node, Var, free_vars, store, substitute
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.checker.defined import defined, divides, settled_conjuncts
from certiloop.proofs.checker.ode_facts import NotCheckable, check_solution, premise, runs_along

FLOW_TIME = Var("s@flow")  # the time variable of a recorded solution


@dataclass(frozen=True)
class Leaf:
    id: str
    path: tuple[str, ...]
    formula: Node


@dataclass(frozen=True)
class State:
    facts: tuple[Node, ...]
    env: dict[str, Node]
    path: tuple[str, ...]

    def value(self, n: Node) -> Node:
        return substitute(n, self.env)

    def assume(self, *fs: Node) -> "State":
        return State(self.facts + tuple(fs), self.env, self.path)

    def bind(self, updates: dict[str, Node]) -> "State":
        return State(self.facts, {**self.env, **updates}, self.path)

    def at(self, label: str) -> "State":
        return State(self.facts, self.env, self.path + (label,))


class Derivation:
    """Obligations of `theorem` with the ODE rules `odes` (program address -> (rule, hint))."""

    def __init__(self, theorem: Theorem, odes: dict[str, tuple[str, object]]) -> None:
        self.theorem, self.odes = theorem, odes
        self.count = 0  # fresh-symbol events: x@1, x@2, ...
        self.leaves: list[Leaf] = []

    def run(self) -> list[Leaf]:
        self.require(State(settled_conjuncts(self.theorem.assumptions), {}, ()), "the assumptions",
                     self.theorem.assumptions)
        start = State((self.theorem.assumptions,), {}, ())
        for name, fact in self.theorem.ghosts:  # fresh names (Theorem checks): one exists, then any
            at = start.at(f"ghost {name}: {fact}")
            self.require(at, f"the fact about the ghost {name}", fact)
            self.emit(at, Exists((free_vars(fact)[name],), fact), "exists")
            start = start.assume(fact)
        self.exec(self.theorem.program, "0", start, self.postcondition)
        return self.leaves

    def postcondition(self, st: State) -> None:
        self.require(st, "the guarantee", self.theorem.guarantee)
        self.emit(st, self.theorem.guarantee, "postcondition")

    def require(self, st: State, what: str, *parts: Node) -> None:
        """A leaf saying that `parts`, evaluated here, never divide by 0 (none when they cannot)."""
        needed = And(*(defined(f) for f in parts))
        if needed.op != "true":
            self.emit(st, needed, f"well-defined: {what} (no division by 0)")

    def emit(self, st: State, goal: Node, what: str) -> None:
        formula = Implies(And(*st.facts), st.value(goal))
        self.leaves.append(Leaf(f"o{len(self.leaves) + 1}", st.path + (what,), formula))

    def fresh(self, name: str, sort, event: int | None = None) -> Node:
        if event is None:
            self.count += 1
            event = self.count
        return Var(f"{name.split('@')[0]}@{event}", sort)

    def havoc(self, st: State, variables: dict[str, Node]) -> State:
        self.count += 1
        return st.bind({nm: self.fresh(nm, v.sort, self.count) for nm, v in variables.items()})

    def write(self, st: State, target: Node, value: Node) -> dict[str, Node]:
        """x := v, or a[i] := v as a := store(a, i, v) with i evaluated in this state."""
        if target.op == "var":
            return {target.payload: value}
        indices: list[Node] = []
        while target.op == "select":
            indices[:0] = target.args[1:]
            target = target.args[0]
        return {target.payload: store(st.value(target), tuple(st.value(i) for i in indices), value)}

    def exec(self, p: Program, at: str, st: State, k: Callable[[State], None]) -> None:
        if isinstance(p, Assign):
            self.require(st, f"`{p}`", *_indices(p.target), p.value)
            k(st.bind(self.write(st, p.target, st.value(p.value))))
        elif isinstance(p, Havoc):
            self.require(st, f"`{p}`", *_indices(p.target))
            k(st.bind(self.write(st, p.target, self.fresh(_root(p.target).payload, p.target.sort))))
        elif isinstance(p, Test):
            self.require(st, f"`{p}`", p.cond)
            k(st.assume(st.value(p.cond)))
        elif isinstance(p, Seq):
            self.sequence(p.parts, at, 0, st, k)
        elif isinstance(p, Choice):
            for n, (label, alt) in enumerate(zip(p.labels, p.alternatives)):
                self.exec(alt, f"{at}.{n}", st.at(label), k)
        elif isinstance(p, Loop):
            self.loop(p, at, st, k)
        elif isinstance(p, ODE):
            self.ode(p, at, st, k)
        else:
            raise NotCheckable(f"the program {type(p).__name__}")

    def sequence(self, parts, at: str, n: int, st: State, k: Callable[[State], None]) -> None:
        if n == len(parts):
            k(st)
            return
        self.exec(parts[n], f"{at}.{n}", st, lambda s: self.sequence(parts, at, n + 1, s, k))

    def loop(self, p: Loop, at: str, st: State, k: Callable[[State], None]) -> None:
        inv = p.invariant if p.invariant is not None else self.theorem.guarantee
        init = st.at(f"{p.label} init")
        self.require(init, "the invariant", inv)
        self.emit(init, inv, "invariant holds initially")
        inside = self.havoc(st, written(p.body))
        inside = inside.assume(inside.value(inv))

        def preserved(s: State) -> None:
            self.require(s, "the invariant", inv)
            self.emit(s, inv, "invariant preserved")

        self.exec(p.body, f"{at}.0", inside.at(f"{p.label} step"), preserved)
        k(inside.at(f"{p.label} use"))

    def ode(self, p: ODE, at: str, st: State, k: Callable[[State], None]) -> None:
        rule, hint = self.odes[at]
        variables = {v.payload: v for v in p.variables}
        if any(divides(f) for f in (p.domain, *(f for _, f in p.eqs))):  # defined wherever it may go
            anywhere = self.havoc(st, variables).at("ODE")
            flow = And(defined(p.domain), Implies(p.domain, And(*(defined(f) for _, f in p.eqs))))
            if flow.op != "true":
                self.emit(anywhere, flow, "well-defined: right-hand side and domain (no division by 0)")
        if rule == "dW":
            after = self.havoc(st, variables)
            k(after.assume(after.value(p.domain)).at("ODE dW"))
        elif rule == "solve":
            if (why := check_solution(p, hint, FLOW_TIME)) is not None:
                raise Rejected(f"ODE at {at}: the recorded solution is wrong: {why}")
            tau = self.fresh("t", REAL)
            along = runs_along(p, hint, tau, FLOW_TIME)
            end = {name: st.value(substitute(x, {FLOW_TIME.payload: tau})) for name, x in hint.items()}
            k(st.assume(tau >= 0, st.value(along)).bind(end).at("ODE solve"))
        elif rule == "dC":
            after = self.havoc(st, variables)
            start = st.assume(st.value(p.domain))
            known = [p.domain]
            for n, (atom, method, cofactor) in enumerate(hint, 1):
                if divides(atom):  # its denominator nonzero all along, given the links before it
                    inside = after.assume(*(after.value(f) for f in known)).at(f"ODE {method} {n}")
                    self.emit(inside, defined(atom), "well-defined: the invariant (no division by 0)")
                self.emit(start.at(f"ODE {method} {n} init"), atom, "holds initially")
                cond = premise(atom, p, method, cofactor)
                if cond is not None:
                    what = "never zero in the domain" if method == "nonzero" else "derivative condition"
                    inside = after.assume(*(after.value(f) for f in known))
                    self.emit(inside.at(f"ODE {method} {n}"), cond, what)
                known.append(atom)
            k(after.assume(*(after.value(f) for f in known)).at("ODE dC/dW"))
        else:
            raise NotCheckable(f"rule ODE {rule} not checkable yet")


def _indices(target: Node) -> tuple[Node, ...]:
    idx: list[Node] = []
    while target.op == "select":
        idx[:0] = target.args[1:]
        target = target.args[0]
    return tuple(idx)


def _root(target: Node) -> Node:
    while target.op == "select":
        target = target.args[0]
    return target


class Rejected(Exception):
    """A step of the certificate is wrong: exit 1, naming it."""

