"""A Theorem: assumptions -> [program] guarantee, with annotations and an expected verdict."""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from html import escape
from typing import Callable

from certiloop.models.lang.printing import show, show_program
from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Havoc,
    Loop,
    Program,
    Seq,
    Test,
    children,
    program_symbols,
    written,
)
from certiloop.models.lang.roles import Roles, check_roles
from certiloop.models.lang.terms import (
    BOOL,
    INT,
    QUANTIFIERS,
    REAL,
    ModelError,
    Node,
    Sort,
    formula,
    free_vars,
    term,
)

VERDICTS = ("proved", "refuted")


@dataclass(frozen=True, eq=False)
class Theorem:
    """`assumptions -> [program] guarantee`, the claim a model makes. Checked when built
    (sorts, names, constants, ODEs): an ill-formed model raises `ModelError`.

    name: the model's name in reports and `certiloop` commands, e.g. "my.train".
    assumptions: formula on the initial state (parameters' ranges, the start inside the
        invariant), e.g. `And(v >= 0, b > 0)`.
    program: the hybrid program, usually `loop(seq(ctrl, plant), invariant=...)`.
    guarantee: formula that must hold after every run, e.g. `p <= m`.
    expected: "proved" (default) or "refuted", the verdict the author expects; unsafe
        designs are kept as "refuted", and `certiloop gate` compares with it.
    abbreviations: name -> term, e.g. {"d0": dot(p - r, n)}. The prover may replace these
        subterms by fresh variables (a sound generalisation) to keep arithmetic small.
    description: one line for `certiloop list`.
    unroll: loop iterations the refuter explores when a proof fails (default 3).
    constants: symbols the program must never write, e.g. `(A, b)`; checked.
    check_nonblocking: also prove that the loop body has a run from every state it can start
        in (the safety proof is not vacuous), and find one.
    scenarios: extra assumptions the refuter tries first, e.g. `(G == 1,)`; they only
        restrict the initial states searched, so a run found under one is a real run.
    well_defined: (what, formula) pairs a translation states for the claim to mean what it
        says, e.g. `("the square root of g/p", Implies(p > 0, g / p >= 0))` when the kyx
        reader names sqrt(g/p) by a symbol; each must be valid, or the claim is ill-defined.
    defined_if: side conditions like well_defined but stricter than the claim needs (a root
        the claim takes only under a guard, or only after the program): each must be valid
        for a proof, and one that fails does not show the claim ill-defined.
    witnesses: (variable, term) pairs, proof hints for an `\\exists v` of the guarantee whose
        body holds a loop: the core proves the body with v := term, evaluated where the
        quantifier stands, e.g. `("del", eps)` for stability's `\\exists del`. Any term is sound
        (a bad one only fails to prove); the prover also tries its own.
    ghosts: (name, fact) pairs, proof hints: fresh constants the proof may use, each with a
        fact about it and the constants before it, e.g. `("l", l^2 - b*l - a = 0 & 2*l <= b)`
        for an eigenvalue of a linear flow. The core proves `assumptions -> \\exists l fact`
        (after the earlier facts) and then assumes the fact; sound because the name is
        fresh: the assumptions, the guarantee and the program's statements do not mention it
        (its invariants may; they are hints too).
    roles: who chooses what, for extraction: `Roles(environment=(al,), controls=(a,))` — the
        values the environment picks and the controller senses, and the values the controller
        computes (its outputs); every other symbol is state. Not part of the logical claim, but
        part of the canonical text (the extracted code's interface depends on it).
    """

    name: str
    assumptions: Node
    program: Program
    guarantee: Node
    expected: str = "proved"
    abbreviations: dict[str, Node] = field(default_factory=dict)
    description: str = ""
    unroll: int = 3  # loop iterations the refuter explores when a proof fails
    constants: tuple[Node, ...] = ()  # parameters the program must never write (G, D, ...)
    # vacuity: also prove that the loop body has a run from every state it can start in
    check_nonblocking: bool = False
    # Extra assumptions the refuter tries first (e.g. axis-aligned boundaries): they only
    # restrict the initial states searched, so a run found under them is a real run.
    scenarios: tuple[Node, ...] = ()
    # Side conditions of a translation (kyx square roots): each proved valid first, like the
    # claim's own divisions (kind `defined`); one that fails makes the claim ill-defined.
    well_defined: tuple[tuple[str, Node], ...] = ()
    defined_if: tuple[tuple[str, Node], ...] = ()  # stricter than needed: a failure shows nothing
    # Proof hints: a term for each \exists v around a loop in the guarantee (see nesting.py)
    witnesses: tuple[tuple[str, Node], ...] = ()
    # Proof hints: fresh constants, each with a fact the core proves satisfiable first
    ghosts: tuple[tuple[str, Node], ...] = ()
    # Extraction: the environment's and the controller's variables (None: not declared)
    roles: Roles | None = None

    def __post_init__(self) -> None:
        if self.expected not in VERDICTS:
            raise ModelError(f"theorem {self.name}: expected must be one of {VERDICTS}")
        _check_collections(self)
        object.__setattr__(self, "assumptions", formula(self.assumptions))
        object.__setattr__(self, "guarantee", formula(self.guarantee))
        object.__setattr__(self, "scenarios", tuple(formula(s) for s in self.scenarios))
        object.__setattr__(self, "well_defined", tuple((str(w), formula(f)) for w, f in self.well_defined))
        object.__setattr__(self, "defined_if", tuple((str(w), formula(f)) for w, f in self.defined_if))
        object.__setattr__(self, "witnesses", tuple((str(v), term(t)) for v, t in self.witnesses))
        object.__setattr__(self, "ghosts", tuple((str(v), formula(f)) for v, f in self.ghosts))
        check_well_formed(self)

    @property
    def text(self) -> str:
        """The theorem as one dL formula in KeYmaera X-like syntax."""
        abbrev = "".join(f"  /* {k} == {show(v)} */\n" for k, v in self.abbreviations.items())
        return (
            f"{abbrev}{show(self.assumptions)}\n->\n[\n  {show_program(self.program, 1)}\n]"
            f"({show(self.guarantee)})"
        )

    @property
    def canonical(self) -> str:
        """Everything that defines the claim, as one deterministic text: the name, the
        expected verdict, every formula and program with the sort of each symbol, the
        invariants and differential invariants, abbreviations, constants, scenarios and
        flags. Two theorems with the same canonical text are the same claim."""
        conditions = (("well_defined", tuple((w, f.key) for w, f in self.well_defined)),) \
            if self.well_defined else ()  # (absent, a theorem's text and hash stay what they were)
        if self.defined_if:
            conditions += (("defined_if", tuple((w, f.key) for w, f in self.defined_if)),)
        conditions += (("witnesses", tuple((v, t.key) for v, t in self.witnesses)),) if self.witnesses else ()
        conditions += (("ghosts", tuple((v, f.key) for v, f in self.ghosts)),) if self.ghosts else ()
        conditions += (("roles", self.roles.key),) if self.roles is not None else ()
        return repr((
            "certiloop-theorem/1", self.name, self.expected, self.assumptions.key, self.program.key,
            self.guarantee.key, tuple(sorted((k, v.key) for k, v in self.abbreviations.items())),
            tuple(c.key for c in self.constants), tuple(s.key for s in self.scenarios),
            ("unroll", self.unroll), ("check_nonblocking", self.check_nonblocking), *conditions,
        ))

    def unused_name(self, base: str) -> str:
        """A name no symbol of the theorem has, bound or free, annotations and hints included:
        base, base2, base3, ..."""
        taken = set(re.findall(r"[A-Za-z_]\w*", self.canonical))
        name, k = base, 1
        while name in taken:
            k += 1
            name = f"{base}{k}"
        return name

    @property
    def content_hash(self) -> str:
        """A hash of `canonical`: changes whenever the claim does (a sort, an invariant, ...)."""
        return hashlib.sha256(self.canonical.encode()).hexdigest()[:16]

    @property
    def latex(self) -> str:
        """The claim `assumptions → [program] guarantee` as LaTeX math (no `$`)."""
        from certiloop.models.lang import notation  # display only: not in the checker's base
        return notation.claim(self.assumptions, self.program, self.guarantee)

    def _repr_latex_(self) -> str:
        """Notebook display: the claim in dL notation."""
        return f"$${self.latex}$$"

    def _repr_html_(self) -> str:
        """Notebook display: name, expected verdict, description, the claim in dL notation
        and, folded, as `text` (with the invariants and branch labels)."""
        from certiloop.models.lang import notation  # display only: not in the checker's base
        about = f" — {escape(self.description)}" if self.description else ""
        formula = notation.claim(self.assumptions, self.program, self.guarantee, notation.HTML)
        return (f'<div class="certiloop-theorem"><p><b>{escape(self.name)}</b> (expected '
                f"{escape(self.expected)}){about}</p><p>{formula}</p><details><summary>as text, with "
                f"annotations</summary><pre>{escape(self.text)}</pre></details></div>")


