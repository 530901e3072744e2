"""`prove` reports a vacuous proof: unsatisfiable assumptions, or a first control step that no
run gets through. Each claim's status is argued by hand in its comment (the independent
witness), and the runs that exist are exhibited by evaluating the program's tests directly."""

from fractions import Fraction

import pytest

from certiloop.cli import main
from certiloop.models import Reals, Theorem, assign, loop, seq
from certiloop.models import test as guard

x, y = Reals("x y")

MODELS = '''
from certiloop.models import Reals, Theorem, assign, choice, loop, seq
from certiloop.models import test as guard
x, y = Reals("x y")
# x > 1 and x < 0 together: no real x meets both
unsat = Theorem(name="unsat", assumptions=(x > 1) & (x < 0), program=assign(x, x + 1), guarantee=x > 5)
# x*x < 0 has no real solution either (a nonlinear emptiness)
unsat_square = Theorem(name="unsat_square", assumptions=x * x < 0, program=assign(y, x), guarantee=y > 5)
# from x >= 0 the only branch needs x < 0: the loop never iterates
blocked = Theorem(name="blocked", assumptions=x >= 0,
                  program=loop(seq(guard(x < 0), assign(x, x + 1)), invariant=x >= 0), guarantee=x >= 0)
# both branches blocked: one needs x < 0, the other x > 10, while x is in [0, 10]
blocked_choice = Theorem(name="blocked_choice", assumptions=(x >= 0) & (x <= 10),
                         program=loop(choice(seq(guard(x < 0), assign(x, x + 1)),
                                             seq(guard(x > 10), assign(x, x - 1))),
                                      invariant=(x >= 0) & (x <= 10)), guarantee=x <= 10)
# one branch runs from x = 0 (x >= 0 holds there): not vacuous
fine = Theorem(name="fine", assumptions=x >= 0,
               program=loop(seq(guard(x >= 0), assign(x, x + 1)), invariant=x >= 0), guarantee=x >= 0)
# a single satisfying state, x = 1/3: narrow, but a state (not vacuous)
narrow = Theorem(name="narrow", assumptions=3 * x == 1, program=assign(y, x), guarantee=3 * y == 1)
# the branch x > 10 is blocked, but x < 5 runs from x = 0: not vacuous
one_branch = Theorem(name="one_branch", assumptions=(x >= 0) & (x <= 10),
                     program=loop(choice(seq(guard(x < 5), assign(x, x + 1)),
                                         seq(guard(x > 10), assign(x, x - 1))),
                                  invariant=(x >= 0) & (x <= 11)), guarantee=x <= 11)
'''


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    path = tmp_path_factory.mktemp("vacuous") / "models.py"
    path.write_text(MODELS)
    return path


@pytest.mark.parametrize("name", ["unsat", "unsat_square", "blocked", "blocked_choice"])
def test_a_vacuous_proof_fails_with_the_reason(models, name, capsys):
    assert main(["prove", f"{models}:{name}", "-q"]) == 1
    err = capsys.readouterr().err
    assert f"{name} is vacuous" in err and "--allow-vacuous" in err


@pytest.mark.parametrize("name", ["unsat", "blocked"])
def test_allow_vacuous_accepts_it_with_a_warning(models, name, capsys):
    assert main(["prove", f"{models}:{name}", "-q", "--allow-vacuous"]) == 0
    assert "warning" in capsys.readouterr().err


@pytest.mark.parametrize("name, start", [("fine", {"x": Fraction(0)}), ("narrow", {"x": Fraction(1, 3)}),
                                         ("one_branch", {"x": Fraction(0)})])
def test_a_model_with_a_run_is_not_vacuous(models, name, start, capsys):
    # the witness: a start state meeting the assumptions, checked in exact rationals here
    value = start["x"]
    assumptions = {"fine": value >= 0, "narrow": 3 * value == 1, "one_branch": 0 <= value <= 10}[name]
    first_test = {"fine": value >= 0, "narrow": True, "one_branch": value < 5}[name]
    assert assumptions and first_test
    assert main(["prove", f"{models}:{name}", "-q"]) == 0
    assert "vacuous" not in capsys.readouterr().err


