"""Bounded runs as one formula of linear size (for refutation).

[a ∪ b]R = [a]R ∧ [b]R copies R into every branch, so a loop body with 140 branches
unrolled twice would copy the rest of the program 140² times. Instead, each loop-free
program becomes a *transition relation*: constraints over fresh symbols, where a choice
merges the branches' values into fresh merge symbols:

    x := e     x@k = e                       ?Q       Q
    x := *     x@k fresh                     a; b     both, in order
    a ∪ b      ∨_i (C_i ∧ m = value_i)       ODE      τ ≥ 0, domain along [0,τ], x@k = x(τ)

A model of  assumptions ∧ C ∧ ¬guarantee(final values)  is a violating run: an initial
state, the chosen values and the ODE durations. ODEs without a polynomial solution are left
out (no runs through them), which only makes the search miss runs, never invent them.
"""

from __future__ import annotations

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import (
    BOOL,
    FALSE,
    REAL,
    And,
    Iff,
    Node,
    Or,
    Var,
    cmp,
    store,
    substitute,
)
from certiloop.proofs.core.odes import runs_along
from certiloop.proofs.core.wp import expand_modalities, flow_solution


def _equal(a: Node, b: Node) -> Node:
    return Iff(a, b) if a.sort == BOOL else cmp("==", a, b)


class Encoder:
    def __init__(self, names) -> None:
        self.names = names
        self.record: dict[int, str] = {}  # statement occurrence -> its fresh symbol

    def _bind(self, name: str, sort, value: Node, constraints: list[Node]) -> Node:
        if value.op in ("var", "const", "true", "false") and (value.sort == sort or sort is None):
            return value
        if value.op == "const" and sort == REAL:  # `x := 0` keeps x real (a merge takes its sort)
            return Node("const", (), REAL, value.payload)
        fresh = self.names.fresh(name, sort, "value")
        constraints.append(_equal(fresh, value))
        return fresh

    def run(self, p: Program, env: dict[str, Node]) -> tuple[list[Node], dict[str, Node]]:
        val = lambda n: substitute(n, env)  # noqa: E731
        if isinstance(p, Assign):
            cs: list[Node] = []
            target = p.target
            if target.op == "var":
                return cs, {**env, target.payload: self._bind(target.payload, target.sort, val(p.value), cs)}
            idx: list[Node] = []
            root = target
            while root.op == "select":
                idx[:0] = root.args[1:]
                root = root.args[0]
            new = store(val(root), tuple(val(i) for i in idx), val(p.value))
            return cs, {**env, root.payload: self._bind(root.payload, root.sort, new, cs)}
        if isinstance(p, Havoc):
            target = p.target
            root = target
            while root.op == "select":
                root = root.args[0]
            fresh = self.names.fresh(root.payload, target.sort, "chosen")
            self.record[id(p)] = fresh.payload
            if target.op == "var":
                return [], {**env, target.payload: fresh}
            idx = list(target.args[1:])
            new = store(val(target.args[0]), tuple(val(i) for i in idx), fresh)
            cs = []
            return cs, {**env, root.payload: self._bind(root.payload, root.sort, new, cs)}
        if isinstance(p, Test):  # a modal test by its first-order equivalent, as the prover reads it
            return [val(expand_modalities(p.cond, self.names))], env
        if isinstance(p, Seq):
            cs = []
            for q in p.parts:
                more, env = self.run(q, env)
                cs.extend(more)
            return cs, env
        if isinstance(p, Choice):
            return self._choice(p, env)
        if isinstance(p, ODE):
            return self._ode(p, env)
        if isinstance(p, Loop):
            raise ValueError("unroll loops before encoding a bounded run")
        raise TypeError(p)

    def _choice(self, p: Choice, env: dict[str, Node]):
        branches = [self.run(q, env) for q in p.alternatives]
        changed = sorted({name for _, e in branches for name, v in e.items()
                          if name not in env or not v.same(env[name])})
        merged = dict(env)
        for name in changed:
            sort = next(e[name].sort for _, e in branches if name in e)
            merged[name] = self.names.fresh(name, sort, "merge")
        options = []
        for cs, e in branches:
            eqs = [_equal(merged[n], e.get(n, env.get(n, Var(n, merged[n].sort)))) for n in changed]
            options.append(And(*cs, *eqs))
        return [Or(*options) if options else FALSE], merged

    def _ode(self, p: ODE, env: dict[str, Node]):
        s, sol = flow_solution(p)
        if sol is None:
            return [FALSE], env
        tau = self.names.fresh("t", None, "ODE duration")
        self.record[id(p)] = tau.payload
        cs = [tau >= 0, substitute(runs_along(p, sol, tau, s), env)]
        new = dict(env)
        for name, x in sol.items():
            value = substitute(substitute(x, {s.payload: tau}), env)
            new[name] = self._bind(name, env.get(name, Var(name)).sort, value, cs)
        return cs, new