# --------------------------------------------------------------------------- well-formedness

IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
RESERVED_SORTS = ("Real", "Int", "Bool", "Array")


def visit(t: "Theorem", on_node: Callable[[Node, str], None],
           on_program: Callable[[Program, str], None] | None = None) -> None:
    """Call on_node for every formula and term node the theorem holds (programs inside
    modalities included), with where it is; on_program for every program node."""

    def nodes(n: Node, where: str) -> None:
        on_node(n, where)
        if n.op in ("box", "diamond"):
            programs(n.payload, where)
        for a in n.args:
            nodes(a, where)

    def programs(p: Program, where: str) -> None:
        if on_program is not None:
            on_program(p, where)
        if isinstance(p, (Assign, Havoc)):
            nodes(p.target, where)
        if isinstance(p, Assign):
            nodes(p.value, where)
        elif isinstance(p, Test):
            nodes(p.cond, where)
        elif isinstance(p, ODE):
            for v, f in p.eqs:
                nodes(v, where)
                nodes(f, where)
            for f in (p.domain, *p.invariants):
                nodes(f, where)
        elif isinstance(p, Loop) and p.invariant is not None:
            nodes(p.invariant, where)
        for q in children(p):
            programs(q, where)

    nodes(t.assumptions, "the assumptions")
    programs(t.program, "the program")
    nodes(t.guarantee, "the guarantee")
    for name, definition in t.abbreviations.items():
        nodes(definition, f"abbreviation {name}")
    for s in t.scenarios:
        nodes(s, "a scenario")
    for c in t.constants:
        nodes(c, "the constants")
    for what, condition in t.well_defined + t.defined_if:
        nodes(condition, f"well-definedness condition ({what})")
    for name, fact in t.ghosts:
        nodes(fact, f"the fact about the ghost {name}")


