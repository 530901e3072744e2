"""Choosing how each ODE is proved: a differential-cut chain and a rule per link.

This is search, outside the trusted core: the core turns any chain into obligations that are
sound whatever the chain (see proofs/core/odes.py), so a wrong choice here can only fail to
prove. The candidates for an ODE are its annotated invariants, atom by atom, and once those
have settled the guarantee's atoms (negations pushed in: `!(x <= -1 | y <= -1)` gives `x > -1`
and `y > -1`); for an ODE with neither an annotation nor a polynomial solution, the atoms of
the guarantee, the domain and
the assumptions that mention its variables (automatic invariants), with the Darboux
polynomials found by linear algebra (darboux.py: affine systems; darboux_search.py: a
degree-bounded search for nonlinear polynomial ones). A second search, once the first left
obligations open, builds such an ODE's chain from polynomial certificates `V <= c` found by
an SDP (certificates.py), each with the one rule it was made for. Each round generates the
obligations with the current chains and discharges the links' own obligations; then, per
chain, the links that do not hold initially are all dropped (whether a link holds at the
start does not depend on the other links of its chain), or else the first link whose premise
fails tries its next rule (dI, dbx with the quotient of p' by p as cofactor, the strict
barrier, progress), then once the end of the chain (where more atoms are known), then is dropped. The
round count is bounded, so the plan is deterministic; when it runs out, each chain is cut
before its first failing link.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

from certiloop.models.lang.nesting import positive_form
from certiloop.models.lang.programs import ODE, Choice, Loop, Program, Seq, children
from certiloop.models.lang.terms import TRUE, And, Implies, ModelError, Node, Not, cmp, free_vars
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.instantiate import has_quantifier
from certiloop.proofs.core.odes import (
    OdeStep,
    annotated_atoms,
    atom_polynomial,
    atom_premise,
    cofactors,
    conjuncts,
    guarded,
    rational_cofactor,
    solvable,
)
from certiloop.proofs.core.vcgen import Obligation, executed, generate
from certiloop.proofs.core.verdicts import ObligationResult
from certiloop.proofs.core.wd import has_division
from certiloop.proofs.engine.darboux import darboux_atoms
from certiloop.proofs.engine.darboux_search import search_atoms
from certiloop.proofs.engine.first_integrals import integral_atoms

MAX_ROUNDS = 40
MAX_DEFERRALS = 3  # a link that fails moves to the chain's end at most this often
REORDER_OBLIGATIONS = 300  # ... in a proof of at most this many obligations; once in a larger one
# progress asks for p'', which for a cubic field in six variables takes sympy seconds to build
# (Yang Wu Lin C7: 4.5 s) and z3 longer to check; its cases so far are planar
MAX_PROGRESS_VARS = 3
Plan = dict[tuple, tuple[OdeStep, ...]]


def odes_of(p: Program) -> list[ODE]:
    """The ODEs of a program, in program order, each once."""
    found: dict[tuple, ODE] = {}

    def walk(q: Program) -> None:
        if isinstance(q, ODE):
            found.setdefault(q.key, q)
        elif isinstance(q, Seq):
            for part in q.parts:
                walk(part)
        elif isinstance(q, Choice):
            for alt in q.alternatives:
                walk(alt)
        elif isinstance(q, Loop):
            walk(q.body)

    walk(p)
    return list(found.values())


def theorem_odes(theorem: Theorem) -> list[ODE]:
    """The ODEs the core proves by a chain: the program's, and those of the guarantee's boxes
    that it executes (a loop, or a flow without a polynomial solution: a diamond's too, which a
    negation turns into a box); a box it expands exactly needs no chain."""
    found = {ode.key: ode for ode in odes_of(theorem.program)}

    def walk(f: Node) -> None:
        if f.op in ("box", "diamond") and executed(f):
            for ode in odes_of(f.payload):
                found.setdefault(ode.key, ode)
        for a in f.args:
            walk(a)

    walk(theorem.guarantee)
    return list(found.values())


def around(theorem: Theorem, ode: ODE) -> Node:
    """The invariants of the program's loops whose body holds the ODE: what a flow that ends
    a loop's body must give."""
    found: list[Node] = []

    def walk(q: Program) -> None:
        if isinstance(q, Loop) and q.invariant is not None and ode.key in {o.key for o in odes_of(q.body)}:
            found.append(q.invariant)
        for part in children(q):
            walk(part)

    walk(theorem.program)
    return And(*found)


