"""A proved model with its proof's annotations, for `certiloop export --kyx --with-proof`.

The proof's certificate (proofs/engine/certificate_writer.py; the format in
proofs/checker/README.md) records the rule the proof used at each program node, with its
hints. Two of them have a KeYmaera X annotation: a loop's invariant (`{...}*@invariant(J)`;
a loop the proof ran with the guarantee as its invariant gets the guarantee) and an ODE's
differential-cut chain (`{x'=f}@invariant(c1, c2, ...)`: KeYmaera X's ODE tactic cuts the
annotated formulas in order, each proved by whichever invariance rule works). Everything else
has no annotation and is only listed in the notes: an ODE proved by its solution or by
differential weakening (KeYmaera X's ODE tactic tries both itself), which rule proved each
cut (dI, Darboux with its cofactor, barrier), ghosts and witnesses of the proof's own, and
the arithmetic leaves proved through a weakening (instances, abstractions), which KeYmaera X
has to prove as stated. The certificate's formulas are read with the proof checker's reader.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from certiloop.models.lang.programs import ODE, Choice, Loop, Program, Seq
from certiloop.models.lang.terms import Node, free_vars
from certiloop.models.lang.theorem import Theorem, symbol_occurrences
from certiloop.proofs.checker import keys


@dataclass(frozen=True)
class ProofAnnotations:
    theorem: Theorem  # the model, its loops and ODEs annotated as its proof had them
    notes: tuple[str, ...]  # what the proof used that no annotation says


def annotate(theorem: Theorem, certificate: dict) -> ProofAnnotations:
    """`theorem` with the loop invariants and cut chains of `certificate` (the certificate of
    its proof, as certificate_writer.certificate returns it) in place of its own annotations."""
    rules = {r["at"]: r for r in certificate["rules"]}
    proof = keys.theorem(certificate["theorem"]["canonical"])
    own = {n for n, _, _ in symbol_occurrences(theorem)}
    notes: list[str] = []
    program = _annotated(theorem.program, "0", (), rules, theorem.guarantee, own, notes)
    for name, fact in proof.ghosts[len(theorem.ghosts):]:
        notes.append(f"the proof's ghost `{name}` (with {fact}) has no annotation")
    for v, t in proof.witnesses[len(theorem.witnesses):]:
        notes.append(f"the proof's witness {v} := {t} has no annotation")
    weakened = sum(leaf.get("weakening") is not None for leaf in certificate["leaves"])
    if weakened:
        notes.append(f"{weakened} of {len(certificate['leaves'])} arithmetic leaves were proved through "
                     "a weakening (instances, abstractions), which has no annotation")
    return ProofAnnotations(replace(theorem, program=program), tuple(notes))


def _annotated(p: Program, at: str, path: tuple[str, ...], rules: dict, guarantee: Node, own: set[str],
               notes: list[str]) -> Program:
    """p with the annotations of the rules recorded at its address and below (the addresses
    are certificate_writer's: `0` the program, `0.i` its i-th part, alternative or body);
    `path`: the loop and branch labels on the way to p, to say where a note belongs."""
    rule = rules.get(at, {}).get("rule")
    if isinstance(p, Seq):
        return replace(p, parts=tuple(_annotated(q, f"{at}.{n}", path, rules, guarantee, own, notes)
                                      for n, q in enumerate(p.parts)))
    if isinstance(p, Choice):
        return replace(p, alternatives=tuple(
            _annotated(q, f"{at}.{n}", (*path, p.labels[n]), rules, guarantee, own, notes)
            for n, q in enumerate(p.alternatives)))
    if isinstance(p, Loop):
        if rule != "loop":
            raise ValueError(f"the certificate has no loop rule at {at}")  # not this theorem's proof
        text = rules[at]["invariant"]
        invariant = guarantee if text is None else keys.from_text(text, want_formula=True)
        if _modal(invariant):  # the guarantee holds a modality: not written as an invariant
            notes.append(f"loop `{p.label}`: the proof's invariant {invariant} holds a modality; left out")
            invariant = p.invariant
        body = _annotated(p.body, f"{at}.0", (*path, p.label), rules, guarantee, own, notes)
        return replace(p, body=body, invariant=invariant)
    if isinstance(p, ODE):
        return _ode(p, rules.get(at, {}), path, own, notes)
    return p


def _ode(p: ODE, rule: dict, path: tuple[str, ...], own: set[str], notes: list[str]) -> ODE:
    where = "the ODE {" + ", ".join(f"{v}' = {f}" for v, f in p.eqs) + "}"
    where += f" (in {' / '.join(path)})" if path else ""
    if rule.get("rule") in ("solve", "dW"):
        how = "its solution" if rule["rule"] == "solve" else "differential weakening"
        notes.append(f"{where} was proved by {how} (KeYmaera X's ODE tactic tries it itself)")
        return replace(p, invariants=())
    if rule.get("rule") != "dC":
        raise ValueError(f"the certificate has no ODE rule for {where}")
    cuts = []
    for link in rule["chain"]:
        atom = keys.from_text(link["atom"], want_formula=True)
        if not set(free_vars(atom)) <= own:
            notes.append(f"{where}: the cut {atom} uses the proof's own symbols and is left out")
            continue
        cuts.append(atom)
        if link["method"] != "dI":
            cofactor = link["cofactor"]
            with_ = "" if cofactor is None else f" with cofactor {keys.from_text(cofactor)}"
            notes.append(f"{where}: the cut {atom} was proved by {link['method']}{with_}")
    return replace(p, invariants=tuple(cuts))


def _modal(f: Node) -> bool:
    return f.op in ("box", "diamond") or any(_modal(a) for a in f.args)


def prove_annotated(theorem: Theorem, prover) -> ProofAnnotations | str:
    """Prove `theorem` with `prover` (an open proofs.engine.Prover) and annotate it with its
    proof; or why it was not proved, in one line."""
    from certiloop.api import prove
    from certiloop.proofs.engine.certificate_writer import certificate

    result = prove(theorem, prover=prover)
    if result.verdict != "proved":
        why = " ".join((result.reason or "no reason given").split())  # one line
        return f"{theorem.name} is not proved ({result.verdict}: {why})"
    if result.proof is None:
        return f"{theorem.name} is proved without a certificate to take annotations from ({result.reason})"
    return annotate(theorem, certificate(*result.proof, result.obligations))
