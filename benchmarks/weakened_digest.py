"""A digest of every library model's obligations and their weakened forms, as z3 would see
them (the SMT-LIB text of each), so a change meant only for speed can show it changed no
formula: z3's search, and so a resource-bounded verdict, depends on the exact text.

    python benchmarks/weakened_digest.py [MODEL ...]      # one line per model, then the total
"""

from __future__ import annotations

import hashlib
import sys

from certiloop.models import library
from certiloop.proofs.arith.projection import abbreviation_instances
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.core.weaken import weakenings
from certiloop.proofs.core.z3terms import Z3Translator


def smt_text(formula) -> str:
    tr = Z3Translator()
    try:
        return tr(formula).sexpr()
    finally:
        tr.release()


def digest(name: str) -> str:
    h = hashlib.sha256()
    try:
        obligations = generate(library.get(name))
    except Exception as exc:  # noqa: BLE001 - the failure is part of what must not change
        return f"error {type(exc).__name__}"
    for ob in obligations:
        h.update(ob.path.encode() + str(ob.formula).encode())
        for how, f in weakenings(ob.formula, ob.abbreviations, abbreviation_instances, ob.stronger):
            h.update(how.encode() + smt_text(f).encode())
    return h.hexdigest()[:16]


def main() -> None:
    sys.setrecursionlimit(100_000)
    names = sys.argv[1:] or library.names()
    total = hashlib.sha256()
    for name in names:
        d = digest(name)
        total.update(f"{name} {d}".encode())
        print(name, d, flush=True)
    print("total", total.hexdigest()[:16])


if __name__ == "__main__":
    main()