def goals(f: Node) -> Node:
    """What must hold inside a guarantee the core takes apart: the postconditions of its
    boxes, as a conjunction; any other guarantee is itself. (The left sides of its
    implications are not made candidates: for stability they are the ball of starts, and a
    seven-variable flow's 14 box bounds cost Laub-Loomis 49 s of trials.)"""
    if not executed(f):
        return f
    if f.op in ("box", "diamond"):  # a diamond the core executes: by the run that stays put
        return goals(f.args[0])
    if f.op == "not":  # the core pushes it inward first
        inward = positive_form(f, executed)
        return TRUE if inward.op == "not" else goals(inward)
    if f.op == "implies":
        return goals(f.args[1])
    if f.op in ("and", "or", "forall", "exists"):
        return And(*(goals(a) for a in f.args))
    return TRUE


def _usable(atom: Node, ode: ODE) -> bool:
    """An atom the core can take as a link: a comparison of arithmetic terms with a
    derivative it can compute. A division is checked defined along the flow by the core; it
    is only proposed where each denominator is one the domain keeps away from 0 (a lifted
    root's `s > 0`, Kepler's energy). Proposing every one, a division by a parameter such as
    `1/(L*C)` too, proved the RLC circuit but cost IJRR17 Theorem 13 16 s -> 43 s."""
    if atom.op != "cmp" or not atom.args[0].sort.is_numeric:
        return False
    if has_division(atom) and not all(_kept_nonzero(d, ode) for d in _denominators(atom)):
        return False
    try:
        atom_premise(atom, ode, "dI")
    except (TypeError, ValueError, ModelError):
        return False
    return True


def _denominators(f: Node) -> list[Node]:
    here = [f.args[1]] if f.op == "/" and f.args[1].op != "const" else []
    return here + [d for a in f.args for d in _denominators(a)]


def _kept_nonzero(d: Node, ode: ODE) -> bool:
    return any(c.op == "cmp" and c.payload in (">", "<", "!=") and
               any(a.same(d) for a in c.args) and any(a.op == "const" and a.payload == 0 for a in c.args)
               for c in conjuncts(ode.domain))


def candidates(theorem: Theorem, ode: ODE) -> tuple[list[Node], list[Node]] | None:
    """Atoms to build the ODE's chain from, and atoms to append once those have settled; or
    None to leave the ODE to the core's default."""
    names = {v.payload for v in ode.variables}
    guarantee = goals(theorem.guarantee)
    if ode.invariants:
        # the author's atoms, then the guarantee's: once those are known, the nonzero rule can
        # show the guarantee's sign is kept (Hamiltonian System 1: x <= 0 under two level sets).
        # The guarantee's join only after the author's have settled: a failing link is retried
        # at the chain's end, and behind more links its premise is a new check, which for an
        # author's atom of degree 5 costs a whole budget again (Bhatia Szego: 22 s, not 43 s)
        annotated = annotated_atoms(ode)
        seen = {a.key for a in annotated}
        extra = [a for a in _atoms(And(guarantee, around(theorem, ode)))
                 if a.key not in seen and set(free_vars(a)) & names and _usable(a, ode)]
        # an author who selects invariants by the flow they hold for (`r = p -> J`) splits the
        # flow into cases: the guarantee's atoms are tried in each case too (Parachute: v > -3
        # holds once the parachute is open, r = p, and is a Darboux inequality only there)
        cases = list({g.key: g for g in (guarded(a)[0] for a in annotated) if g is not None}.values())
        extra += [Implies(case, a) for a in extra for case in cases]
        return annotated, list({a.key: a for a in extra}.values())
    if solvable(ode):
        return None
    seen: dict[tuple, Node] = {}
    # the searches' atoms first (Darboux polynomials over QQ, none for an affine system; first
    # integrals with parameters): each is proved without a premise, so it needs no earlier
    # link and gives every later link one more fact
    first = And(*search_atoms(theorem, ode), *integral_atoms(theorem, ode))
    for source in (first, guarantee, ode.domain, theorem.assumptions, And(*darboux_atoms(ode))):
        for atom in _atoms(source):
            if atom.key not in seen and set(free_vars(atom)) & names and _usable(atom, ode):
                seen[atom.key] = atom
    return (list(seen.values()), []) if seen else None


