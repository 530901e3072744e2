"""No mutant of a library model that the falsifier can break is ever proved.

The default run takes an evenly spread sample of mutants of every library model; the deep
run (HYPOTHESIS_PROFILE=deep python -m pytest -q) takes all of them."""

from __future__ import annotations

import pytest

from certiloop.falsify.search import Options, falsify
from certiloop.models import library
from certiloop.models.lang.terms import ModelError
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine import Budget, Prover, discharge_one

from .mutants import mutants

SAMPLE = 2  # per model and kind in the default run
# A mutant that needs more is 'unknown', which is allowed (the library needs under 60,000).
# z3 can stall on a false raw obligation without counting units; the wall net then makes it
# 'unknown', which only costs a mutant the chance to be checked, never a wrong pass.
BUDGET = Budget(rlimit=150_000, wall_s=20)


def _proves(theorem) -> bool:
    """What the engine's `proved` rests on: every obligation proved. Stops at the first one
    that is not (the mutant is then not proved, whatever the others say)."""
    return all(discharge_one(ob, BUDGET).verdict == "proved" for ob in generate(theorem))


def _check(name: str, limit: int | None, prover: Prover, examples: int,
           quick: bool = True) -> tuple[int, int, int]:
    """quick: only discharge the obligations (what can make a mutant proved); otherwise
    also search for a violating run of mutants that do not prove, which must be confirmed."""
    proved = refuted = other = 0
    for what, mutant in mutants(library.get(name), limit):
        try:
            if quick:
                verdict = "proved" if _proves(mutant) else "unknown"
            else:
                result = prover.prove(mutant)
                verdict = result.verdict
        except ModelError:  # e.g. a perturbed constant made a division by zero literal
            continue
        if verdict == "proved":
            proved += 1
            found = falsify(mutant, Options(max_examples=examples, database=None, shrink=False))
            assert not found.found, (f"{mutant.name} ({what}) was PROVED, yet the falsifier found a "
                                     f"violating run: {found.run.violated if found.run else ''}")
        elif verdict == "refuted":
            refuted += 1
            assert result.run is not None and result.run.confirmed
        else:
            other += 1
    return proved, refuted, other


@pytest.fixture(scope="module")
def prover():
    with Prover(jobs=2, budget=BUDGET) as p:
        yield p


# the big models' mutants take minutes: they run in the slow set (`-m slow`, run by CI)
BIG = ("sbs.ctrl2", "sbs.predictive_multi", "rcm.", "raven.")


def _sampled(name: str):
    return pytest.param(name, marks=pytest.mark.slow) if name.startswith(BIG) else name


@pytest.mark.parametrize("name", [_sampled(n) for n in library.names()])
def test_sampled_mutants_that_prove_have_no_violating_run(prover, name):
    if next(iter(mutants(library.get(name), SAMPLE)), None) is None:
        pytest.skip(f"{name} has no test, domain or constant to mutate")
    proved, refuted, other = _check(name, SAMPLE, prover, examples=200)
    assert proved + refuted + other > 0


@pytest.mark.deep
@pytest.mark.parametrize("name", library.names())
def test_every_mutant_that_proves_has_no_violating_run(prover, name):
    _check(name, None, prover, examples=1000, quick=False)
