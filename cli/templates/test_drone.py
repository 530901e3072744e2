"""The drone's claims as ordinary pytest tests (`python -m pytest -q`)."""

from fractions import Fraction

from drone_models import altitude_limiter, no_reaction_time

from certiloop.testing import assert_proved, assert_refuted


def test_the_limiter_keeps_the_drone_below_the_ceiling():
    assert_proved(altitude_limiter)


def test_forgetting_the_control_period_overshoots():
    run = assert_refuted(no_reaction_time)
    end = run.steps[-1].state  # the run's last state, exact: it is above the ceiling
    assert Fraction(str(end["h"])) > Fraction(str(end["H"]))