_NEGATED = {"<=": ">", "<": ">=", ">=": "<", ">": "<=", "==": "!=", "!=": "=="}


def _atoms(f: Node) -> list[Node]:
    """The conjuncts of f with negations pushed in, as comparisons where they are: archives
    write a guarantee as the unsafe set excluded, `!(x <= -1 | y <= -1)`, which is the atoms
    `x > -1` and `y > -1`."""
    out: list[Node] = []
    for atom in conjuncts(f):
        inner = atom.args[0] if atom.op == "not" else None
        if inner is not None and inner.op == "or":
            out += [a for d in inner.args for a in _atoms(Not(d))]
        elif inner is not None and inner.op == "not":
            out += _atoms(inner.args[0])
        elif inner is not None and inner.op == "cmp" and inner.args[0].sort.is_numeric:
            out.append(cmp(_NEGATED[inner.payload], *inner.args))
        else:
            out.append(atom)
    return out


def rule_options(atom: Node, ode: ODE) -> list[OdeStep]:
    """The rules to try for one link, best first."""
    try:
        exact, quotient = cofactors(atom, ode)
    except (TypeError, ValueError, ModelError):
        return [OdeStep(atom)]
    if exact is not None:
        return [OdeStep(atom, "dbx", exact)]  # a Darboux identity: nothing left to prove
    options = [OdeStep(atom)]
    if quotient is not None:
        options.append(OdeStep(atom, "dbx", quotient))
    rational = rational_cofactor(atom, ode)
    if rational is not None:
        options.append(OdeStep(atom, "dbx", rational))
    if atom_polynomial(atom)[1] in (">", ">="):
        options.append(OdeStep(atom, "barrier"))
    polynomial = not has_division(atom) and not any(has_division(rhs) for _, rhs in ode.eqs)
    if atom_polynomial(atom)[1] == ">=" and polynomial and len(ode.variables) <= MAX_PROGRESS_VARS:
        options.append(OdeStep(atom, "progress"))
    if not has_division(atom):
        options.append(OdeStep(atom, "nonzero"))
    return options


@dataclass
class _Link:
    options: list[OdeStep]
    tried: int = 0
    deferrals: int = 0  # times moved to the chain's end

    @property
    def step(self) -> OdeStep:
        return self.options[self.tried]