def symbol_occurrences(t: "Theorem") -> list[tuple[str, Sort, str]]:
    """(name, sort, where) for every symbol the theorem mentions: free or bound, in its
    formulas, programs, annotations, abbreviations, scenarios and constants."""
    out: list[tuple[str, Sort, str]] = []

    def on_node(n: Node, where: str) -> None:
        if n.op == "var":
            out.append((n.payload, n.sort, where))
        if n.op in QUANTIFIERS:
            out.extend((v.payload, v.sort, f"{where} (bound)") for v in n.payload)

    visit(t, on_node)
    return out


def _check_term_sorts(t: "Theorem", where: str) -> None:
    """Nodes built directly (not through the DSL's checked constructors) are sort-checked
    too: array indices have their domain's sort, an Int cell or symbol gets an Int value."""

    def on_node(n: Node, place: str) -> None:
        if n.op in ("select", "store"):
            indices = n.args[1:] if n.op == "select" else n.args[1:-1]
            for want, got in zip(n.args[0].sort.domain, indices):
                if got.sort != want:
                    raise ModelError(f"{where}: index `{got}` of `{n.args[0]}` in {place} has sort "
                                     f"{got.sort}, expected {want}")

    def on_program(p: Program, place: str) -> None:
        if isinstance(p, Assign):
            want, got = p.target.sort, p.value.sort
            ok = want == got or (want == REAL and got == INT)
            if not ok:
                raise ModelError(f"{where}: cannot assign `{p.value}` ({got}) to `{p.target}` ({want}) "
                                 f"in {place}")

    visit(t, on_node, on_program)


