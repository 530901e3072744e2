"""Where a tactic's hints (tactic_hints.py) go in an entry's program, and which ones stay.

Each hint becomes an `@invariant(...)` annotation in the entry's parse tree, on a loop or an
ODE that has none, so it is read exactly as the author's annotation would be (definitions,
`old(e)`, differential symbols). Loops: the tactic applies `loop` to the loops in the order
the proof meets them, outer and earlier first, which is the program's order; the invariants
are matched to the loops one to one when there are as many of each, all to the only loop
(the first one named is used: a loop has one invariant), and otherwise none is used. ODEs:
a cut names no ODE unless its position does (`'R=="[{x'=...}]..."`); each goes to the ODEs
whose equations the position names, or else to every ODE it mentions a variable of (the ODE
planner drops links that fail, so a cut offered to the wrong flow only costs search).

A hint is kept only if the entry still reads and says the same thing with it (assumptions,
guarantee, program and definedness conditions equal once annotations and the ghost
assignments of `old(e)` are set aside); otherwise it is left out with a note. The prover
proves every invariant it uses, so a hint can never make a claim true.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from lark import Token, Tree

from certiloop.models.kyx.archive import KyxError, Scope, parse_tree
from certiloop.models.kyx.tactic_hints import Hint, tactic_hints
from certiloop.models.lang.programs import ODE, Assign, Loop, Program, Seq, Test, children, seq
from certiloop.models.lang.terms import MODALITIES, Node, free_vars
from certiloop.models.lang.theorem import Theorem

_KNOWN_CALLS = {"old", "abs", "min", "max", "sqrt"}


@dataclass
class Placement:
    node: Tree  # a `loop` or `ode` tree of the entry
    hint: Hint
    annotation: Tree


def entry_hints(item: Tree) -> list[Hint]:
    """The hints of every Tactic of an entry, in order, each formula once per kind."""
    out: dict[tuple[str, str, str], Hint] = {}
    for t in item.children:
        if isinstance(t, Tree) and t.data == "tactic":
            for tok in t.children:
                if isinstance(tok, Token) and tok.type == "TACTIC_TEXT":
                    for h in tactic_hints(str(tok)):
                        out.setdefault((h.kind, _squash(h.text), h.locator), h)
    return list(out.values())


def placements(problem: Tree, scope: Scope, hints: list[Hint], notes: list[str]) -> list[Placement]:
    """Where each usable hint goes; notes say why the others are not used."""
    loops, odes, walked = _program_nodes(problem, scope)
    known = set().union(*(_names(t) for t in walked)) | set(scope.variables) | set(scope.defs) | _KNOWN_CALLS
    parsed: list[tuple[Hint, Tree]] = []
    for h in hints:
        tree = _parse(h, known, notes)
        if tree is not None:
            parsed.append((h, tree))
    out: list[Placement] = []
    loop_hints = list({_squash(h.text): (h, t) for h, t in parsed if h.kind == "loop"}.values())
    if loop_hints and not loops:
        notes.append(f"tactic hint `{loop_hints[0][0].text}`: the program has no loop to attach it to")
    elif len(loops) == 1 or len(loop_hints) == len(loops):
        if len(loops) == 1 and len(loop_hints) > 1:
            notes.append(f"the tactics name {len(loop_hints)} loop invariants for the one loop: the first "
                         "is used")
        for node, (h, t) in zip(loops, loop_hints):
            if _annotated(node):
                notes.append(f"tactic hint `{h.text}` not used: the loop has its own @invariant")
            else:
                out.append(Placement(node, h, _annotation(t)))
    elif loop_hints:
        notes.append(f"the tactics name {len(loop_hints)} loop invariants for {len(loops)} loops: which "
                     "belongs to which is not certain, none is used")
    for h, t in parsed:
        if h.kind != "ode":
            continue
        targets = _ode_targets(h, odes)
        if not targets:
            notes.append(f"tactic hint `{h.text}` ({h.tactic}): no ODE of the program it belongs to")
        for node in targets:
            if _polynomial_solution(node):
                # the prover solves such a flow; a cut chain would replace the solution, and a
                # cut the tactic makes in one branch only fails in the others (LICS 4a)
                notes.append(f"tactic hint `{h.text}` ({h.tactic}) not used: the ODE has a polynomial "
                             "solution, which the prover uses")
            elif not _annotated(node):
                out.append(Placement(node, h, _annotation(t)))
    return out


def _polynomial_solution(ode: Tree) -> bool:
    """Do the ODE's equations have a polynomial solution (no rate depends, directly or through
    others, on its own variable, and none divides)? Read on the tree: a rate that calls a
    definition counts as not solved, so its cuts are kept."""
    rates = {str(eq.children[0])[:-1]: eq.children[1] for eq in ode.children[0].children}
    needs: dict[str, set[str]] = {}
    for x, rate in rates.items():
        if any(isinstance(t, Tree) and t.data in ("call", "differential") for t in rate.iter_subtrees()) or \
                any(str(v) == "/" for v in rate.scan_values(lambda v: isinstance(v, Token))):
            return False
        needs[x] = _names(rate) & set(rates)
    done: set[str] = set()
    while True:
        ready = [x for x in needs if x not in done and needs[x] <= done]
        if not ready:
            return len(done) == len(needs)
        done |= set(ready)


def chosen(build: Callable[[], Theorem], found: list[Placement], notes: list[str]) -> Theorem:
    """The theorem built with the placements that leave the claim as it was, all at once if
    they do, else one by one in order. Without any, as if there were no tactic."""
    plain = build()
    if not found:
        return plain
    base = _all_names(plain.assumptions) | _all_names(plain.guarantee) | _all_names(plain.program)
    same = claim_key(plain, base)
    refused = _refused_guards(plain)

    def attempt(extra: list[Placement]) -> Theorem | None:
        for p in extra:
            p.node.children.append(p.annotation)
        try:
            built = build()
        except Exception:  # a hint never loses the entry: without it, the entry reads as before
            return None
        finally:
            for p in extra:
                p.node.children.remove(p.annotation)
        if claim_key(built, base) != same or _refused_guards(built) - refused:
            return None
        return built

    everything = attempt(found)
    if everything is not None:
        return _kept(found, everything, notes)
    kept: list[Placement] = []
    result = plain
    for p in found:
        trial = attempt(kept + [p])
        if trial is None:
            notes.append(f"tactic hint `{p.hint.text}` ({p.hint.tactic}) not used: it does not read as an "
                         "invariant of its place, or it would change the claim")
            continue
        kept.append(p)
        result = trial
    return _kept(kept, result, notes)


def _refused_guards(t: Theorem) -> set[tuple]:
    """ODE invariant atoms `C -> a` whose condition C changes along the flow (mentions a
    variable the flow moves) or holds a modality: the prover refuses those, so a hint that
    adds one would lose the entry."""
    out: set[tuple] = set()
    for ode in _odes_in(t.program) + [o for f in (t.assumptions, t.guarantee) for o in _odes_in_formula(f)]:
        moving = {v.payload for v in ode.variables}
        for inv in ode.invariants:
            for atom in _conjuncts(inv):
                if atom.op == "implies" and (set(free_vars(atom.args[0])) & moving or _modal(atom.args[0])):
                    out.add(atom.key)
    return out


def _conjuncts(f: Node) -> list[Node]:
    if f.op == "and":
        return [x for a in f.args for x in _conjuncts(a)]
    if f.op == "implies" and f.args[1].op == "and":
        return [Node("implies", (f.args[0], x), f.sort) for x in _conjuncts(f.args[1])]
    return [f]


def _modal(f: Node) -> bool:
    return f.op in MODALITIES or any(_modal(a) for a in f.args)


def _odes_in(p: Program) -> list[ODE]:
    here = [p] if isinstance(p, ODE) else []
    for f in _program_formulas(p):
        here += _odes_in_formula(f)
    return here + [o for q in children(p) for o in _odes_in(q)]


def _odes_in_formula(f: Node) -> list[ODE]:
    here = _odes_in(f.payload) if f.op in MODALITIES else []
    return here + [o for a in f.args for o in _odes_in_formula(a)]


def _kept(kept: list[Placement], theorem: Theorem, notes: list[str]) -> Theorem:
    for p in kept:
        notes.append(f"tactic hint used: {p.hint.tactic}(\"{p.hint.text}\") as the "
                     f"{'loop' if p.node.data == 'loop' else 'ODE'} invariant")
    return theorem


# ---------------------------------------------------------------------------- the claim


def claim_key(t: Theorem, base: set[str]) -> tuple:
    """What the theorem claims and when it is defined, without its proof hints: annotations,
    and assignments to names outside `base` (the names of the claim without hints: old(e)'s
    ghosts, the differential symbols an annotation mentions), are left out."""
    return (t.assumptions.key, _formula(t.guarantee, base).key, _program(t.program, base).key,
            tuple((w, c.key) for w, c in t.well_defined), tuple((w, c.key) for w, c in t.defined_if),
            tuple(c.key for c in t.constants))


def _program(p: Program, base: set[str]) -> Program:
    if isinstance(p, Loop):
        return Loop(_program(p.body, base), None, p.label, p.each, p.count)
    if isinstance(p, ODE):
        return ODE(p.eqs, _formula(p.domain, base), ())
    if isinstance(p, Seq):
        return seq(*(_program(q, base) for q in p.parts if not _ghost(q, base)))
    if isinstance(p, Test):
        return Test(_formula(p.cond, base))
    if hasattr(p, "alternatives"):
        return type(p)(tuple(_program(q, base) for q in p.alternatives), p.labels)
    return p


def _ghost(p: Program, base: set[str]) -> bool:
    return isinstance(p, Assign) and p.target.op == "var" and p.target.payload not in base


def _formula(f: Node, base: set[str]) -> Node:
    if f.op in MODALITIES:
        return Node(f.op, tuple(_formula(a, base) for a in f.args), f.sort, _program(f.payload, base))
    if not f.args:
        return f
    return Node(f.op, tuple(_formula(a, base) for a in f.args), f.sort, f.payload)


def _all_names(x: Node | Program) -> set[str]:
    """Every symbol of a formula or program, inside its modalities and annotations too."""
    if isinstance(x, Node):
        out = set(free_vars(x))
        if x.op in MODALITIES:
            out |= _all_names(x.payload)
        for a in x.args:
            out |= _all_names(a)
        return out
    out = set(x.symbols())
    for f in _program_formulas(x):
        out |= _all_names(f)
    for q in children(x):
        out |= _all_names(q)
    return out


def _program_formulas(p: Program) -> list[Node]:
    if isinstance(p, Test):
        return [p.cond]
    if isinstance(p, Assign):
        return [p.value]
    if isinstance(p, ODE):
        return [p.domain]
    return []


# ---------------------------------------------------------------------------- the tree


def _program_nodes(problem: Tree, scope: Scope) -> tuple[list[Tree], list[Tree], list[Tree]]:
    """The loops and ODEs of the problem, in program order, definitions expanded (each once),
    and the trees read: the problem and the bodies of the definitions it uses."""
    loops: list[Tree] = []
    odes: list[Tree] = []
    seen: set[str] = set()
    walked = [problem]

    def walk(t: Tree) -> None:
        if t.data == "loop" and not any(t is x for x in loops):
            loops.append(t)
        if t.data == "ode" and not any(t is x for x in odes):
            odes.append(t)
        if t.data in ("program_call", "symbol", "call"):
            name = str(t.children[0])
            d = scope.defs.get(name)
            if d is not None and d.body is not None and name not in seen:
                seen.add(name)
                walked.append(d.body)
                walk(d.body)
        for c in t.children:
            if isinstance(c, Tree) and c.data != "annotation":
                walk(c)

    walk(problem)
    return loops, odes, walked


def _annotated(node: Tree) -> bool:
    return any(isinstance(c, Tree) and c.data == "annotation" for c in node.children)


def _annotation(expr: Tree) -> Tree:
    return Tree("annotation", [Token("ANNOTATION", "@invariant"), expr])


def _names(t: Tree) -> set[str]:
    return {str(v) for v in t.scan_values(lambda v: isinstance(v, Token) and v.type in ("IDENT", "DIFFSYM"))}


def _parse(h: Hint, known: set[str], notes: list[str]) -> Tree | None:
    if h.ghost:
        ghosts = set(re.findall(r"([A-Za-z][A-Za-z0-9_]*)'", h.ghost))
        if ghosts & set(re.findall(r"[A-Za-z][A-Za-z0-9_]*", h.text)):
            notes.append(f"tactic hint `{h.text}` (dG) not used: it needs the differential ghost "
                         f"`{h.ghost}`, which certiloop does not have")
            return None
    try:
        tree = parse_tree(f'ArchiveEntry "hint" Problem {h.text} End. End.', "<tactic hint>")
    except KyxError:
        notes.append(f"tactic hint `{h.text}` ({h.tactic}) not used: it does not parse")
        return None
    entry = tree.children[0]
    problem = next(c for c in entry.children if isinstance(c, Tree) and c.data == "problem")
    expr = problem.children[0]
    bound = {str(v) for q in expr.iter_subtrees() if q.data == "quantifier"
             for v in q.children if isinstance(v, Token) and v.type == "IDENT"}
    unknown = sorted({n.rstrip("'") for n in _names(expr)} - known - bound)
    if unknown:
        notes.append(f"tactic hint `{h.text}` ({h.tactic}) not used: `{unknown[0]}` is not a name of the "
                     "entry")
        return None
    return expr


def _ode_targets(h: Hint, odes: list[Tree]) -> list[Tree]:
    if len({_evolved(o) for o in odes}) == 1:
        return odes
    if h.locator:
        named = frozenset(re.findall(r"([A-Za-z][A-Za-z0-9_]*)'\s*=", h.locator.split("}")[0]))
        return [o for o in odes if _evolved(o) == named]
    mentioned = set(re.findall(r"[A-Za-z][A-Za-z0-9_]*", h.text))
    return [o for o in odes if _evolved(o) & mentioned]


def _evolved(ode: Tree) -> frozenset[str]:
    eqs = ode.children[0]
    return frozenset(str(eq.children[0])[:-1] for eq in eqs.children)


def _squash(text: str) -> str:
    return re.sub(r"\s+", "", text)


__all__ = ["Placement", "chosen", "claim_key", "entry_hints", "placements"]
