"""The raven.* theorems (the Raven-II paper): verdicts, counterexamples re-checked here, mutations."""

from fractions import Fraction

import pytest

from certiloop.models import library
from certiloop.proofs.engine.prover import Prover
from certiloop.studies.raven import models as raven

RAVEN = [n for n in library.names() if n.startswith("raven.")]

# plain-Python readings of each refuted model's guarantee, on exact values
VIOLATED = {
    "raven.deviation_small_margin": lambda s: s["dr"] < 0,
    "raven.deviation_haptic_only": lambda s: s["dr"] < 0,
    "raven.residual_drift": lambda s: s["dr"] < 0,
    "raven.jump_above_tol": lambda s: s["seen"] == 1 and s["stopped"] == 0,
}
# the flows of the 1-D models, integrated here: (dm', dr') as functions of the state
FLOWS = {
    "raven.deviation_small_margin": lambda s: (s["v"], s["v"] + s["u"]),
    "raven.deviation_haptic_only": lambda s: (s["v"], s["v"] + s["u"]),
    "raven.residual_drift": lambda s: (s["v"], s["v"] + s["u"] * (1 - s["stopped"])),
    "raven.jump_above_tol": lambda s: (s["v"], s["v"] + s["u"]),
}


@pytest.fixture(scope="module")
def prover():
    with Prover(jobs=2) as p:
        yield p


@pytest.fixture(scope="module")
def results(prover):
    return {name: prover.prove(library.get(name)) for name in RAVEN}


def test_the_family_is_registered():
    assert set(RAVEN) == {"raven.deviation_stop", "raven.deviation_small_margin", "raven.deviation_stop_3d",
                          "raven.deviation_haptic_only", "raven.residual_drift", "raven.jump_detected",
                          "raven.jump_above_tol", "raven.haptic_force"}
    assert set(VIOLATED) == {n for n in RAVEN if library.get(n).expected == "refuted"}
    for name in RAVEN:
        assert library.get(name).description


@pytest.mark.parametrize("name", RAVEN)
def test_verdict_is_the_expected_one(results, name):
    theorem, result = library.get(name), results[name]
    assert result.verdict == theorem.expected, result.reason
    if theorem.expected == "proved":
        assert all(o.verdict == "proved" for o in result.obligations)
        if theorem.check_nonblocking:
            assert result.nonblocking_verdict == "proved"
    else:
        assert result.run is not None and result.run.replayed and result.run.flows_confirmed, result.reason


def _exact(state: dict[str, str]) -> dict[str, Fraction]:
    return {k: Fraction(v) for k, v in state.items()}


@pytest.mark.parametrize("name", sorted(VIOLATED))
def test_counterexample_violates_the_guarantee_when_rechecked_here(results, name):
    """Independently of the engine: every flow of the run is re-integrated here in exact
    arithmetic from the state before it (the 1-D flows are linear in time), and the final
    state violates the guarantee read in plain Python."""
    ref = results[name].refutation
    assert ref is not None and ref.trace
    before = _exact(ref.initial)
    flows = 0
    for step in ref.trace:
        if step.kind == "choice":  # a choice records no state
            continue
        after = _exact(step.state)
        if step.kind == "ode":
            tau = Fraction(step.value)
            assert tau >= 0
            rate_m, rate_r = FLOWS[name](before)
            assert after["dm"] == before["dm"] + rate_m * tau, step.path
            assert after["dr"] == before["dr"] + rate_r * tau, step.path
            assert 0 <= after["t"] <= after["eps"]
            flows += 1
        before = after
    assert flows >= 1
    assert VIOLATED[name](before), (name, ref.trace[-1].state)


def test_residual_drift_run_never_alarms_and_needs_several_periods(results):
    ref = results["raven.residual_drift"].refutation
    assert ref.depth >= 3  # a margin of tol + U eps takes three periods of sub-tol drift
    assert all("stop" not in s.path for s in ref.trace)


def test_haptic_only_run_has_the_force_on_when_it_crosses(results):
    ref = results["raven.deviation_haptic_only"].refutation
    assert any("haptic force" in s.path for s in ref.trace)
    final = _exact(ref.trace[-1].state)
    assert final["F"] > 0 and final["dr"] < 0


@pytest.mark.parametrize("factor", [Fraction(1, 2), Fraction(9, 10), 0])
def test_stop_theorem_with_a_smaller_margin_is_not_proved(prover, factor):
    """Mutation: m >= tol + factor U eps with factor < 1 must not prove; the engine must
    find a confirmed crossing."""
    result = prover.prove(raven.deviation_stop(margin_factor=factor))
    assert result.verdict == "refuted", result.reason
    assert result.run is not None and result.run.replayed


def test_jump_threshold_below_two_tol_is_not_proved(prover):
    """Mutation of jump_detected: jumps only larger than tol + U eps are not always seen."""
    from certiloop.models.lang.programs import havoc, seq, test

    smaller = seq(havoc(raven.jmp), test(raven._beyond(raven.jmp, raven.tol + raven.U * raven.eps)))
    mutant = raven._jump("raven.jump_detected", smaller, raven._within(raven.dr - raven.dm, raven.tol),
                         "proved", "mutant")
    assert prover.prove(mutant).verdict == "refuted"
