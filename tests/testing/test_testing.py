"""certiloop.testing.assert_proved / assert_refuted on small models, including an unknown one."""

import pytest

from certiloop.models import Reals, Theorem, assign, loop, seq
from certiloop.models.library import textbook
from certiloop.testing import Counterexample, assert_proved, assert_refuted

x, y = Reals("x y")


def unknown_model() -> Theorem:
    """True (x stays 0 + 1 + 1 ...), but `y := y` forgets y = 1, so the guarantee is not an
    inductive invariant, and no run violates it: the prover can only say unknown."""
    return Theorem(name="t.unknown", assumptions=(x == 0) & (y == 1),
                   program=loop(seq(assign(x, x + y), assign(y, y))), guarantee=x >= 0, unroll=1)


def test_assert_proved_passes_on_a_safe_model_and_returns_the_result():
    result = assert_proved(textbook.cart_forward)  # a function returning a theorem is fine too
    assert result.verdict == "proved" and result.model == "textbook.cart_forward"


def test_assert_proved_fails_on_an_unsafe_model_and_shows_the_counterexample():
    with pytest.raises(AssertionError) as info:
        assert_proved(textbook.cart_may_brake())
    message = str(info.value)
    assert message.startswith("textbook.cart_may_brake is refuted, not proved")
    assert "not proved:\n    o3 drive loop step / ODE dI 1 / derivative condition: refuted" in message
    assert "obligation counterexample (exact rationals)" in message
    assert "counterexample run (checked with exact rationals):\n    start: " in message
    assert "violated: y >= y0 is false at the end" in message
    assert "independent checks: replayed in the interpreter" in message


def test_assert_refuted_returns_the_confirmed_run():
    cex = assert_refuted(textbook.cart_may_brake)
    assert isinstance(cex, Counterexample)
    assert cex.evidence.confirmed
    assert set(cex.initial) >= {"y", "y0", "w"} and cex.values["y"] >= cex.values["y0"]  # the assumption
    assert cex.violated == "y >= y0 is false at the end"
    assert any("ODE" in s.what for s in cex.steps)
    assert str(cex).startswith("textbook.cart_may_brake:\ncounterexample run")
    assert "&lt;" not in cex._repr_html_() and "violated: y &gt;= y0" in cex._repr_html_()


def test_assert_refuted_fails_on_a_proved_model():
    with pytest.raises(AssertionError, match=r"^textbook.cart_forward is proved, not refuted: every"):
        assert_refuted(textbook.cart_forward)


def test_unknown_fails_both_assertions_with_the_reason():
    for check, wanted in ((assert_proved, "proved"), (assert_refuted, "refuted")):
        with pytest.raises(AssertionError) as info:
            check(unknown_model())
        message = str(info.value)
        assert message.startswith(f"t.unknown is unknown, not {wanted}: ")
        assert "unknown never passes" in message
        assert "loop step / invariant preserved: refuted" in message  # the obligation that failed
        assert "no violating run with at most 1 loop iterations" in message


def test_falsify_option_runs_the_falsifier_too():
    cex = assert_refuted(textbook.water_tank_late_check, falsify=200)
    assert cex.falsification is not None and cex.falsification.found
    assert assert_proved(textbook.cart_forward, falsify=50).verdict == "proved"


def test_falsify_option_catches_a_vacuous_proof():
    nothing = Theorem(name="t.vacuous", assumptions=(x > 0) & (x < 0), program=assign(x, x - 1),
                      guarantee=x >= 0)
    assert_proved(nothing)  # every state meeting the assumptions (none) is safe
    with pytest.raises(AssertionError, match=r"^t.vacuous is proved, but the falsifier could not start"):
        assert_proved(nothing, falsify=20)


def test_falsify_option_reports_a_run_the_prover_missed(monkeypatch):
    """A proof the falsifier contradicts (here a prover forced to say proved) fails, with the
    falsifier's run."""
    import certiloop.testing.assertions as assertions
    from certiloop.proofs.engine import TheoremResult

    monkeypatch.setattr(assertions, "prove", lambda theorem, **_: TheoremResult(
        theorem.name, "proved", theorem.expected, 0.0, []))
    with pytest.raises(AssertionError) as info:
        assert_proved(textbook.cart_may_brake, falsify=200)
    message = str(info.value)
    assert message.startswith("textbook.cart_may_brake is proved, yet the falsifier found a violating run")
    assert "counterexample after" in message and "violated after control step" in message


def test_budget_options_reach_the_prover():
    # one z3 resource unit cannot prove anything: a tiny rlimit turns proved into unknown
    with pytest.raises(AssertionError, match="is unknown, not proved"):
        assert_proved(textbook.cart_forward, rlimit=1)


def test_a_non_theorem_is_a_type_error():
    with pytest.raises(TypeError, match="expected a Theorem"):
        assert_proved(lambda: 42)
