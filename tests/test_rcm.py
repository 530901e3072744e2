"""Seed 001 (RCM admittance): every rcm.* model meets its verdict; refuted runs violate their
guarantee when re-checked here; the proved guard does not survive a smaller margin."""

import re
from fractions import Fraction

import pytest

from certiloop.models import library
from certiloop.models.library import rcm
from certiloop.proofs.core.exact import evaluate
from certiloop.proofs.engine.prover import Prover

NAMES = [n for n in library.names() if n.startswith("rcm.")]


@pytest.fixture(scope="module")
def prover():
    with Prover(jobs=2) as p:
        yield p


@pytest.fixture(scope="module")
def results(prover):
    return {name: prover.prove(library.get(name)) for name in NAMES}


def test_the_family_is_complete():
    expected = [library.get(n).expected for n in NAMES]
    assert len(NAMES) >= 10 and expected.count("refuted") >= 4
    assert all(library.get(n).description for n in NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_model_meets_expected_verdict(results, name):
    theorem, result = library.get(name), results[name]
    assert result.verdict == theorem.expected, result.reason
    if theorem.expected == "proved":
        assert all(o.verdict == "proved" for o in result.obligations)
        assert result.refutation is None


def _exact(text: str) -> Fraction:
    """A value as the trace prints it: `0.345761 (= p/q)` or `0.00188`."""
    m = re.search(r"\(= (-?\d+/\d+)\)", text)
    return Fraction(m.group(1)) if m else Fraction(text)


@pytest.mark.parametrize("name", [n for n in NAMES if library.get(n).expected == "refuted"])
def test_refuted_runs_violate_the_guarantee_when_checked_here(results, name):
    ref = results[name].refutation
    assert ref is not None and ref.trace and ref.check == "exact rationals"
    state = {k: _exact(v) for k, v in ref.initial.items()}
    for step in ref.trace:
        state.update({k: _exact(v) for k, v in step.state.items()})
    assert evaluate(library.get(name).guarantee, state) is False


def test_euler_counterexample_is_the_crossing_recomputed_by_hand(results):
    """The paper's step with the model's upper-bound ln and exp, in plain Fractions: from
    3.3 mm at 0.355 m/s under 5 N the third period ends past the wall, as the trace says."""
    d0, k, h = rcm.D0, rcm.K_BAR, rcm.H
    gap, w, F = Fraction(33, 10000), Fraction(71, 200), Fraction(5)
    gaps = []
    while gap > 0 and len(gaps) < 10:
        y = gap * (2 * d0 - gap) / d0**2
        lam = (1 - y * y) / (2 * y) if gap < d0 else Fraction(0)
        f = 2 * k * lam * (d0 - gap) / (d0**2 * y) if gap < d0 else Fraction(0)
        dmp = 10 + Fraction(25) / (1 + 22 * w) + Fraction(60, 100) * f * f
        gap, w = gap - h * w, w + h * (F - f - dmp * w)
        gaps.append(gap)
    assert len(gaps) == 3 and gaps[0] > 0 and gaps[1] > 0 and gaps[2] < Fraction(-1, 2000)
    ref = results["rcm.axial_euler_4ms"].refutation
    last_gap = [s.state["gap"] for s in ref.trace if "gap" in s.state and s.what.startswith("gap :=")]
    assert [_exact(g) for g in last_gap] == gaps


@pytest.mark.parametrize("factor", [Fraction(9, 10), Fraction(1, 2), Fraction(0)])
def test_the_guard_with_a_smaller_margin_is_not_proved(prover, factor):
    mutant = rcm._axial_guard(f"rcm.guard_margin_x{factor.numerator}_{factor.denominator}", rcm.mrg * factor,
                              "refuted", "mutant")
    result = prover.prove(mutant)
    assert result.verdict == "refuted", result.reason


def test_the_guard_is_proved_with_its_step_always_runnable(results):
    result = results["rcm.axial_guard"]
    assert result.verdict == "proved"
    assert result.nonblocking_verdict == "proved" and result.witness_replayed