def _check_names_and_sorts(t: "Theorem", where: str) -> None:
    """One symbol, one sort; names are identifiers, so no name can look like the ones the
    prover makes up (those all contain '@')."""
    seen: dict[str, tuple[Sort, str]] = {}
    for name, sort, place in symbol_occurrences(t):
        if not IDENTIFIER.fullmatch(name):
            raise ModelError(f"{where}: symbol name {name!r} in {place} is not an identifier "
                             "(letters, digits and _, not starting with a digit); '@', '[', '!' "
                             "and '#' are reserved for names the prover makes up")
        for s in (sort, *sort.domain, *((sort.range,) if sort.range is not None else ())):
            if not s.is_numeric and s not in (BOOL,) and s.name != "Array":
                if not IDENTIFIER.fullmatch(s.name) or s.name in RESERVED_SORTS:
                    raise ModelError(f"{where}: index sort name {s.name!r} must be an identifier "
                                     "other than Real, Int, Bool and Array")
        if name in seen and seen[name][0] != sort:
            raise ModelError(f"{where}: symbol `{name}` is used with two sorts: {seen[name][0]} in "
                             f"{seen[name][1]} and {sort} in {place}; give each its own name")
        seen.setdefault(name, (sort, place))
    for abbrev in t.abbreviations:
        if not IDENTIFIER.fullmatch(abbrev):
            raise ModelError(f"{where}: abbreviation name {abbrev!r} is not an identifier")


def _check_odes(p: Program, where: str) -> None:
    if isinstance(p, ODE):
        for v, _ in p.eqs:
            if v.sort != REAL:
                raise ModelError(f"{where}: `{v.payload}` of sort {v.sort} cannot evolve in an ODE; "
                                 "only Real symbols change continuously")
    for q in children(p):
        _check_odes(q, where)


def _modal(f: Node) -> bool:
    return f.op in ("box", "diamond") or any(_modal(a) for a in f.args)


def _check_ghosts(t: Theorem, where: str) -> None:
    """Each ghost is a fresh name: the claim and the program's runs never mention it (a proof
    that assumes a fact about it then holds for the claim, whatever value it takes)."""
    claim = (set(free_vars(t.assumptions)) | set(free_vars(t.guarantee))
             | set(program_symbols(t.program, annotations=False)) | {c.payload for c in t.constants}
             | {n for s in t.scenarios for n in free_vars(s)}
             | {n for v in t.abbreviations.values() for n in free_vars(v)} | set(t.abbreviations))
    names = [name for name, _ in t.ghosts]
    for k, (name, fact) in enumerate(t.ghosts):
        if not name.isidentifier() or name in claim or name in names[:k]:
            raise ModelError(f"{where}: the ghost `{name}` must be a fresh name (the claim or an earlier "
                             "ghost uses it)")
        mentioned = set(free_vars(fact))
        if name not in mentioned:
            raise ModelError(f"{where}: the fact about the ghost `{name}` does not mention it: `{fact}`")
        # a later ghost is chosen after this fact is assumed: read here, it would be any value
        if later := sorted(mentioned & set(names[k + 1:])):
            raise ModelError(f"{where}: the fact about the ghost `{name}` mentions the later ghost "
                             f"`{later[0]}`")
        if _modal(fact):
            raise ModelError(f"{where}: the fact about the ghost `{name}` holds a modality: `{fact}`")


