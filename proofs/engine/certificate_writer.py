"""Write a proof certificate (format v1, proofs/checker/README.md) for a proved theorem.

Recording only: the proof is re-generated from the theorem and the ODE plan the prover used
(generation is deterministic), and each rule the core applied is written down with its hints.
Nothing here decides anything; `certiloop check-proof` does.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from certiloop.models.lang.programs import ODE, Choice, Loop, Program, Seq
from certiloop.models.lang.terms import Var
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.arith.smtlib import script
from certiloop.proofs.checker.certificate import DECIDED, FORMAT, tree
from certiloop.proofs.core.odes import OdeStep, default_chain, polynomial_solution
from certiloop.proofs.core.vcgen import generate


def certificate(theorem: Theorem, plan: dict[tuple, tuple[OdeStep, ...]]) -> dict:
    """The certificate of the proof of `theorem` with the ODE `plan` (as vcgen.generate reads it)."""
    obligations = generate(theorem, plan)
    return {
        "format": FORMAT,
        "theorem": {"name": theorem.name, "hash": theorem.content_hash, "canonical": theorem.canonical},
        "rules": _rules(theorem.program, "0", plan),
        "tree": tree([(ob.id, ob.path) for ob in obligations]),
        "leaves": [{"id": ob.id, "path": ob.path, "smtlib": script(ob.formula), "decided": DECIDED}
                   for ob in obligations],
    }


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


def write_certificate(theorem: Theorem, plan: dict, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    safe = re.sub(r"[^\w.+=-]+", "_", theorem.name).strip("_")
    path = folder / f"{safe}.certificate.json"
    path.write_text(json.dumps(certificate(theorem, plan), indent=1, ensure_ascii=False) + "\n")
    return path
