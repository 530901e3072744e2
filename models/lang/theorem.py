"""A Theorem: assumptions -> [program] guarantee, with annotations and an expected verdict."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

from certiloop.models.lang.printing import show, show_program
from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Loop,
    Program,
    Seq,
    Test,
    program_symbols,
    written,
)
from certiloop.models.lang.terms import (
    BOOL,
    QUANTIFIERS,
    ModelError,
    Node,
    formula,
    free_vars,
)

VERDICTS = ("proved", "refuted")


@dataclass(frozen=True, eq=False)
class Theorem:
    """`assumptions -> [program] guarantee`, the claim a model makes.

    abbreviations: name -> term, e.g. {"d0": dot(p - r, n)}. The prover may replace these
    subterms by fresh variables (a sound generalisation) to keep arithmetic small.
    expected: the verdict the author expects; unsafe designs are kept as `refuted`.
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

    def __post_init__(self) -> None:
        if self.expected not in VERDICTS:
            raise ModelError(f"theorem {self.name}: expected must be one of {VERDICTS}")
        object.__setattr__(self, "assumptions", formula(self.assumptions))
        object.__setattr__(self, "guarantee", formula(self.guarantee))
        object.__setattr__(self, "scenarios", tuple(formula(s) for s in self.scenarios))
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
    def content_hash(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()[:16]



# --------------------------------------------------------------------------- well-formedness


def _nonzero_facts(assumptions: Node) -> set[str]:
    """Symbols the assumptions state are nonzero by a top-level conjunct c > 0, c < 0, c != 0."""
    out: set[str] = set()
    conj = assumptions.args if assumptions.op == "and" else (assumptions,)
    for c in conj:
        if c.op != "cmp":
            continue
        a, b = c.args
        zero = lambda x: x.op == "const" and x.payload == 0  # noqa: E731
        if c.payload in (">", "<", "!=") and a.op == "var" and zero(b):
            out.add(a.payload)
        if c.payload in (">", "<", "!=") and b.op == "var" and zero(a):
            out.add(b.payload)
    return out


def _nonzero(d: Node, safe: set[str]) -> bool:
    """d is a product/power of nonzero literals and parameters the assumptions bound away from 0."""
    if d.op == "const":
        return d.payload != 0
    if d.op == "var":
        return d.payload in safe
    if d.op in ("*", "neg", "^", "/"):
        return all(_nonzero(a, safe) for a in d.args)
    return False


def _check_divisions(n: Node, safe: set[str], where: str) -> None:
    if n.op == "/":
        d = n.args[1]
        if not _nonzero(d, safe):
            raise ModelError(
                f"{where}: division by `{show(d)}`, which is not a constant known to be nonzero; "
                "divide by a parameter the assumptions bound away from 0, or write "
                "`tmp := *; ?tmp*d = 1` as the seed does"
            )
    if n.op in ("box", "diamond"):
        _check_program(n.payload, safe, where)
    for a in n.args:
        _check_divisions(a, safe, where)


def _check_program(p: Program, safe: set[str], where: str) -> None:
    def visit(q: Program) -> None:
        if isinstance(q, Assign):
            _check_divisions(q.value, safe, f"{where}: `{show_program(q)}`")
        elif isinstance(q, Test):
            _check_divisions(q.cond, safe, f"{where}: `{show_program(q)}`")
        elif isinstance(q, ODE):
            for v, f in q.eqs:
                _check_divisions(f, safe, f"{where}: ODE {v.payload}'")
            _check_divisions(q.domain, safe, f"{where}: ODE domain")
        elif isinstance(q, Seq):
            for r in q.parts:
                visit(r)
        elif isinstance(q, Choice):
            for r in q.alternatives:
                visit(r)
        elif isinstance(q, Loop):
            visit(q.body)
            if q.invariant is not None:
                _check_divisions(q.invariant, safe, f"{where}: invariant of {q.label}")

    visit(p)


def check_well_formed(t: Theorem) -> None:
    where = f"theorem {t.name}"
    if not isinstance(t.program, Program):
        raise ModelError(f"{where}: program is not a hybrid program")
    for nm, val in t.abbreviations.items():
        if not isinstance(val, Node) or val.sort == BOOL:
            raise ModelError(f"{where}: abbreviation {nm} must be a term")
    declared = dict(free_vars(t.assumptions))
    declared.update(free_vars(t.guarantee))
    prog_syms = program_symbols(t.program)
    declared.update(prog_syms)
    for name, v in list(declared.items()):
        if "@" in name:
            raise ModelError(f"{where}: symbol name {name!r} may not contain '@'")
        for other in (t.assumptions, t.guarantee):
            o = free_vars(other).get(name)
            if o is not None and o.sort != v.sort:
                raise ModelError(f"{where}: symbol `{name}` used with sorts {o.sort} and {v.sort}")
    for name, v in prog_syms.items():
        if name in declared and declared[name].sort != v.sort:
            raise ModelError(f"{where}: symbol `{name}` used with sorts {declared[name].sort} and {v.sort}")
    # An assumption names a *constant* only if the program never writes it; a guarantee
    # about a symbol nobody mentions anywhere else is almost always a typo.
    mentioned = set(free_vars(t.assumptions)) | set(prog_syms) | _written_in_modalities(t.guarantee)
    for name in free_vars(t.guarantee):
        if name not in mentioned:
            raise ModelError(
                f"{where}: unknown symbol `{name}` in the guarantee (not in the assumptions or the program)"
            )
    writes = written(t.program)
    for c in t.constants:
        if c.payload in writes:
            raise ModelError(f"{where}: `{c.payload}` is declared constant but the program assigns to it")
    safe = _nonzero_facts(t.assumptions) - set(writes)
    _check_program(t.program, safe, where)
    _check_divisions(t.assumptions, safe, f"{where}: assumptions")
    _check_divisions(t.guarantee, safe, f"{where}: guarantee")
    _check_quantifier_sorts(t.guarantee, where)


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