def check_well_formed(t: Theorem) -> None:
    where = f"theorem {t.name}"
    if not isinstance(t.name, str) or not t.name:
        raise ModelError("a theorem needs a non-empty name")
    if not t.name.isprintable():  # it names files, reports and the generated code's comments
        raise ModelError(f"theorem name {t.name!r}: use printable characters on one line "
                         "(no newline, tab or control character)")
    if not isinstance(t.program, Program):
        raise ModelError(f"{where}: program is not a hybrid program")
    _check_program_shape(t.program, where)
    for nm, val in t.abbreviations.items():
        if not isinstance(val, Node) or val.sort == BOOL:
            raise ModelError(f"{where}: abbreviation {nm} must be a term")
    if not isinstance(t.unroll, int) or isinstance(t.unroll, bool) or t.unroll < 1:
        raise ModelError(f"{where}: unroll must be a positive integer, got {t.unroll!r}")
    for c in t.constants:
        if not isinstance(c, Node) or c.op != "var":
            raise ModelError(f"{where}: constants must be symbols, got `{c}`")
    if t.roles is not None:
        check_roles(t.roles, where)
    _check_names_and_sorts(t, where)
    _check_ghosts(t, where)
    _check_term_sorts(t, where)
    _check_odes(t.program, where)
    prog_syms = program_symbols(t.program)
    # An assumption names a *constant* only if the program never writes it; a guarantee
    # about a symbol nobody mentions anywhere else is almost always a typo.
    # (a declared constant counts too: .kyx archives declare every symbol)
    mentioned = (set(free_vars(t.assumptions)) | set(prog_syms) | _written_in_modalities(t.guarantee)
                 | {c.payload for c in t.constants})
    for name in free_vars(t.guarantee):
        if name not in mentioned:
            raise ModelError(
                f"{where}: unknown symbol `{name}` in the guarantee (not in the assumptions or the program)"
            )
    writes = written(t.program)
    for c in t.constants:
        if c.payload in writes:
            raise ModelError(f"{where}: `{c.payload}` is declared constant but the program assigns to it")
    _check_quantifier_sorts(t.guarantee, where)
    _check_quantifier_sorts(t.assumptions, where)


_COLLECTIONS = {  # argument: (how its items look, whether each is a (name, value) pair)
    "constants": ("symbols, e.g. constants=(A, b)", False),
    "scenarios": ("formulas, e.g. scenarios=(G == 1,)", False),
    "well_defined": ('(what, formula) pairs, e.g. well_defined=(("sqrt of g", g >= 0),)', True),
    "defined_if": ('(what, formula) pairs, e.g. defined_if=(("sqrt of a", a >= 0),)', True),
    "witnesses": ('(variable, term) pairs, e.g. witnesses=(("del", eps),)', True),
    "ghosts": ('(name, formula) pairs, e.g. ghosts=(("l", l >= 0),)', True),
}


def _check_collections(t: Theorem) -> None:
    """The arguments that hold several items are tuples or lists of the right items (a bare
    formula or symbol is one item the user forgot to wrap, not a collection)."""
    for argument, (items, pairs) in _COLLECTIONS.items():
        value = getattr(t, argument)
        wrong = isinstance(value, Node) or not isinstance(value, (tuple, list)) or (
            pairs and not all(isinstance(v, (tuple, list)) and len(v) == 2 for v in value))
        if wrong:
            raise ModelError(f"theorem {t.name}: {argument} must be a tuple of {items}, got {value!r}")


def _check_program_shape(program: Program, where: str) -> None:
    """Every part of the program is a program, and no sequence or choice is empty (what the
    constructors ensure, checked for programs built from the classes directly)."""
    stack = [program]
    while stack:
        p = stack.pop()
        labels = p.labels if isinstance(p, Choice) else (p.label,) if isinstance(p, Loop) else ()
        for label in labels:
            if not isinstance(label, str) or not label.isprintable():
                raise ModelError(f"{where}: the label {label!r} must be printable text on one line "
                                 "(it names proof paths and comments in the generated code)")
        parts = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else None
        if parts is not None and not parts:
            kind = "sequence" if isinstance(p, Seq) else "choice"
            raise ModelError(f"{where}: an empty {kind} in the program "
                             "(use skip() for a step that does nothing)")
        for child in children(p):
            if not isinstance(child, Program):
                raise ModelError(f"{where}: expected a hybrid program inside {type(p).__name__}, "
                                 f"got {child!r}")
            stack.append(child)


def _written_in_modalities(n: Node) -> set[str]:
    out: set[str] = set(written(n.payload)) if n.op in ("box", "diamond") else set()
    for a in n.args:
        out |= _written_in_modalities(a)
    return out


def _check_quantifier_sorts(n: Node, where: str) -> None:
    if n.op in QUANTIFIERS:
        for v in n.payload:
            if v.sort == BOOL:
                raise ModelError(f"{where}: cannot quantify over the Bool symbol `{v.payload}`")
    for a in n.args:
        _check_quantifier_sorts(a, where)