def test_the_json_result_names_why(models, tmp_path):
    import json

    out = tmp_path / "r.json"
    main(["prove", f"{models}:blocked", "-q", "--json", str(out)])
    assert "first control step" in json.loads(out.read_text())["vacuous"]


def test_the_vacuity_check_is_built_of_the_programs_first_step():
    from certiloop.proofs.engine.vacuous import first_step

    body = seq(guard(x < 0), assign(x, x + 1))
    prefix = assign(y, 0)
    assert first_step(loop(body, invariant=x >= 0)).key == body.key
    assert first_step(seq(prefix, loop(body, invariant=x >= 0))).key == seq(prefix, body).key
    whole = seq(prefix, assign(x, 1))
    assert first_step(whole) is whole


def test_a_flow_counts_as_its_run_of_duration_0():
    from certiloop.models import ode
    from certiloop.proofs.engine.vacuous import zero_duration

    flow = ode({x: 1}, domain=x <= 5)
    assert zero_duration(seq(assign(y, 0), flow)).key == seq(assign(y, 0), guard(x <= 5)).key
    assert Theorem  # the DSL names used by MODELS exist


TIMED = '''
from certiloop.models import Reals, Theorem, And, assign, loop, ode, seq
from certiloop.models import test as guard
x, t, eps = Reals("x t eps")
# a flow, then a test its longer runs pass: from x = 0, following x' = 1 for 10 s gives x = 10
after_flow = Theorem(name="after_flow", assumptions=x == 0, program=seq(ode({x: 1}), guard(x >= 10)),
                     guarantee=x >= 10)
# time-triggered: each step lasts exactly eps (t = eps after the flow for eps > 0 seconds)
timed = Theorem(name="timed", assumptions=And(x == 0, eps > 0),
                program=loop(seq(assign(t, 0), ode({x: 1, t: 1}, t <= eps), guard(t == eps)),
                             invariant=x >= 0), guarantee=x >= 0)
# the test after the flow can never pass (x only grows from 0 and must be negative): vacuous
never = Theorem(name="never", assumptions=x == 0,
                program=loop(seq(ode({x: 1}), guard(x < 0)), invariant=x >= 0), guarantee=x >= 0)
'''


@pytest.mark.parametrize("name, duration, end_test", [
    ("after_flow", Fraction(10), lambda x, t: x >= 10),
    ("timed", Fraction(1), lambda x, t: t == 1)])  # eps = 1
def test_a_test_after_a_flow_is_passed_by_its_longer_runs(tmp_path, name, duration, end_test, capsys):
    """The vacuity check read every flow as its run of duration 0, so a test after it that only
    a longer run passes made `prove` call a model with runs vacuous (exit 1)."""
    path = tmp_path / "timed_models.py"
    path.write_text(TIMED)
    # the witness by hand: x' = 1 (and t' = 1) from x = t = 0 for `duration` seconds passes the test
    assert end_test(Fraction(0) + duration, Fraction(0) + duration)
    assert main(["prove", f"{path}:{name}", "-q"]) == 0
    assert "vacuous" not in capsys.readouterr().err


def test_a_test_after_a_flow_that_no_run_passes_is_still_vacuous(tmp_path, capsys):
    path = tmp_path / "timed_models.py"
    path.write_text(TIMED)
    # x = s after s >= 0 seconds, never < 0: no run passes the test
    assert main(["prove", f"{path}:never", "-q"]) == 1
    assert "never is vacuous" in capsys.readouterr().err


def test_a_flow_with_a_test_after_it_stays_a_flow():
    from certiloop.models import ode
    from certiloop.proofs.engine.vacuous import zero_duration

    flow = ode({x: 1}, domain=x <= 5)
    step = seq(assign(y, 0), flow, guard(x >= 3))
    assert zero_duration(step).key == step.key
    body = seq(guard(y >= 0), flow)  # the next iteration's test follows the flow
    assert zero_duration(loop(body, invariant=x >= 0)).key == loop(body, invariant=x >= 0).key
