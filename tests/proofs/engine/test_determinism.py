"""Verdicts never depend on the clock, the machine's load or Python's hash seed."""

import multiprocessing
import os
import subprocess
import sys
import time

import pytest

from certiloop.models import library
from certiloop.proofs.engine import Prover

DIGEST = """
import hashlib
from certiloop.models import library
from certiloop.proofs.arith.projection import abbreviation_instances
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.core.weaken import weakenings
h = hashlib.sha256()
for name in {names!r}:
    for ob in generate(library.get(name)):
        h.update(str(ob.formula).encode())
        for how, f in weakenings(ob.formula, ob.abbreviations, abbreviation_instances, ob.stronger):
            h.update(how.encode() + str(f).encode())
print(h.hexdigest())
"""


def test_obligations_and_their_weakenings_do_not_depend_on_the_hash_seed():
    """z3's search (and so a resource-bounded verdict) depends on the exact formula: it must
    be the same text whatever order Python's sets and dicts of strings happen to take."""
    names = ["sbs.ctrl1", "sbs.ctrl2_2d", "sbs.predictive", "cfmpa.builtdr", "textbook.train"]
    digests = set()
    for seed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        out = subprocess.run([sys.executable, "-c", DIGEST.format(names=names)], env=env,
                             capture_output=True, text=True, timeout=600, check=True)
        digests.add(out.stdout.strip())
    assert len(digests) == 1


def _burn(stop_at: float) -> None:
    x = 0
    while time.time() < stop_at:
        x = (x * 31 + 7) % 1_000_003


def _verdicts(name: str) -> tuple[str, list[str]]:
    with Prover(jobs=2) as prover:
        result = prover.prove(library.get(name))
    return result.verdict, [o.verdict for o in result.obligations]


@pytest.mark.slow
def test_a_heavy_refuted_model_gets_the_same_verdicts_with_both_cores_busy():
    idle = _verdicts("sbs.ctrl2_last_wins")
    ctx = multiprocessing.get_context("fork")
    burners = [ctx.Process(target=_burn, args=(time.time() + 600,)) for _ in range(2)]
    for b in burners:
        b.start()
    try:
        busy = _verdicts("sbs.ctrl2_last_wins")
    finally:
        for b in burners:
            b.terminate()
            b.join()
    assert idle[0] == "refuted"
    assert busy == idle