def plan_odes(theorem: Theorem, discharge: Callable[[Obligation], ObligationResult],
              certify: bool = False) -> Plan | None:
    """A chain per ODE whose links' obligations all discharge, as far as the search gets;
    None when no ODE of the theorem is open to planning (with certify: to a certificate)."""
    odes = theorem_odes(theorem)
    steps = {}
    if certify:  # imported here: numpy and the SDP code cost every CLI run 0.08 s otherwise
        from certiloop.proofs.engine.certificates import certificate_steps

        # a certificate was made for one rule (dI, or dbx with the SDP's cofactor): only that one
        steps = {ode.key: certificate_steps(theorem, ode) for ode in odes
                 if not ode.invariants and not solvable(ode)}
    if certify and not any(steps.values()):
        return None  # nothing new to try
    chains: dict[tuple, list[_Link]] = {}
    later: dict[tuple, list[_Link]] = {}  # links to append once a chain has settled
    for ode in odes:
        if steps.get(ode.key):
            chains[ode.key] = [_Link([step]) for step in steps[ode.key]]
        elif atoms := candidates(theorem, ode):
            chains[ode.key] = [_Link(rule_options(a, ode)) for a in atoms[0]]
            later[ode.key] = [_Link(rule_options(a, ode)) for a in atoms[1]]
    if not chains:
        return None
    known: dict[tuple, str] = {}  # obligation formula -> verdict (fresh names are deterministic)
    plan: Plan = {}
    for _ in range(MAX_ROUNDS):
        plan = {key: tuple(link.step for link in links) for key, links in chains.items()}
        failed: dict[tuple, dict[int, str]] = {}
        obligations = generate(theorem, plan)
        # moving a link again costs whole rounds, each generating every obligation: a large
        # proof (a hybrid automaton's 1,300) moves each link once
        deferrals = MAX_DEFERRALS if len(obligations) <= REORDER_OBLIGATIONS else 1
        for ob in obligations:
            if not ob.ode_step or ob.ode_step[0] not in chains:
                continue
            key, n, kind = ob.ode_step
            if ob.formula.key not in known:
                known[ob.formula.key] = discharge(_for_search(ob)).verdict
            if known[ob.formula.key] != "proved" and failed.get(key, {}).get(n) != "init":
                failed.setdefault(key, {})[n] = kind
        settled = [key for key in chains if key not in failed and later.get(key)]
        for key in settled:
            chains[key] += later.pop(key)
        if not failed and not settled:
            return plan
        for key, bad in failed.items():
            if starts := [n for n, kind in bad.items() if kind == "init"]:
                _drop(chains[key], starts)
            else:
                _revise(chains[key], min(bad), deferrals)
    # the rounds ran out: each chain up to its first failing link, whose links all hold (a
    # link's premise assumes only the links before it), rather than a chain that fails
    return {key: steps[: min(failed[key]) - 1] if key in failed else steps for key, steps in plan.items()}


def _for_search(ob: Obligation) -> Obligation:
    """The obligation without its quantified hypotheses, for a link's trial: a weaker claim,
    so a link it proves holds. With them, z3's quantifier procedure (nlsat under qsat) can
    stall inside one step that neither its units nor its allocation count bound: 53 s on one
    link of ModelPlex's Planar Flight Motion Safety with Intruder Velocity Uncertainty, whose
    `\\forall v2p \\forall w2p (...)` fact from a test says nothing about the link. The
    planned proof's obligations keep every hypothesis."""
    weaker = _drop_quantified_facts(ob.formula)
    if weaker is ob.formula:
        return ob
    stronger = tuple((how, _drop_quantified_facts(f)) for how, f in ob.stronger)
    return replace(ob, formula=weaker, stronger=stronger)


def _drop_quantified_facts(f: Node) -> Node:
    if f.op != "implies":
        return f
    facts, goal = f.args
    conjuncts = facts.args if facts.op == "and" else (facts,)
    kept = [c for c in conjuncts if not has_quantifier(c)]
    return f if len(kept) == len(conjuncts) else Implies(And(*kept), goal)


def _drop(links: list[_Link], numbers: list[int]) -> None:
    """Drop the links (numbers from 1) that do not hold initially, all in one round: whether a
    link holds at the start does not depend on the other links of its chain."""
    for n in sorted(numbers, reverse=True):
        del links[n - 1]


def _revise(links: list[_Link], n: int, max_deferrals: int = MAX_DEFERRALS) -> None:
    """Change the first failing link (number n, from 1) of a chain, whose premise failed."""
    link = links[n - 1]
    if link.tried + 1 < len(link.options):
        link.tried += 1
    elif link.deferrals < max_deferrals and n < len(links):
        # behind the links that follow it: one of them may be what its premise needs, and
        # again after those that were moved behind it (a triple integrator's x >= 0 needs
        # y >= 0, which needs z >= 0, listed in that order)
        del links[n - 1]
        link.tried, link.deferrals = 0, link.deferrals + 1
        links.append(link)
    else:
        del links[n - 1]
