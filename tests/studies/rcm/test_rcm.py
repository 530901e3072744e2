"""The RCM paper (RCM admittance): every rcm.* model meets its verdict; refuted runs violate their
guarantee when re-checked here; the proved guard does not survive a smaller margin."""

import re
from fractions import Fraction

import pytest

from certiloop.models import library
from certiloop.proofs.core.exact import evaluate
from certiloop.proofs.engine.prover import Prover
from certiloop.studies.rcm.models import constraint as rcm

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
    assert ref is not None and ref.check == "exact rationals"
    # (a lemma without steps, e.g. rcm.clearance_unbounded_energy, is refuted by its start)
    assert ref.trace or not library.get(name).program.symbols()
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


# --------------------------------------------------------------------------- energy: mutants never prove

from certiloop.models.lang.terms import Reals  # noqa: E402
from certiloop.studies.rcm.models import energy as rcm_energy  # noqa: E402
from certiloop.studies.rcm.models import lyapunov as rcm_lyapunov  # noqa: E402


@pytest.mark.parametrize("floor", [Fraction(-1, 100), Fraction(-1), Fraction(-100)])
def test_passivity_with_negative_damping_is_never_proved(prover, floor):
    mutant = rcm_energy._passivity("rcm.passivity_mut", floor, "refuted", "mutant")
    assert prover.prove(mutant).verdict != "proved"


@pytest.mark.parametrize("floor", [Fraction(-1, 1000), Fraction(-1), Fraction(-10)])
def test_midpoint_step_with_negative_damping_is_refuted(prover, floor):
    mutant = rcm_energy._midpoint("rcm.midpoint_mut", rcm_energy.da >= floor, True, "refuted", "mutant")
    assert prover.prove(mutant).verdict == "refuted"


@pytest.mark.parametrize("lever", ["0", "2*c2", "c1"])
def test_capsule_with_the_force_mapped_by_another_lever_is_never_proved(prover, lever):
    c1, c2 = Reals("c1 c2")
    mutant = rcm_energy._capsule("rcm.capsule_mut", True, "refuted", "mutant",
                                 lever2={"0": 0, "2*c2": 2 * c2, "c1": c1}[lever])
    assert prover.prove(mutant).verdict != "proved"


def test_capsule_without_the_energy_cap_is_never_proved(prover):
    mutant = rcm_energy._capsule("rcm.capsule_uncapped", False, "refuted", "mutant")
    assert prover.prove(mutant).verdict != "proved"


@pytest.mark.parametrize("entry,delta", [((0, 0), Fraction(-50)), ((0, 1), Fraction(5)),
                                         ((1, 1), Fraction(-1, 2))])
def test_a_perturbed_lyapunov_matrix_is_not_proved(prover, monkeypatch, entry, delta):
    P = [row[:] for row in rcm_lyapunov.EULER_P]
    i, j = entry
    P[i][j] += delta
    P[j][i] = P[i][j]
    monkeypatch.setattr(rcm_lyapunov, "EULER_P", P)
    mutant = rcm_lyapunov._lyapunov("rcm.lyap_mut", rcm.ALPHA, "refuted", "mutant")
    assert prover.prove(mutant).verdict != "proved"
