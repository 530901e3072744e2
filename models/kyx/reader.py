"""Read KeYmaera X archives (.kyx) into certiloop `Theorem`s.

An entry's `Problem` is a dL formula; it becomes `assumptions -> [program] guarantee` by
peeling what is equivalent: `A -> B` moves A into the assumptions, `[a][b]P` is `[a;b]P`,
`[a](Q -> P)` is `[a;?Q]P` and `Q | [a]P` is `!Q -> [a]P`. Whatever is left (a diamond, an
equivalence, a quantifier) stays in the guarantee, behind the program `?true`.

Language the engine does not have is translated exactly or refused with line and column:
  * definitions (functions, predicates, programs) are expanded where they are used;
  * `abs`, `min`, `max` are split into cases at the comparison (or assignment) using them;
    in an ODE's right-hand side, |a| is g*a for a sign g chosen before the flow (lifting.py);
  * a differential symbol `x'` is an ordinary variable that an ODE sets to its right-hand
    side at the end of the flow (dL's semantics); inside the ODE's own domain and
    annotations it is replaced by that right-hand side, which it equals along the flow;
  * `(e)'` is the total differential of e (sum of ∂e/∂x · x'; constants have none);
  * `old(e)` in an ODE's annotation is a fresh variable assigned e just before the ODE;
  * a square root `e^(1/2)` (or `sqrt(e)`, `e^(k/2)`) of a sum of squares is eliminated at
    each comparison (roots.py); of any other term that no program writes, it is a symbol s
    pinned by `s >= 0 & s^2 = e` in the assumptions, and the claim is well-defined only if
    its first assumptions give e >= 0 (a `defined` obligation, like a division's); in an
    ODE's right-hand side it is lifted to a variable of the flow (lifting.py).
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

from lark import Token, Tree

from certiloop.models.kyx.archive import (
    KyxError,
    Scope,
    declarations,
    parse_tree,
    place,
)
from certiloop.models.kyx.expressions import Builder
from certiloop.models.kyx.hint_placement import chosen, entry_hints, placements
from certiloop.models.kyx.slicing import one_entry
from certiloop.models.lang.nesting import divides, loop_nesting_problem, modal_domains, tests_have_loops
from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Havoc,
    Loop,
    Program,
    Seq,
    Test,
    assign,
    children,
    seq,
    skip,
    test,
    written,
)
from certiloop.models.lang.roles import Roles
from certiloop.models.lang.terms import (
    BOOL,
    MODALITIES,
    TRUE,
    And,
    Implies,
    ModelError,
    Node,
    Not,
    Or,
    Real,
    Var,
    free_vars,
)
from certiloop.models.lang.theorem import Theorem

METADATA = re.compile(r"/\*@certiloop (\{.*?\})\s*\*/", re.S)


# --------------------------------------------------------------------------- problem -> Theorem


def _with_ode_primes(p: Program, primes: dict[str, str]) -> Program:
    """After every ODE, set the differential symbols in use to the right-hand sides (dL:
    x' = f(x) holds in the final state of every run, also the run of duration 0), also in
    the modalities of a test (`?([{y'=1}] y'=1)` always passes)."""
    if isinstance(p, ODE):
        sets = [assign(Real(primes[v.payload]), f) for v, f in p.eqs if v.payload in primes]
        return seq(p, *sets) if sets else p
    if isinstance(p, Test):
        return Test(_primes_in_formula(p.cond, primes))
    if isinstance(p, Assign) and p.value.sort == BOOL:
        return Assign(p.target, _primes_in_formula(p.value, primes))
    if isinstance(p, Seq):
        return seq(*(_with_ode_primes(q, primes) for q in p.parts))
    if isinstance(p, Loop):
        return Loop(_with_ode_primes(p.body, primes), p.invariant, p.label, p.each, p.count)
    if hasattr(p, "alternatives"):
        return type(p)(tuple(_with_ode_primes(q, primes) for q in p.alternatives), p.labels)
    return p


def _primes_in_formula(f: Node, primes: dict[str, str]) -> Node:
    if f.op in MODALITIES:
        inner = _primes_in_formula(f.args[0], primes)
        return Node(f.op, (inner,), f.sort, _with_ode_primes(f.payload, primes))
    if not f.args:
        return f
    return Node(f.op, tuple(_primes_in_formula(a, primes) for a in f.args), f.sort, f.payload)


def _has_loop(p: Program) -> bool:
    return isinstance(p, Loop) or any(_has_loop(q) for q in children(p))


def _nested_loop(f: Node) -> bool:
    if f.op in MODALITIES and (_has_loop(f.payload) or tests_have_loops(f.payload)):
        return True
    if f.op in MODALITIES:
        return _nested_loop(f.args[0])
    return any(_nested_loop(a) for a in f.args)


def split_problem(f: Node, exact: bool = False,
                  risky: frozenset[str] = frozenset()) -> tuple[Node, Program, Node]:
    """`A -> [a](Q -> [b]P)` as (A, a; ?Q; b, P), and `Q | [a]P` as `!Q -> [a]P`: each step an
    equivalence. exact: just `A -> [a]P` (how certiloop writes a theorem, so it reads back as
    the same one). risky: symbols (square roots) that count as divisions for the order of `|`."""
    if exact:
        assumptions, rest = (f.args[0], f.args[1]) if f.op == "implies" else (TRUE, f)
        if rest.op == "box":
            return assumptions, rest.payload, rest.args[0]
        return assumptions, skip(), rest
    assumptions: list[Node] = []
    parts: list[Program] = []
    while True:
        if f.op == "implies" and not parts and not _nested_loop(f.args[0]):
            # (a loop on the left stays in the guarantee, where the core may assume it bounded)
            assumptions.append(f.args[0])
            f = f.args[1]
        elif f.op == "implies" and parts and f.args[0].op not in MODALITIES and not _modal(f.args[0]):
            parts.append(test(f.args[0]))
            f = f.args[1]
        elif f.op == "box":
            parts.append(f.payload)
            f = f.args[0]
        elif f.op == "or" and _one_box_among_first_order(f.args, risky):
            # Q | [a]P is !Q -> [a]P: a loop in [a] then becomes the theorem's own program
            guard = Not(Or(*(d for d in f.args if d.op != "box")))
            if parts:
                parts.append(test(guard))
            else:
                assumptions.append(guard)
            f = next(d for d in f.args if d.op == "box")
        else:
            break
    return And(*assumptions), seq(*parts) if parts else skip(), f


def _modal_domain_inside(f: Node) -> bool:
    if f.op in MODALITIES and modal_domains(f.payload):
        return True
    return any(_modal_domain_inside(a) for a in f.args)


def _one_box_among_first_order(disjuncts: tuple[Node, ...], risky: frozenset[str] = frozenset()) -> bool:
    """One box among first-order disjuncts, which `!Q -> [a]P` may evaluate before it: only if
    the box is the last one or nothing from it on divides (read left to right, a later
    disjunct is evaluated only where the box is false)."""
    boxes = [n for n, d in enumerate(disjuncts) if d.op == "box"]
    if len(boxes) != 1 or any(_modal(d) for d in disjuncts if d.op != "box"):
        return False
    return boxes[0] == len(disjuncts) - 1 or not any(divides(d, risky) for d in disjuncts[boxes[0]:])


def _modal(f: Node) -> bool:
    return f.op in MODALITIES or any(_modal(a) for a in f.args)


@dataclass
class Entry:
    name: str
    kind: str
    theorem: Theorem | None
    error: str | None  # why the entry cannot be used (not supported), with line and column
    notes: tuple[str, ...] = ()  # which of its Tactic's invariants are used as hints, which not


def read_entries(text: str, source: str = "<kyx>", only: str | None = None) -> list[Entry]:
    """Every entry of an archive, each a Theorem or the one-line reason it is not supported.
    A syntax error in the file raises KyxError (no entry can be trusted then). With `only`,
    just that entry is built; the others are listed by name (theorem and error None), or
    left out when the archive could be cut to that entry without parsing them."""
    tree = _only_tree(text, source, only) if only is not None else None
    if tree is None:
        tree = parse_tree(text, source)
    if tree.data in ("bare_entry", "bare_formula"):  # one problem, no ArchiveEntry: named by the file
        name = Path(source).stem if source != "<kyx>" else "problem"
        item = tree if tree.data == "bare_entry" else Tree("bare_entry", [Tree("problem", tree.children)])
        if only is not None and name != only:
            return [Entry(name, "Problem", None, None)]
        try:
            return [Entry(name, "Problem", _entry_theorem(item, name, Scope(source), text, source), None)]
        except ModelError as exc:
            why = str(exc) if isinstance(exc, KyxError) else f"{source}: {exc}"
            return [Entry(name, "Problem", None, why)]
    shared = Scope(source)
    entries: list[Entry] = []
    seen: set[str] = set()
    for item in tree.children:
        if item.data == "shared":
            declarations([item], shared)
            continue
        kind, name_tok, name = _header(item)
        if name in seen:
            raise KyxError(f"{place(source, name_tok)}: two entries named {name!r}")
        seen.add(name)
        if only is not None and name != only:
            entries.append(Entry(name, str(kind), None, None))
            continue
        span = text[item.meta.start_pos:item.meta.end_pos]
        notes: list[str] = []
        try:
            theorem = _entry_theorem(item, name, shared, span, source, notes)
            entries.append(Entry(name, str(kind), theorem, None, tuple(notes)))
        except ModelError as exc:
            message = str(exc)
            if not isinstance(exc, KyxError):
                message = f"{place(source, name_tok)}: {message}"
            entries.append(Entry(name, str(kind), None, message))
        except Exception as exc:  # a certiloop bug in one entry: its row, the others are still read
            if os.environ.get("CERTILOOP_DEBUG"):
                raise
            entries.append(Entry(name, str(kind), None, f"{place(source, name_tok)}: internal error while "
                                 f"reading it: {type(exc).__name__}: {exc} (please report it)"))
    return entries


def _only_tree(text: str, source: str, only: str) -> Tree | None:
    """The parse of the archive cut to entry `only` (slicing.py), if it is exactly that entry."""
    cut = one_entry(text, only)
    if cut is None:
        return None
    try:
        tree = parse_tree(cut, source)
    except KyxError:  # the whole file's parse names the error
        return None
    items = [c for c in tree.children if c.data == "entry"] if tree.data == "start" else []
    return tree if len(items) == 1 and _header(items[0])[2] == only else None


def _header(item: Tree) -> tuple[Token, Token, str]:
    """An entry's kind keyword, its name's token and the name."""
    kind, *rest = item.children
    name_tok = next(c for c in rest if isinstance(c, Token) and c.type == "STRING")
    return kind, name_tok, json.loads(str(name_tok)) if "\\" in str(name_tok) else str(name_tok)[1:-1]


def _entry_theorem(item: Tree, name: str, shared: Scope, span: str, source: str,
                   notes: list[str] | None = None) -> Theorem:
    """The entry's theorem, with the invariants its Tactic names attached where it has none
    (hint_placement.py: hints the prover proves before it uses them); notes say which."""
    hints = entry_hints(item)
    if not hints:
        return _plain_theorem(item, name, shared, span, source)
    scope = Scope(source, dict(shared.defs), list(shared.variables), set(shared.bools))
    try:
        declarations([c for c in item.children
                      if isinstance(c, Tree) and c.data in ("definitions", "variables")], scope)
    except KyxError:
        return _plain_theorem(item, name, shared, span, source)  # which raises the same error
    problem = next(c for c in item.children if isinstance(c, Tree) and c.data == "problem")
    notes = notes if notes is not None else []
    try:
        found = placements(problem, scope, hints, notes)
    except Exception as exc:  # the hints are lost, never the entry
        notes.append(f"the tactic's hints are not used: internal error while placing them: {exc!r}")
        found = []
    return chosen(lambda: _plain_theorem(item, name, shared, span, source), found, notes)


def _plain_theorem(item: Tree, name: str, shared: Scope, span: str, source: str) -> Theorem:
    scope = Scope(source, dict(shared.defs), list(shared.variables), set(shared.bools))
    blocks = [c for c in item.children if isinstance(c, Tree) and c.data in ("definitions", "variables")]
    declarations(blocks, scope)
    problem = next(c for c in item.children if isinstance(c, Tree) and c.data == "problem")
    spelled = {str(tok) for tok in item.scan_values(lambda v: isinstance(v, Token) and v.type == "IDENT")}
    builder = Builder(scope, {}, taken=spelled | set(shared.defs))
    formula_tree = problem.children[0]
    f = builder.expr(formula_tree, {})
    if f.sort != BOOL:
        raise KyxError(f"{place(source, problem)}: the Problem is a term, not a formula")
    if builder.primes:
        f = _primes_in_formula(f, builder.primes)
    meta = _metadata(span, source, problem)
    if meta.get("names"):
        _check_renaming(meta["names"], spelled | set(shared.defs), place(source, problem))
        f = _rename(f, meta["names"])
    risky = frozenset(builder.named_roots)  # defined only where their argument is >= 0
    assumptions, program, guarantee = split_problem(f, exact=meta.get("shape") == "A->[a]P", risky=risky)
    roots = {n: (_rename(e, meta.get("names", {})), where) for n, (e, where) in builder.named_roots.items()}
    assumptions, root_conditions, guarded_roots = _pin_roots(roots, assumptions, program, guarantee, source)
    if _nested_loop(assumptions):
        raise KyxError(f"{place(source, problem)}: a loop inside an assumption's modality is not supported")
    if tests_have_loops(program):
        raise KyxError(f"{place(source, problem)}: the Problem holds a loop inside a formula of a program "
                       "(a test, an ODE domain, an annotation), which is not supported")
    if modal_domains(program) or _modal_domain_inside(guarantee) or _modal_domain_inside(assumptions):
        raise KyxError(f"{place(source, problem)}: the Problem holds a modality inside an ODE's domain or "
                       "annotation, which is not supported")
    if why := loop_nesting_problem(guarantee, risky):
        raise KyxError(f"{place(source, problem)}: the Problem holds {why}, which is not supported")
    names = meta.get("names", {})
    constants = [Real(names.get(n, n)) for n, d in scope.defs.items()
                 if d.kind == "constant" and n not in scope.bools]
    writes = written(program)
    for c in constants:
        if c.payload in writes:
            raise KyxError(f"{place(source, problem)}: the program writes `{c.payload}`, declared "
                           "constant in Definitions")
    theorem = Theorem(
        name=name,
        assumptions=assumptions,
        program=_relabel(program, meta.get("labels", [])),
        guarantee=guarantee,
        expected=meta.get("expected", "proved"),
        constants=tuple(constants) + _guarantee_only(assumptions, program, guarantee, constants),
        description=meta.get("description", _described(item)),
        unroll=meta.get("unroll", 3),
        check_nonblocking=meta.get("check_nonblocking", False),
        abbreviations={k: _rename(_meta_term(v, scope, source), names)
                       for k, v in meta.get("abbreviations", {}).items()},
        scenarios=tuple(_rename(_meta_formula(s, scope, source), names) for s in meta.get("scenarios", [])),
        well_defined=root_conditions,
        defined_if=guarded_roots + tuple((what, _rename(c, names)) for what, c in builder.lift_conditions),
        roles=_roles(meta.get("roles"), place(source, problem)),
    )
    return theorem


def _roles(roles, where) -> Roles | None:
    """The metadata's roles (`certiloop export` writes them): symbols by certiloop's names."""
    if roles is None:
        return None
    fields = ("environment", "controls")
    if not (isinstance(roles, dict) and all(isinstance(roles.get(k, []), list) for k in fields)):
        raise KyxError(f"{where}: the certiloop metadata's roles must be "
                       '{"environment": [names], "controls": [names]}')
    return Roles(environment=tuple(Real(str(n)) for n in roles.get("environment", [])),
                 controls=tuple(Real(str(n)) for n in roles.get("controls", [])))


def _pin_roots(roots: dict[str, tuple[Node, object]], assumptions: Node, program: Program,
               guarantee: Node, source: str) -> tuple[Node, tuple[tuple[str, Node], ...]]:
    """The assumptions with each named square root s of e pinned, `s >= 0 & s^2 = e`, and
    the side conditions that make this exact. No program writes e's symbols and no
    quantifier binds them, so e keeps its initial value in every run. Each pin goes right
    before the first assumption that uses its root: read left to right, the ones before it
    are evaluated first, and the claim is well-defined only where they give e >= 0 (`those
    -> e >= 0` valid). Then in every state they allow, s is sqrt(e), and where one of them
    fails, both claims hold for want of an assumption.

    Returns the assumptions and the side conditions, exact ones first (the root is taken
    wherever its assumption is evaluated, so a failure is a real negative root) and then those
    stricter than needed (the root taken under a guard, or by the program or guarantee)."""
    if not roots:
        return assumptions, (), ()
    changing = _changing(assumptions) | _changing(guarantee) | set(written(program)) | _bound_in(program)
    for e, where in roots.values():
        if bad := sorted(set(free_vars(e)) & changing):
            raise KyxError(f"{place(source, where)}: the square root of `{e}`, which may be negative and "
                           f"changes with `{bad[0]}` (written by the program or bound by a quantifier), "
                           "is not supported")
    parts = list(assumptions.args) if assumptions.op == "and" else [assumptions]
    out: list[Node] = []
    exact: list[tuple[str, Node]] = []
    stricter: list[tuple[str, Node]] = []
    waiting = dict(roots)

    def pin(names: list[str], part: Node | None) -> None:
        for n in names:
            e, where = waiting.pop(n)
            taken = part is not None and _always_taken(part, n)
            if not taken and divides(e):  # the pin would divide where the claim may not
                raise KyxError(f"{place(source, where)}: the square root of `{e}`, which divides and is "
                               "taken under a condition, is not supported")
            what = f"the square root of `{e}` (named {n}) is of a number >= 0"
            (exact if taken else stricter).append((what, Implies(And(*out), e >= 0)))
            out.append(And(Real(n) >= 0, Real(n) * Real(n) == e))

    for part in parts:
        pin([n for n in waiting if n in free_vars(part)], part)
        out.append(part)
    pin(list(waiting), None)  # roots only the program or the guarantee takes
    return And(*out), tuple(exact), tuple(stricter)


def _always_taken(f: Node, name: str) -> bool:
    """Is the symbol evaluated whenever f is, read left to right? (Not under a later operand
    of &, |, ->, nor inside a modality, whose postcondition waits for the program's runs.)"""
    if name not in free_vars(f) or f.op in MODALITIES:
        return False
    if f.op in ("and", "or", "implies"):
        return _always_taken(f.args[0], name)
    if f.op in ("not", "iff"):
        return any(_always_taken(a, name) for a in f.args)
    if f.op in ("forall", "exists"):
        return _always_taken(f.args[0], name)
    return True  # a comparison: every part of its terms is evaluated


def _changing(f: Node) -> set[str]:
    """Symbols a program inside f writes, or a quantifier in f binds."""
    out: set[str] = set()
    if f.op in MODALITIES:
        out |= set(written(f.payload)) | _bound_in(f.payload)
    if f.op in ("forall", "exists"):
        out |= {v.payload for v in f.payload}
    for a in f.args:
        out |= _changing(a)
    return out


def _bound_in(p: Program) -> set[str]:
    """Symbols quantifiers bind, or nested programs write, in p's tests and annotations."""
    out: set[str] = set()
    for f in _formulas_of(p):
        out |= _changing(f)
    for q in children(p):
        out |= _bound_in(q)
    return out


def _formulas_of(p: Program) -> list[Node]:
    if isinstance(p, Test):
        return [p.cond]
    if isinstance(p, ODE):
        return [p.domain, *p.invariants]
    if isinstance(p, Loop) and p.invariant is not None:
        return [p.invariant]
    return []


def _described(item: Tree) -> str:
    """The entry's `Description "..."`, shown by `certiloop list`."""
    for m in item.children:
        if isinstance(m, Tree) and m.data == "meta" and str(m.children[0]) == "Description":
            text = str(m.children[1])
            return json.loads(text) if "\\" in text else text[1:-1]
    return ""


def _guarantee_only(assumptions: Node, program: Program, guarantee: Node, constants) -> tuple[Node, ...]:
    """Symbols only the guarantee mentions and none of its programs writes: constants."""
    known = (set(free_vars(assumptions)) | set(program.symbols()) | {c.payload for c in constants}
             | _changing(guarantee))
    return tuple(v for n, v in free_vars(guarantee).items() if n not in known and v.sort != BOOL)


def _metadata(span: str, source: str, where) -> dict:
    m = METADATA.search(span)
    if m is None:
        return {}
    try:
        data = json.loads(m.group(1))
    except json.JSONDecodeError as exc:
        raise KyxError(f"{place(source, where)}: unreadable /*@certiloop ...*/ comment: {exc}") from None
    return data if isinstance(data, dict) else {}


def _meta_term(text: str, scope: Scope, source: str) -> Node:
    tree = parse_tree(f'ArchiveEntry "m" Problem {text} = 0 End. End.', source)
    f = Builder(scope, {}).expr(tree.children[0].children[-2].children[0], {})
    return f.args[0]


def _meta_formula(text: str, scope: Scope, source: str) -> Node:
    tree = parse_tree(f'ArchiveEntry "m" Problem {text} End. End.', source)
    return Builder(scope, {}).expr(tree.children[0].children[-2].children[0], {})


def _check_renaming(names: dict[str, str], spelled: set[str], where: str) -> None:
    """certiloop's metadata renames KeYmaera X's spelling back to certiloop's names: one to
    one, onto names the entry does not use otherwise (else it would merge two symbols)."""
    if not isinstance(names, dict) or not all(isinstance(v, str) and v.isidentifier()
                                              for v in names.values()):
        raise KyxError(f"{where}: the certiloop metadata's names must map names to identifiers")
    if len(set(names.values())) != len(names):
        raise KyxError(f"{where}: the certiloop metadata renames two symbols to one name")
    for kyx, ours in names.items():
        if ours != kyx and ours in spelled:
            raise KyxError(f"{where}: the certiloop metadata renames `{kyx}` to `{ours}`, a name the entry "
                           "already uses")


def _rename(f: Node, names: dict[str, str]) -> Node:
    """Rename symbols (KeYmaera X's spelling -> certiloop's) everywhere in a formula."""

    def node(n: Node) -> Node:
        if n.op == "var":
            return Var(names.get(n.payload, n.payload), n.sort)
        payload = n.payload
        if n.op in ("forall", "exists"):
            payload = tuple(node(v) for v in payload)
        elif n.op in MODALITIES:
            payload = program(payload)
        return Node(n.op, tuple(node(a) for a in n.args), n.sort, payload)

    def program(p: Program) -> Program:
        if isinstance(p, Assign):
            return Assign(node(p.target), node(p.value))
        if isinstance(p, Havoc):
            return Havoc(node(p.target))
        if isinstance(p, Test):
            return Test(node(p.cond))
        if isinstance(p, Seq):
            return Seq(tuple(program(q) for q in p.parts))
        if isinstance(p, Loop):
            inv = None if p.invariant is None else node(p.invariant)
            return Loop(program(p.body), inv, p.label, p.each, p.count)
        if isinstance(p, ODE):
            return ODE(tuple((node(v), node(e)) for v, e in p.eqs), node(p.domain),
                       tuple(node(i) for i in p.invariants))
        return type(p)(tuple(program(q) for q in p.alternatives), p.labels)

    return node(f)


def _relabel(p: Program, labels: list) -> Program:
    """Put back certiloop's branch and loop labels (pre-order), which .kyx has no syntax for."""
    if not labels:
        return p
    queue = list(labels)

    def walk(q: Program) -> Program:
        if isinstance(q, Seq):
            return Seq(tuple(walk(x) for x in q.parts))
        if isinstance(q, Loop):
            label = queue.pop(0) if queue else q.label
            return Loop(walk(q.body), q.invariant, label, q.each, q.count)
        if hasattr(q, "alternatives"):
            names = tuple(queue.pop(0) if queue else lab for lab in q.labels)
            return type(q)(tuple(walk(x) for x in q.alternatives), names)
        return q

    return walk(p)


__all__ = ["Entry", "KyxError", "read_entries", "split_problem"]
