"""No mutant of a library model that the falsifier can break is ever proved.

The default run takes an evenly spread sample of mutants of every library model; the deep
run (HYPOTHESIS_PROFILE=deep python -m pytest -m deep) takes all of them."""

from __future__ import annotations

import pytest

from certiloop.falsify.search import Options, falsify
from certiloop.models import library
from certiloop.models.lang.terms import ModelError
from certiloop.proofs.engine import Budget, Prover

from .mutants import mutants

SAMPLE = 2  # per model and kind in the default run
BUDGET = Budget(rlimit=2_000_000)  # a mutant that needs more is 'unknown', which is allowed


def _check(name: str, limit: int | None, prover: Prover, examples: int) -> tuple[int, int, int]:
    proved = refuted = other = 0
    for what, mutant in mutants(library.get(name), limit):
        try:
            result = prover.prove(mutant)
        except ModelError:  # e.g. a perturbed constant made a division by zero literal
            continue
        if result.verdict == "proved":
            proved += 1
            found = falsify(mutant, Options(max_examples=examples, database=None, shrink=False))
            assert not found.found, (f"{mutant.name} ({what}) was PROVED, yet the falsifier found a "
                                     f"violating run: {found.run.violated if found.run else ''}")
        elif result.verdict == "refuted":
            refuted += 1
            assert result.run is not None and result.run.confirmed
        else:
            other += 1
    return proved, refuted, other


@pytest.fixture(scope="module")
def prover():
    with Prover(jobs=2, budget=BUDGET) as p:
        yield p


@pytest.mark.parametrize("name", library.names())
def test_sampled_mutants_that_prove_have_no_violating_run(prover, name):
    proved, refuted, other = _check(name, SAMPLE, prover, examples=200)
    assert proved + refuted + other > 0


@pytest.mark.deep
@pytest.mark.parametrize("name", library.names())
def test_every_mutant_that_proves_has_no_violating_run(prover, name):
    _check(name, None, prover, examples=1000)
