"""Write a proof certificate (format v1, or v2 when a leaf was proved through a weakening;
proofs/checker/README.md) for a proved theorem.

Recording only: the proof is re-generated from the theorem and the ODE plan the prover used
(generation is deterministic), and each rule the core applied is written down with its hints;
a leaf the prover closed by a weakening (instantiated, lowered, abstracted) gets the weakening
re-built here with the choices it made. Nothing here decides anything; `certiloop check-proof` does.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from certiloop.models.lang.programs import ODE, Choice, Loop, Program, Seq
from certiloop.models.lang.terms import Node, Var, free_vars
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.arith.projection import abbreviation_instances
from certiloop.proofs.arith.smtlib import script
from certiloop.proofs.checker.certificate import CASES, DECIDED, FORMAT, FORMAT_V2, WEAKENED, tree
from certiloop.proofs.core.abstraction import abstract, congruences, fresh_instances, lower_term
from certiloop.proofs.core.instantiate import instantiate
from certiloop.proofs.core.lowering import lower
from certiloop.proofs.core.odes import OdeStep, default_chain, polynomial_solution
from certiloop.proofs.core.vcgen import Obligation, generate
from certiloop.proofs.engine.forked import forked_map

STEPS = ("instantiated", "instantiated more", "lowered", "abstracted")


def certificate(theorem: Theorem, plan: dict[tuple, tuple[OdeStep, ...]], results=()) -> dict:
    """The certificate of the proof of `theorem` with the ODE `plan` (as vcgen.generate reads it).
    `results` (the prover's ObligationResults) say which leaves were proved through a weakening;
    without them every leaf is recorded as decided as stated."""
    obligations = generate(theorem, plan)
    backends = {r.id: r.backend for r in results if r.verdict == "proved"}

    def leaf(i: int) -> tuple[dict, dict | None]:  # each leaf alone: spread over forked children
        ob = obligations[i]
        return ({"id": ob.id, "path": ob.path, "smtlib": script(ob.formula), "decided": DECIDED},
                _weakening(ob, backends.get(ob.id, "z3")))

    leaves, weakened = map(list, zip(*forked_map(leaf, len(obligations)))) if obligations else ([], [])
    by_cases = [re.fullmatch(r"z3 \(\d+ cases\)", backends.get(ob.id, "")) is not None for ob in obligations]
    v2 = any(w is not None for w in weakened) or any(by_cases)
    if v2:
        for leaf, w, split in zip(leaves, weakened, by_cases):
            leaf.update(decided=CASES if split else DECIDED if w is None else WEAKENED, weakening=w)
    return {
        "format": FORMAT_V2 if v2 else FORMAT,
        "theorem": {"name": theorem.name, "hash": theorem.content_hash, "canonical": theorem.canonical},
        "rules": _rules(theorem.program, "0", plan),
        "tree": tree([(ob.id, ob.path) for ob in obligations]),
        "leaves": leaves,
    }


def _text(n: Node) -> str:
    return repr(n.key)


def _weakening(ob: Obligation, backend: str) -> dict | None:
    """The weakening `backend` names (as proofs/core/weaken.py built it), with its choices:
    the instances of each hypothesis, whether arrays were lowered, the abbreviation instances
    and congruences of the abstraction, and the atoms it rewrote; None for any other backend."""
    steps = backend[len("z3 ("):-1].split(", ") if backend.startswith("z3 (") else []
    if not steps or not set(steps) <= set(STEPS):
        return None
    base, record = ob.formula, []
    if steps[0].startswith("instantiated"):
        base = instantiate(base, steps[0] == "instantiated more", keep_goal_exists=True, record=record)
    lowered = "lowered" in steps
    found = abbreviation_instances(ob.abbreviations, base) if ob.abbreviations else []
    instances = fresh_instances(base, found)
    facts = congruences(instances, lower_term if lowered else (lambda t: t))
    if lowered:
        base = lower(base)
        instances = fresh_instances(base, [i.with_definition(lower_term(i.definition)) for i in instances])
    before = base
    if "abstracted" in steps:
        base = abstract(base, instances, facts)
    else:
        instances, facts = [], []
    used, atoms = free_vars(base), []
    if "abstracted" in steps:
        _atoms(base.args[1] if facts else base, before, atoms, [0])
    return {"instances": None if not steps[0].startswith("instantiated") else
            [k if isinstance(k, int) else [k[0], [_text(t) for t in k[1]]] for k in record],
            "lowered": lowered,
            "abbreviations": [[i.symbol.payload, _text(i.definition)] for i in instances
                              if i.symbol.payload in used],
            "facts": [_text(f) for f in facts],
            "atoms": atoms,
            "smtlib": script(base)}


def _atoms(w: Node, f: Node, out: list, seen: list[int]) -> None:
    """[k, atom of w] for each k-th atom (pre-order) the abstraction rewrote in f."""
    if f.op in ("and", "or", "not", "implies", "iff", "forall", "exists"):
        for a, b in zip(w.args, f.args):
            _atoms(a, b, out, seen)
        return
    if not w.same(f):
        out.append([seen[0], _text(w)])
    seen[0] += 1


def _rules(p: Program, at: str, plan: dict) -> list[dict]:
    subs = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else \
        (p.body,) if isinstance(p, Loop) else ()
    if isinstance(p, Loop):
        head = {"at": at, "rule": "loop", "invariant": None if p.invariant is None else repr(p.invariant.key)}
    elif isinstance(p, ODE):
        head = {"at": at, **_ode_rule(p, plan)}
    else:
        head = {"at": at, "rule": type(p).__name__.lower()}
    return [head] + [r for n, q in enumerate(subs) for r in _rules(q, f"{at}.{n}", plan)]


def _ode_rule(p: ODE, plan: dict) -> dict:
    """The rule vcgen applies to this ODE: the plan's cut chain, else the annotations' chain,
    else its polynomial solution, else differential weakening."""
    chain = plan.get(p.key)
    if chain is None and p.invariants:
        chain = default_chain(p)
    if chain is not None and (chain or p.invariants):
        return {"rule": "dC", "chain": [{"atom": repr(s.atom.key), "method": s.method,
                                         "cofactor": None if s.cofactor is None else repr(s.cofactor.key)}
                                        for s in chain]}
    solution = polynomial_solution(p, Var("s@flow"))
    if solution is None:
        return {"rule": "dW"}
    return {"rule": "solve", "solution": {name: repr(x.key) for name, x in solution.items()}}


def write_certificate(theorem: Theorem, plan: dict, folder: Path, results=()) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    safe = re.sub(r"[^\w.+=-]+", "_", theorem.name).strip("_")
    path = folder / f"{safe}.certificate.json"
    path.write_text(json.dumps(certificate(theorem, plan, results), indent=1, ensure_ascii=False) + "\n")
    return path
