"""Square roots in an ODE's right-hand side (models/kyx/lifting.py): each becomes a variable
of the flow, with the side condition that the domain keeps its argument positive.

Every verdict has an independent witness: scipy integrates the ORIGINAL flow, with numpy's
square root, never the lifted one certiloop reasons about, or a closed-form solution checks
it by hand. Each false twin would be proved by the mutant of the rule it targets (named at
the test), which was run to make sure."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from certiloop.models.kyx import KyxError, read_entries
from certiloop.models.lang.programs import ODE, Havoc, Test
from certiloop.models.lang.terms import ModelError
from certiloop.proofs.engine import Prover


def entry(problem: str, variables: str = "Real x, y, v, w, t;", definitions: str = ""):
    text = (f'ArchiveEntry "e" {definitions} ProgramVariables {variables} End. '
            f'Problem {problem} End. End.')
    (e,) = read_entries(text)
    if e.error:
        raise KyxError(e.error)
    return e.theorem


def prove(problem: str, **kw):
    with Prover(jobs=1) as p:
        return p.prove(entry(problem, **kw))


KEPLER_FLOW = "{x'=v, v'=-x/(x^2+y^2)^(3/2), y'=w, w'=-y/(x^2+y^2)^(3/2) & x != 0 | y != 0}"
ENERGY = "(v^2+w^2)/2 - 1/(x^2+y^2)^(1/2)"


def kepler(x, y, v, w):
    r3 = (x * x + y * y) ** 1.5
    return [v, w, -x / r3, -y / r3]


def energy(x, y, v, w):
    return (v * v + w * w) / 2 - 1 / math.sqrt(x * x + y * y)


def test_keplers_energy_is_proved_and_scipy_sees_it_conserved():
    result = prove(f"x^2 + y^2 > 0 & {ENERGY} = E -> [{KEPLER_FLOW}] {ENERGY} = E",
                   definitions="Definitions Real E; End.")
    assert result.verdict == "proved"
    rng = np.random.default_rng(7)
    for _ in range(5):  # bound orbits from random starts: the energy stays put
        x0, y0 = rng.uniform(0.5, 2.0), rng.uniform(-1.0, 1.0)
        v0, w0 = rng.uniform(-0.3, 0.3), rng.uniform(0.3, 0.9)
        sol = solve_ivp(lambda _t, z: kepler(*z), (0, 5), [x0, y0, v0, w0], rtol=1e-10, atol=1e-12)
        e0 = energy(x0, y0, v0, w0)
        assert max(abs(energy(*z) - e0) for z in sol.y.T) < 1e-6


def test_the_wrong_energy_is_not_proved_and_scipy_shows_it_changes():
    wrong = "(v^2+w^2)/2 - 2/(x^2+y^2)^(1/2)"
    result = prove(f"x^2 + y^2 > 0 & {wrong} = E -> [{KEPLER_FLOW}] {wrong} = E",
                   definitions="Definitions Real E; End.")
    assert result.verdict != "proved"
    sol = solve_ivp(lambda _t, z: kepler(*z), (0, 1), [1.0, 0.0, 0.0, 1.2], rtol=1e-10)
    values = [(v * v + w * w) / 2 - 2 / math.hypot(x, y) for x, y, v, w in sol.y.T]
    assert max(values) - min(values) > 1e-2


def test_keplers_claim_as_keymaera_x_writes_it_divides_by_zero_in_its_assumption():
    # with no x^2 + y^2 > 0 first, the assumption's 1/sqrt(x^2+y^2) is evaluated at the origin
    result = prove(f"{ENERGY} = E -> [{KEPLER_FLOW}] {ENERGY} = E", definitions="Definitions Real E; End.")
    assert result.verdict != "proved" and result.ill_defined


def test_the_lifted_program_pins_the_root_and_adds_its_equation():
    theorem = entry("x >= 1 -> [{x' = x^(1/2) & x > 0}] x >= 1", variables="Real x;")
    havoc, pin, flow = theorem.program.parts
    assert isinstance(havoc, Havoc) and isinstance(pin, Test) and isinstance(flow, ODE)
    s = havoc.target.payload
    assert [str(v) for v, _ in flow.eqs] == ["x", s]
    assert s in str(flow.domain) and f"{s} > 0" in str(pin.cond)
    (what, condition), = theorem.defined_if  # the side condition: the domain keeps x > 0
    assert "`x` > 0" in what and condition.op == "implies" and str(condition.args[1]) == "x > 0"


def test_a_growing_root_flow_is_proved():
    # sqrt(x) = sqrt(x0) + t/2 grows: x stays >= 1
    assert prove("x >= 1 -> [{x' = x^(1/2) & x > 0}] x >= 1", variables="Real x;").verdict == "proved"


def test_a_shrinking_root_flow_is_refuted_with_the_closed_form_as_witness():
    # x' = -sqrt(x), x(0) = 1: x(t) = (1 - t/2)^2, so x(1) = 1/4 < 1/2 while x > 0 on [0, 1]
    result = prove("x = 1 -> [{x' = -(x^(1/2)) & x > 0}] x >= 1/2", variables="Real x;")
    assert result.verdict == "refuted"
    assert (1 - 1 / 2) ** 2 < 0.5


def test_a_flow_that_reaches_the_roots_zero_is_not_proved():
    # x(t) = (1 - t/2)^2 reaches 0 at t = 2 and may stay there: x > 0 is false. The lifted
    # flow keeps s > 0, so without the side condition `true -> x > 0` (mutant: dropped) it
    # would be proved
    sol = (1 - 2 / 2) ** 2
    assert sol == 0
    result = prove("x = 1 -> [{x' = -(x^(1/2))}] x > 0", variables="Real x;")
    assert result.verdict != "proved" and not result.ill_defined


def test_a_root_written_again_after_a_write_is_not_the_lifted_one():
    # after x := 0 the test reads sqrt(0^2 + 1) = 1 <= 1: it passes and `false` must hold, so
    # the claim is false. Read as the flow's lifted root (mutant: aliases inside a program),
    # the test would see sqrt(x^2 + 1) >= sqrt(2) at the flow's end and the claim be proved
    result = prove("x = 1 -> [{x'=(x^2+1)^(1/2)}][x := 0; ?(x^2+1)^(1/2) <= 1;] false", variables="Real x;")
    assert result.verdict != "proved"


def test_a_second_flow_lifts_its_own_root():
    # the second flow moves x, so its root is its own variable. Read as the first flow's
    # (a constant there; mutant: aliases inside a program), x would grow linearly and
    # x <= y + sqrt(y^2+1)*t be proved; scipy shows x = sinh(t) from 0 beats t
    claim = ("x = 0 & t = 0 -> [{x'=(x^2+1)^(1/2) & x <= 0}][y := x; t := 0;]"
             "[{x'=(x^2+1)^(1/2), t'=1}] x <= y + (y^2+1)^(1/2)*t")
    assert prove(claim).verdict != "proved"
    sol = solve_ivp(lambda _t, z: [math.sqrt(z[0] ** 2 + 1)], (0, 1), [0.0], rtol=1e-10)
    assert sol.y[0, -1] > 1.0 + 0.1 and abs(sol.y[0, -1] - math.sinh(1)) < 1e-6


def test_a_planned_invariant_that_divides_is_checked_defined_along_the_flow():
    # x' = -x^2 - 1 takes x from 1 through 0: 1/x > 0 is false (and undefined at 0). Its
    # dI premise holds wherever x != 0, so a plan that skipped the check would prove it
    result = prove("x = 1 -> [{x' = -x^2 - 1}] 1/x > 0", variables="Real x;")
    assert result.verdict != "proved"
    sol = solve_ivp(lambda _t, z: [-z[0] ** 2 - 1], (0, 1), [1.0], rtol=1e-10)
    assert sol.y[0, -1] < 0


def test_a_constant_root_in_a_flow_is_a_constant():
    # sqrt(2) is no number certiloop writes: x grows at rate sqrt(2) > 1.4
    result = prove("x = 0 & t = 0 -> [{x' = 2^(1/2), t' = 1}] x >= 7/5*t", variables="Real x, t;")
    assert result.verdict == "proved"
    result = prove("x = 0 & t = 0 -> [{x' = 2^(1/2), t' = 1}] x >= 3/2*t", variables="Real x, t;")
    assert result.verdict == "refuted"
    assert 1.4 < math.sqrt(2) < 1.5


def test_a_constant_expression_under_a_root_is_folded():
    # 3*10^2/(2*10^1)^2 is 3/4: a constant of the flow pinned by s^2 = 3/4 (no side condition)
    claim = "x = 0 -> [{x' = (3*10^2/(2*10^1)^2)^(1/2)}] x >= 0"
    theorem = entry(claim, variables="Real x;")
    havoc, pin, flow = theorem.program.parts
    assert "3/4" in str(pin.cond) and len(flow.eqs) == 1 and not theorem.defined_if
    assert prove(claim, variables="Real x;").verdict == "proved"


@pytest.mark.parametrize("problem, why", [
    ("x >= 0 -> [{x' = (abs(x))^(1/2)}] x >= 0", "holds abs/min/max"),
    # a red team's findings: the outer root's rate needs the inner one's (x = (1 + t/2)^2 from
    # x = 1 under x' = sqrt(sqrt(x)^2), so x(2) = 4 > 3, and this was proved); a differential
    # symbol hidden under a root was pinned to its value before the flow; a negative power of
    # a number that folds to 0 crashed the ODE solver
    ("x = 1 & t = 0 -> [{x' = sqrt(sqrt(x)^2), t' = 1 & x > 0}] x <= 1 + t", "holds another root"),
    ("x = 1 & t = 0 -> [{x' = sqrt(x + 1 + sqrt(t)^2), t' = 1 & x > 0}] x >= 1", "holds another root"),
    ("x = 0 & t = 0 -> [{x' = sqrt(y'^2 + 3), y' = 1, t' = 1}] x = 2*t", "differential symbol"),
    ("x = 0 -> [{x' = (1-1)^(-3/2)}] x >= 0", "division by the constant 0"),
    ("x = 0 -> [{x' = 1/(1-1)}] x >= 0", "division by the constant 0"),
    # x' in the domain reads sqrt(-1) at x = -1 before `x > 0` is read: ill-defined, was proved
    ("x = -1 -> [{x' = sqrt(x) & x' > 0 & x > 0}] false", "differential symbol in the domain"),
])
def test_what_is_still_refused_in_a_right_hand_side(problem, why):
    with pytest.raises(KyxError, match=why):
        entry(problem, variables="Real x, y, t;")


@pytest.mark.parametrize("claim", [
    # a second red team: each is TRUE (x' = |x| + 1 from 0 gives x = e^t - 1, which reaches 1 at
    # t = ln 2) and was refuted: the refutation proved the negation on the lifted flow without
    # the side condition, and at x = 0 the test ?(s > 0 & s^2 = x^2) blocks every lifted run
    "x = 0 -> <{x' = sqrt(x^2) + 1}> x >= 1",
    "x = 0 -> (x >= 5 | <{x' = sqrt(x^2) + 1}> x >= 1)",
    "x = 0 & [{x' = sqrt(x^2) + 1}] x <= 0 -> false",
])
def test_a_true_claim_through_a_lifted_flow_is_not_refuted(claim):
    try:
        assert prove(claim, variables="Real x;").verdict != "refuted"
    except ModelError as exc:  # not supported (the flow sits in a formula): fine, not refuted
        assert "no polynomial solution" in str(exc)
    sol = solve_ivp(lambda _t, z: [abs(z[0]) + 1], (0, 1), [0.0], rtol=1e-10, dense_output=True)
    assert sol.sol(math.log(2))[0] == pytest.approx(1.0, abs=1e-6)


def test_old_of_a_lifted_root_is_its_value_before_the_flow():
    theorem = entry("x = 4 -> [{x' = x^(1/2) & x > 0}@invariant(x^(1/2) >= old(x^(1/2)))] x >= 4",
                    variables="Real x;")
    havoc, pin, remember, flow = theorem.program.parts
    assert isinstance(havoc, Havoc) and isinstance(pin, Test) and str(remember.value) == str(havoc.target)


def test_a_flow_dividing_by_a_zero_term_is_ill_defined_not_a_crash():
    # 1/(0*x): sympy's solution is complex infinity, which used to fail an internal check
    result = prove("x = 0 -> [{x' = 1/(0*x)}] x >= 0", variables="Real x;")
    assert result.ill_defined or result.verdict == "unknown"


def test_a_float_only_run_does_not_fail_the_gate_of_a_proved_model():
    # a third red team: `1e12*(sqrt(1-x^2)*sqrt(1-x^2) + x^2 - 1) <= 0` is proved (it is 0), but
    # the falsifier's float run takes the lifted root s with s*s = 1 - x^2 only within rounding
    # and reports it violated "in floating point only (not validated)": no evidence against an
    # exact proof. A validated run still fails the gate
    from certiloop.api.gate_run import GateEntry
    from certiloop.falsify.depth import FLOAT_ONLY

    def entry_with(check):
        return GateEntry("m", "proved", "proved", 0.1, [], checked="accepted: m",
                         falsify={"verdict": "refuted", "check": check, "violated": "p <= 0"})
    assert not entry_with(f"{FLOAT_ONLY}: violated by 0.0142 (not validated)").problems
    assert entry_with("replayed in exact rational arithmetic").problems


def test_a_definition_wrapping_the_root_is_read_after_the_flow():
    # r(x, y) after the flow is the lifted root: its own variable, not a substitution clash
    definitions = "Definitions Real r(Real a, Real b) = (a^2 + b^2)^(1/2); End."
    flow = "{x' = v, y' = w, v' = -x/r(x,y)^3, w' = -y/r(x,y)^3 & x^2 + y^2 > 0}"
    assert prove(f"x = 1 & y = 0 -> [{flow}] r(x,y) > 0", definitions=definitions).verdict == "proved"
    # false: the circular orbit from (1, 0) at speed 1 keeps r = 1 (v = 0, w = 1 gives it)
    sol = solve_ivp(lambda _t, z: kepler(*z), (0, 3), [1, 0, 0, 1], rtol=1e-10, atol=1e-12)
    assert all(abs(math.hypot(z[0], z[1]) - 1) < 1e-6 for z in sol.y.T)
    assert prove(f"x = 1 & y = 0 & v = 0 & w = 1 -> [{flow}] r(x,y) > 1",
                 definitions=definitions).verdict != "proved"
