"""Which library models' certificates the checker accepts, and checking time vs proving time.

    python benchmarks/checker_coverage.py [NAME-PREFIX ...] > benchmarks/results/checker_coverage.txt

One line per model expected proved: the prover's verdict and seconds, then the checker's
outcome and seconds (same process, one after the other)."""

from __future__ import annotations

import json
import sys
import time

from certiloop.models import library
from certiloop.proofs.checker import check
from certiloop.proofs.engine.certificate_writer import certificate
from certiloop.proofs.engine.prover import Prover


def main(prefixes: list[str]) -> None:
    names = [n for n in library.names() if not prefixes or n.startswith(tuple(prefixes))]
    with Prover(jobs=1) as prover:
        for name in names:
            theorem = library.get(name)
            if theorem.expected != "proved":
                continue
            start = time.perf_counter()
            result = prover.prove(theorem)
            proving = time.perf_counter() - start
            if result.proof is None:
                print(f"{name:45s} prove {result.verdict:8s} {proving:8.2f} s", flush=True)
                continue
            doc = json.loads(json.dumps(certificate(*result.proof, result.obligations)))
            start = time.perf_counter()
            outcome = check(doc)
            checking = time.perf_counter() - start
            print(f"{name:45s} prove {result.verdict:8s} {proving:8.2f} s  check {outcome.status:9s} "
                  f"{checking:7.2f} s  {outcome.message[:400]}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
