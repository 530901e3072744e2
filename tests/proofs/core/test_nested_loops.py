"""Loops inside the guarantee's formulas (models/lang/nesting.py; the core's `establish`).

Stability claims `\\forall eps \\exists del ... [sys*] ...` are proved with a witness for del,
and each proof is witnessed independently: scipy integrates the switched system along random
switching sequences from random starts inside the ball and the run stays inside the eps
ball. Each false twin (an unstable mode, a false conjunct, the wrong disjunct assumed, a
quantifier that must rebind a program variable) is shown false by hand or by scipy and is
never proved; each twin would be proved by the mutant of the rule it targets."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from certiloop.models.kyx import KyxError, read_entries
from certiloop.proofs.engine import Prover
from certiloop.proofs.engine.witnesses import witness_options


def entry(problem: str, variables: str = "Real x, t;"):
    (e,) = read_entries(f'ArchiveEntry "e" ProgramVariables {variables} End. Problem {problem} End. End.')
    if e.error:
        raise KyxError(e.error)
    return e.theorem


def prove(problem: str, variables: str = "Real x, t;"):
    with Prover(jobs=1) as p:
        return p.prove(entry(problem, variables))


def stability(modes: str, lyap: str = "x^2", variables: str = "\\forall x") -> str:
    return (f"\\forall eps (eps > 0 -> \\exists del (del > 0 & {variables} ({lyap} < del^2 -> "
            f"[{{{modes}}}*] {lyap} < eps^2)))")


ONE_D = "{x'=-x, t'=1} ++ {x'=-x^3, t'=1}"
FIELDS_1D = [lambda x: -x, lambda x: -x**3]


def switched_run(fields, start, switches, dwell):
    """Integrate the switched system along a switching sequence: the states visited."""
    state, visited = np.asarray(start, float), []
    for mode in switches:
        sol = solve_ivp(lambda _t, s, f=fields[mode]: f(*s) if len(s) > 1 else [f(*s)], (0.0, dwell),
                        state, rtol=1e-10, atol=1e-12, dense_output=True)
        path = sol.sol(np.linspace(0.0, dwell, 41))
        visited.append(path)
        state = path[:, -1]
    return np.concatenate(visited, axis=1)


def test_switched_stability_is_proved_with_the_witness_del_eps():
    result = prove(stability(ONE_D))
    assert result.verdict == "proved", result.reason
    assert "del := eps" in result.reason


@settings(max_examples=25, deadline=None)
@given(st.floats(0.1, 3.0), st.floats(-0.999, 0.999), st.lists(st.integers(0, 1), min_size=1, max_size=6),
       st.floats(0.05, 2.0))
def test_the_proved_stability_holds_along_simulated_switching(eps, fraction, switches, dwell):
    # the proof's witness: starts with |x| < del = eps stay in |x| < eps under any switching
    path = switched_run(FIELDS_1D, [fraction * eps], switches, dwell)
    assert (path[0] ** 2 < eps**2).all()


def test_an_unstable_mode_makes_stability_false_and_unproved():
    twin = prove(stability("{x'=-x, t'=1} ++ {x'=x, t'=1}"))
    assert twin.verdict != "proved"
    # for eps = 1 and any del, the start del/2 leaves the eps ball in mode 2
    for d in (1.0, 0.1, 1e-3):
        path = switched_run([lambda x: -x, lambda x: x], [d / 2], [1], 12.0)
        assert (path[0] ** 2 >= 1.0).any()


LYAP_2D = ("{x1'=-x1/8-x2, x2'=2*x1-x2/8, t'=1 & x1*x2 <= 0} ++ "
           "{x1'=-x1/8-2*x2, x2'=x1-x2/8, t'=1 & x1*x2 >= 0}")


def test_state_dependent_switching_with_a_common_lyapunov_function():
    result = prove(stability(LYAP_2D, "x1^2+x2^2", "\\forall x1 \\forall x2"), "Real x1, x2, t;")
    assert result.verdict == "proved", result.reason
    # witness: each mode on its own domain never increases x1^2 + x2^2
    rng = np.random.default_rng(7)
    for _ in range(40):
        x1, x2 = rng.uniform(-2, 2, 2)
        if x1 * x2 <= 0:
            assert 2 * x1 * (-x1 / 8 - x2) + 2 * x2 * (2 * x1 - x2 / 8) <= 1e-12
        if x1 * x2 >= 0:
            assert 2 * x1 * (-x1 / 8 - 2 * x2) + 2 * x2 * (x1 - x2 / 8) <= 1e-12


def test_a_false_conjunct_is_not_proved():
    good = "x = 0 -> [{x:=x+1;}*]x >= 0 & [{x:=x-1;}*]x <= 0"
    assert prove(good).verdict == "proved"
    bad = "x >= 0 -> [{x:=x+1;}*]x >= 0 & [{x:=x-1;}*]x <= 0"  # x = 1, no iteration: 1 <= 0 fails
    assert prove(bad).verdict != "proved"


def test_a_disjunction_assumes_the_other_parts_false():
    assert prove("x >= 0 -> x > 5 | [{x:=x+1;}*]x >= 0").verdict == "proved"
    # x = -1: not > 5, and the loop's zero iterations leave x = -1 < 0. Assuming x > 5 (the
    # disjunct itself, not its negation) would prove it
    assert prove("x >= -1 -> x > 5 | [{x:=x+1;}*]x >= 0").verdict != "proved"
    # the same inside a quantifier, where the core (not the reader) takes the disjunction apart
    assert prove("\\forall x (x >= 0 -> x > 5 | [{x:=x+1;}*]x >= 0)").verdict == "proved"
    assert prove("\\forall x (x >= -1 -> x > 5 | [{x:=x+1;}*]x >= 0)").verdict != "proved"


def test_forall_rebinds_a_program_variable():
    assert prove("x = -5 -> \\forall x (x >= 0 -> [{x:=x+1;}*]x >= 0)").verdict == "proved"
    # x = -10 fails at zero iterations; reading the bound x as the assumed 5 would prove it
    assert prove("x = 5 -> \\forall x (x >= -10 -> [{x:=x+1;}*]x >= 0)").verdict != "proved"


def test_nested_boxes_take_their_own_postcondition_as_invariant():
    assert prove("x >= 0 -> [{x:=x+1;}*][{x:=x+2;}*]x >= 0").verdict == "proved"
    assert prove("x >= 0 -> [{x:=x+1;}*](x >= 3 -> [{x:=x-1;}*]x >= 0)").verdict != "proved"


def test_an_exists_without_a_working_witness_is_not_proved():
    # d must exceed every value of x, which grows without bound: false for every d
    claim = "x = 0 -> \\exists d (d > 0 & [{x:=x+1;}*]x < d)"
    assert [str(dict(o[0])["d"]) for o in witness_options(entry(claim))] == ["1"]  # no \forall around it
    assert prove(claim).verdict != "proved"


def test_witness_options_start_with_the_enclosing_variable():
    options = witness_options(entry(stability(ONE_D)))
    assert [str(dict(o[0])["del"]) for o in options] == ["eps", "eps/2", "eps/10", "1"]
    assert len(options) <= 4


@pytest.mark.parametrize("problem, why", [
    ("x > 0 -> <{x:=x+1;}*>[{x:=x-1;}*]x > 5", "diamond's postcondition"),
    ("x > 0 -> [?[{x:=x+1;}*]x > 0;]x > 0", "formula of a program"),
])
def test_unsupported_shapes_are_refused_with_the_reason(problem, why):
    with pytest.raises(KyxError, match="1:") as caught:
        entry(problem)
    assert why in str(caught.value)


def test_a_division_inside_never_reports_ill_defined():
    # 1/x is evaluated only where x != 0 (the first disjunct false)
    result = prove("x >= 0 -> x = 0 | [{x:=x+1;}*]1/x > 0")
    assert not result.ill_defined
    assert result.verdict in ("proved", "unknown")


def test_the_gate_skips_a_stability_falsifier_and_fails_it_until_the_checker_covers_it(tmp_path, capsys):
    """prove proves the stability claim (with a witness for its ∃); the gate says proved only
    for a proof the proof checker accepted, and the checker does not cover witnesses yet: the
    gate fails it, with the checker's reason, and does not run the falsifier on a claim no run
    can refute."""
    from certiloop.cli import main

    archive = tmp_path / "stable.kyx"
    archive.write_text(f'ArchiveEntry "stable" ProgramVariables Real x, t; End. Problem {stability(ONE_D)} '
                       'End. End.\n')
    assert main(["prove", str(archive), "--jobs", "1"]) == 0
    report = tmp_path / "gate.json"
    assert main(["gate", str(archive), "--no-cache", "--jobs", "1", "--json", str(report)]) == 1
    (entry,) = json.loads(report.read_text())
    assert entry["verdict"] == "unknown" and not entry["passed"]
    assert "proof checker did not accept" in entry["reason"] and "not checkable yet" in entry["reason"]
    assert entry["falsify"]["verdict"] == "not run" and "modality" in entry["falsify"]["skipped"]
    assert main(["falsify", str(archive)]) == 0
    assert "not run" in capsys.readouterr().out


# a red team's findings (each was a wrong verdict or an unclear refusal)

def test_a_definition_argument_captured_by_its_body_is_refused():
    # pasted as is, stays(x) would read [{x'=x}*] x^2 <= x^2: proved, though x = 0.5 grows to
    # 0.5e at time 1. KeYmaera X calls this a substitution clash
    text = ('ArchiveEntry "c" Definitions Bool stays(Real v) <-> [{{x\' = x}}*] x^2 <= v^2; End. '
            'ProgramVariables Real x; End. Problem \\forall x (x^2 < 1 -> stays(x)) End. End.')
    (e,) = read_entries(text)
    assert e.theorem is None and "substitution clash" in e.error and "`x`" in e.error
    fine = text.replace("\\forall x (x^2 < 1 -> stays(x))", "x^2 < 1 -> stays(1)")
    (ok,) = read_entries(fine)
    assert ok.error is None


def test_a_disjunction_is_not_reordered_past_a_division():
    # read left to right, 1/x is evaluated only where the box is false, which it never is
    with pytest.raises(KyxError, match="division among them"):
        entry("x = 0 -> ([{x := x + 1;}*] x >= 0 | 1/x > 0)")
    # loop-free, the box stays in the guarantee and is read in order: proved
    assert prove("x = 0 -> ([x := x + 1;] x >= 1 | 1/x > 0)").verdict == "proved"


def test_a_root_taken_under_a_guard_is_not_reported_ill_defined():
    result = prove("\\forall x (a >= 0 -> [{x := x/2;}*] x^2 <= x^2 + sqrt(a))", "Real x, a;")
    assert result.verdict != "proved" and not result.ill_defined  # a = -1 fails the (stricter) condition
    assert "where the claim may not take it" in result.reason


def test_a_modality_inside_an_ode_domain_is_refused_with_the_position():
    with pytest.raises(KyxError, match=r"1:\d+: .*modality inside an ODE's domain"):
        entry("x = 0 -> \\forall y ([{{x' = 1 & [{y := y + 1;}*] y >= 0}}*] x >= 0)", "Real x, y;")


def test_a_clash_hidden_in_abs_or_a_root_or_in_the_body_itself_is_refused():
    # a second red team: abs(x) and sqrt(x^2+1) are markers whose x was captured unseen
    for arg in ("abs(x)", "max(x,0)", "sqrt(x^2+1)"):
        text = (f'ArchiveEntry "c" Definitions Bool p(Real v) <-> [x := 0;] v <= 1; End. '
                f'ProgramVariables Real x; End. Problem x = 3 -> p({arg}) End. End.')
        (e,) = read_entries(text)
        assert e.theorem is None and "substitution clash" in e.error, arg
    # a definition's own x under a binder of x around its use (h() would read 0 + 1, not 5 + 1)
    text = ('ArchiveEntry "c" Definitions Real h() = x + 1; End. ProgramVariables Real x; End. '
            'Problem x = 5 -> [x := 0;] h() = 1 End. End.')
    (e,) = read_entries(text)
    assert e.theorem is None and "bound where it is used" in e.error
    (ok,) = read_entries(text.replace("[x := 0;] h() = 1", "h() = 6"))
    assert ok.error is None


def test_a_root_before_its_guard_in_a_disjunction_is_not_proved():
    # read left to right the box takes sqrt(x) first: at x = -1 that is sqrt(-1)
    result = prove("[y := sqrt(x);] y >= 0 | x < 0", "Real x, y;")
    assert result.verdict != "proved" and not result.ill_defined
    with pytest.raises(KyxError, match="divides and is taken under a condition"):
        entry("[y := sqrt(1/x);] y >= 0 | x <= 0", "Real x, y;")


def test_a_flow_without_a_polynomial_solution_inside_a_formula_is_executed():
    # x(t) = x0 e^-t never grows: |x0| < eps stays below eps; under x' = x it leaves any ball
    claim = ("\\forall eps (eps > 0 -> \\exists del (del > 0 & \\forall x (x^2 < del^2 -> "
             "[{x'=-x}] x^2 < eps^2)))")
    assert prove(claim, "Real x;").verdict == "proved"
    assert all(abs(0.9 * np.exp(-t)) < 1.0 for t in np.linspace(0, 20, 201))
    assert prove(claim.replace("x'=-x", "x'=x"), "Real x;").verdict != "proved"
    assert abs(1e-3 * np.exp(8.0)) > 1.0  # from 0.001 the flow x' = x passes 1 by time 8
