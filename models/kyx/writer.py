"""Write Theorems as KeYmaera X archives (.kyx).

Everything is printed fully parenthesised, so KeYmaera X's parser and ours read the same
tree. certiloop's invariants become `@invariant` annotations (a loop's one formula, an ODE's
differential-cut chain). What .kyx has no syntax for (branch and loop labels, the expected
verdict, abbreviations, scenarios, names KeYmaera X does not allow) rides along in one
`/*@certiloop {...}*/` comment per entry, which KeYmaera X ignores and our reader uses, so
export -> read gives back the same theorem. A model .kyx cannot express at all (arrays,
families, integers) raises `NotExpressible` with the reason.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from fractions import Fraction

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import BOOL, INT, REAL, ModelError, Node
from certiloop.models.lang.theorem import Theorem, symbol_occurrences

KYX_IDENT = re.compile(r"[A-Za-z][A-Za-z0-9]*(_[0-9]+)?")  # KeYmaera X's identifiers (with index)
KEYWORDS = {"true", "false", "Real", "Bool", "HP", "HG", "Axiom", "End", "Functions", "Definitions",
            "ProgramVariables", "Variables", "Problem", "Tactic", "implicit", "Sequent", "Formula",
            "Lemma", "Tool", "SharedDefinitions", "ArchiveEntry", "Theorem", "Exercise", "if",
            "else", "old", "abs", "min", "max", "import"}


class NotExpressible(ModelError):
    """The theorem uses something a KeYmaera X archive cannot say; the message says what."""


class _Printer:
    def __init__(self, theorem: Theorem, names: dict[str, str]):
        self.t = theorem
        self.names = names

    def fail(self, what: str) -> NotExpressible:
        return NotExpressible(f"theorem {self.t.name} cannot be written as .kyx: {what}")

    def num(self, n: Node) -> str:
        f: Fraction = n.payload
        if n.sort == INT:
            text = str(f.numerator)
        elif f.denominator == 1:
            text = f"{abs(f.numerator)}.0"
            text = f"-{text}" if f < 0 else text
        else:
            text = f"{f.numerator}/{f.denominator}"
        return f"({text})" if f < 0 or "/" in text else text

    def term(self, n: Node) -> str:
        op = n.op
        if n.sort not in (REAL, INT):
            raise self.fail(f"`{n}` has sort {n.sort} (KeYmaera X has reals only)")
        if op == "const":
            return self.num(n)
        if op == "var":
            if n.sort == INT:
                raise self.fail(f"the integer symbol `{n.payload}` (KeYmaera X has reals only)")
            return self.names.get(n.payload, n.payload)
        if op == "+":
            out = self.term_arg(n.args[0])
            for a in n.args[1:]:
                out += f" - {self.term_arg(a.args[0])}" if a.op == "neg" else f" + {self.term_arg(a)}"
            return out
        if op == "neg":
            return f"-{self.term_arg(n.args[0])}"
        if op == "*":
            return "*".join(self.term_arg(a) for a in n.args)
        if op == "/":
            if n.args[0].op == "const" and n.args[1].op == "const":
                raise self.fail(f"the division of constants `{n}` (it would read back as one number)")
            return f"{self.term_arg(n.args[0])}/{self.term_arg(n.args[1])}"
        if op == "^":
            return f"{self.term_arg(n.args[0])}^{n.payload}"
        if op in ("select", "store"):
            raise self.fail(f"the array or family access `{n}` (KeYmaera X archives have no arrays)")
        raise self.fail(f"the term `{n}`")  # pragma: no cover

    def term_arg(self, n: Node) -> str:
        text = self.term(n)
        return text if n.op in ("var",) or (n.op == "const" and not text.startswith("(")) else f"({text})"

    def formula(self, n: Node) -> str:
        op = n.op
        if op in ("true", "false"):
            return op
        if op == "var":
            raise self.fail(f"the Bool symbol `{n.payload}`")
        if op == "cmp":
            sym = {"==": "="}.get(n.payload, n.payload)
            return f"{self.term(n.args[0])} {sym} {self.term(n.args[1])}"
        if op in ("and", "or"):
            joiner = " & " if op == "and" else " | "
            return joiner.join(f"({self.formula(a)})" for a in n.args)
        if op == "not":
            return f"!({self.formula(n.args[0])})"
        if op == "implies":
            return f"({self.formula(n.args[0])}) -> ({self.formula(n.args[1])})"
        if op == "iff":
            return f"({self.formula(n.args[0])}) <-> ({self.formula(n.args[1])})"
        if op in ("forall", "exists"):
            for v in n.payload:
                if v.sort != REAL:
                    raise self.fail(f"a quantifier over the {v.sort} symbol `{v.payload}`")
            q = "\\forall" if op == "forall" else "\\exists"
            names = ", ".join(self.names.get(v.payload, v.payload) for v in n.payload)
            return f"{q} {names} ({self.formula(n.args[0])})"
        if op == "box":
            return f"[{self.program(n.payload, 1)}]({self.formula(n.args[0])})"
        if op == "diamond":
            return f"<{self.program(n.payload, 1)}>({self.formula(n.args[0])})"
        if n.sort != BOOL:
            raise self.fail(f"`{n}` is not a formula")  # pragma: no cover
        raise self.fail(f"the formula `{n}`")  # pragma: no cover

    def program(self, p: Program, depth: int) -> str:
        pad = "\n" + "  " * depth
        if isinstance(p, Assign):
            if p.target.op != "var":
                raise self.fail(f"the array assignment `{p}`")
            return f"{self.term(p.target)} := {self.term(p.value)};"
        if isinstance(p, Havoc):
            if p.target.op != "var":
                raise self.fail(f"the array assignment `{p}`")
            return f"{self.term(p.target)} := *;"
        if isinstance(p, Test):
            return f"?({self.formula(p.cond)});"
        if isinstance(p, Seq):
            return pad.join(self.program(q, depth) for q in p.parts)
        if isinstance(p, Choice):
            alts = [f"{{{pad}  {self.program(q, depth + 1)}{pad}}}" for q in p.alternatives]
            return "{" + f"{pad}  " + f"{pad}++ ".join(alts) + f"{pad}}}"
        if isinstance(p, Loop):
            if p.each is not None or p.count is not None:
                raise self.fail(f"the counted loop `{p.label}` (foreach/for_range)")
            inv = "" if p.invariant is None else f"@invariant({self.formula(p.invariant)})"
            return f"{{{pad}  {self.program(p.body, depth + 1)}{pad}}}*{inv}"
        if isinstance(p, ODE):
            eqs = ", ".join(f"{self.names.get(v.payload, v.payload)}' = {self.term(f)}" for v, f in p.eqs)
            dom = "" if p.domain.op == "true" else f" & {self.formula(p.domain)}"
            invs = ", ".join(self.formula(i) for i in p.invariants)
            return f"{{{eqs}{dom}}}" + (f"@invariant({invs})" if invs else "")
        raise self.fail(f"the program `{p}`")  # pragma: no cover


def _labels(p: Program) -> list[str]:
    """Branch and loop labels in pre-order (the reader puts them back in that order)."""
    out: list[str] = []

    def walk(q: Program) -> None:
        if isinstance(q, Seq):
            for x in q.parts:
                walk(x)
        elif isinstance(q, Loop):
            out.append(q.label)
            walk(q.body)
        elif isinstance(q, Choice):
            out.extend(q.labels)
            for x in q.alternatives:
                walk(x)

    walk(p)
    return out


def _kyx_names(t: Theorem) -> dict[str, str]:
    """certiloop name -> a name KeYmaera X accepts (inner '_' dropped, keywords suffixed)."""
    names = sorted({n for n, _, _ in symbol_occurrences(t)})
    taken = set(names)
    out: dict[str, str] = {}
    for n in names:
        if KYX_IDENT.fullmatch(n) and n not in KEYWORDS:
            continue
        base = re.sub(r"[^A-Za-z0-9]", "", n) or "v"
        base = base if base[0].isalpha() else f"v{base}"
        candidate, k = base, 1
        while candidate in taken or candidate in KEYWORDS or not KYX_IDENT.fullmatch(candidate):
            k += 1
            candidate = f"{base}x{k}"
        taken.add(candidate)
        out[n] = candidate
    return out


def to_kyx(t: Theorem, proof_notes: Sequence[str] | None = None) -> str:
    """One ArchiveEntry for the theorem; raises NotExpressible if .kyx cannot say it.
    proof_notes: the annotations are a proof's (`export --with-proof`), and these are the
    steps of that proof that have no annotation; they go into the metadata comment."""
    names = _kyx_names(t)
    pr = _Printer(t, names)
    if t.well_defined or t.defined_if:  # written as assumptions, the pins would prove what is ill-defined
        raise pr.fail(f"its side condition ({(t.well_defined + t.defined_if)[0][0]}) has no .kyx form")
    if t.ghosts:  # a proof hint with a fact the proof must first show satisfiable: not an annotation
        raise pr.fail(f"its ghost constant `{t.ghosts[0][0]}` has no .kyx form")
    body = pr.program(t.program, 2)
    problem = f"  ({pr.formula(t.assumptions)})\n  ->\n  [\n    {body}\n  ]({pr.formula(t.guarantee)})"
    constants = [c.payload for c in t.constants]
    sorts = {n: s for n, s, _ in symbol_occurrences(t)}
    for n, s in sorts.items():
        if s != REAL:
            raise pr.fail(f"the {s} symbol `{n}` (KeYmaera X has reals only)")
    variables = [n for n in sorted(sorts) if n not in constants]
    meta = {
        "expected": t.expected, "description": t.description, "labels": _labels(t.program),
        "unroll": t.unroll, "check_nonblocking": t.check_nonblocking, "shape": "A->[a]P",
        "abbreviations": {k: pr.term(v) for k, v in t.abbreviations.items()},
        "scenarios": [pr.formula(s) for s in t.scenarios],
        "names": {kyx: ours for ours, kyx in names.items()},
    }
    if proof_notes is not None:
        meta["proof"] = {"annotations": "the loop invariants and differential cuts of certiloop's proof",
                         "not_annotated": list(proof_notes)}
    if t.roles is not None:  # certiloop's own names, as the reader gives them back
        meta["roles"] = {"environment": list(t.roles.environment_names),
                         "controls": list(t.roles.control_names)}
    lines = [f"ArchiveEntry {json.dumps(t.name, ensure_ascii=False)}"]
    if t.description:
        lines.append(f"  Description {json.dumps(t.description, ensure_ascii=False)}.")
    lines.append(f"  /*@certiloop {json.dumps(meta)} */")
    if constants:
        lines += ["  Definitions", *(f"    Real {names.get(c, c)};" for c in constants), "  End."]
    if variables:
        lines += ["  ProgramVariables", *(f"    Real {names.get(v, v)};" for v in variables), "  End."]
    lines += ["  Problem", problem, "  End.", "End."]
    text = "\n".join(lines) + "\n"
    if "*/" in json.dumps(meta):
        raise pr.fail("its metadata contains `*/`, which would end the comment")
    return text


def write_archive(theorems: list[Theorem], proof_notes: Sequence[Sequence[str]] | None = None) -> str:
    """An archive of several theorems; raises NotExpressible for the first that cannot be said.
    proof_notes: for each theorem, what its proof used that no annotation says (see to_kyx)."""
    notes = [None] * len(theorems) if proof_notes is None else proof_notes
    return "\n".join(to_kyx(t, n) for t, n in zip(theorems, notes, strict=True))
