"""A loop inside a diamond, `<a*>P`, where the guarantee is positive (the core's `establish`).

It is proved by the runs with at most DIAMOND_ITERATIONS iterations of each loop: fewer runs,
so a proof proves the claim, and a failure is unknown (more iterations may reach P). Each
proof is witnessed independently (a run found by simple iteration, or integrated by scipy
with the durations it needs); false twins are shown false by hand and never proved, and a
false liveness claim is refuted by proving its negation, `[a*]!P`, at a state."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from certiloop.models.kyx import KyxError, read_entries
from certiloop.proofs.core.vcgen import DIAMOND_ITERATIONS
from certiloop.proofs.engine import Prover


def entry(problem: str, variables: str = "Real x, y, v, a, t;"):
    (e,) = read_entries(f'ArchiveEntry "e" ProgramVariables {variables} End. Problem {problem} End. End.')
    if e.error:
        raise KyxError(e.error)
    return e.theorem


def prove(problem: str):
    with Prover(jobs=1) as p:
        return p.prove(entry(problem))


def test_a_goal_a_few_iterations_away_is_proved():
    result = prove("x >= 0 & x <= 1 -> <{x := x + 1;}*> x >= 2")
    assert result.verdict == "proved", result.reason


@settings(max_examples=40, deadline=None)
@given(st.fractions(0, 1))
def test_the_proved_goal_is_reached_by_iterating(x0):
    x, steps = x0, 0
    while x < 2:
        x, steps = x + 1, steps + 1
    assert steps <= DIAMOND_ITERATIONS


FLOW = "<{a := 1; t := 0; {x' = v, v' = a, t' = 1 & t <= 1}}*> x >= p"


def test_a_flow_reaches_every_target_up_to_two_with_a_witnessed_run():
    result = prove(f"x = 0 & v = 0 -> \\forall p (p >= 0 & p <= 2 -> {FLOW})")
    assert result.verdict == "proved", result.reason
    # the witness: two rounds of one time unit each, integrated by scipy, end at x = 2
    state = np.array([0.0, 0.0])
    for _ in range(2):
        state = solve_ivp(lambda _t, s: [s[1], 1.0], (0.0, 1.0), state, rtol=1e-10, atol=1e-12).y[:, -1]
    assert state[0] >= 2 - 1e-9


def test_a_target_further_than_the_iterations_reach_is_unknown_not_false():
    result = prove(f"x = 0 & v = 0 -> \\forall p (p >= 0 & p <= 100 -> {FLOW})")
    assert result.verdict == "unknown"
    assert "at most 3 iterations" in result.obligations[0].path


@settings(max_examples=30, deadline=None)
@given(st.integers(-3, 3), st.integers(-4, 8))
@example(2, 8).via("four iterations: one past the bound")
@example(3, 9).via("three iterations")
@example(0, 1).via("never")
@example(-1, 2).via("never")
def test_proved_only_when_some_run_reaches_the_target(step, target):
    result = prove(f"x = 0 -> <{{x := x + {step};}}*> x >= {target}")
    reachable_within = any(k * step >= target for k in range(DIAMOND_ITERATIONS + 1))
    reachable_ever = target <= 0 or step > 0
    if result.verdict == "proved":
        assert reachable_within
    if not reachable_ever:  # the twin that is false: x never reaches the target
        assert result.verdict != "proved"


@pytest.mark.parametrize("problem", [
    "x >= 0 -> <{x := x + 1;}*> x < 0",  # counting up never goes negative
    "x = 0 -> <{{x' = 1 & x <= 1}}*> x >= 2",  # the domain stops every flow at 1
])
def test_a_false_liveness_claim_is_refuted_by_a_proof_of_its_negation(problem):
    result = prove(problem)
    assert result.verdict == "refuted"
    assert result.run is not None and result.run.negation_proved


def test_a_flow_without_a_polynomial_solution_keeps_only_its_run_of_duration_zero():
    assert prove("x = 1 -> <{{x' = x}}*> x >= 1").verdict == "proved"  # no time needed
    # true (e^t reaches 2), but only runs that take time show it: unknown, never refuted
    assert prove("x = 1 -> <{{x' = x}}*> x >= 2").verdict == "unknown"
    # false: x decays from 1 and never exceeds it
    assert prove("x = 1 -> <{{x' = -x & x >= 1/2}}*> x > 1").verdict != "proved"


@pytest.mark.parametrize("problem", [  # a red team's finds: each was proved
    "x = 0 & y = 0 -> <{{x' = y*(1/y)}}*> x >= 1",  # 0*(1/0): x stays 0
    "x = -1 -> <{{x' = 1 & x*(1/x) >= 1}}*> x >= 1",  # the flow passes x = 0 in its domain
    "x = 0 & y = 0 -> <{x' = y/y}> x >= 1",  # without a loop too
    "x = 0 & y = 0 -> <{x := x + 1;}*>[{x' = y/y}] x >= 1",  # in the postcondition
    "y = 0 -> <x := 1/y;> true",  # an assignment the rest never reads
])
def test_a_division_the_expansion_cancels_is_still_checked(problem):
    """sympy solves `x' = y/y` as x + s: the expanded diamond divides by nothing. The
    program's statements are checked defined along its runs (wdmodal.py)."""
    result = prove(problem)
    assert result.verdict != "proved"
    assert any("well-defined" in o.path and o.verdict != "proved" for o in result.obligations)
    assert prove("x = 0 & y = 1 -> <{{x' = y/y}}*> x >= 1").verdict == "proved"  # y = 1: defined


@pytest.mark.parametrize("problem", [  # a second red team's finds: each was proved
    "z = 0 & x = 1 -> \\exists x (x = 0 & <{z' = x/x}> z >= 1) | false",  # the bound x, not the free one
    "x = 1 & z = 0 -> <x := x - 1;> <{z' = x/x}> z >= 1",  # after the first program's write
    "x = 1 & z = 0 -> <{x := x - 1;}*> (x = 0 & <{z' = x/x}> z >= 1)",  # after the loop
    "x = 1 -> \\forall z [x := z;]<y := 1/x;>true",  # 1/0 at z = 0
    "x = 0 & z = 0 & <{z' = x/x}> z >= 1 -> z = 0",  # in an assumption
])
def test_a_division_inside_a_nested_program_is_checked_in_the_state_it_runs_in(problem):
    result = prove(problem.replace("z", "t"))
    assert result.verdict != "proved"


@pytest.mark.parametrize("problem, defined", [  # a third red team's class: each was proved
    ("y = 0 -> (y/y = 1 | true)", False),  # y/y is evaluated first
    ("x = 0 -> !(1/x > 0 & false)", False),
    ("x = 0 -> [t := 0;] ([y := 1/x;] true -> true)", False),
    ("y = 0 -> (true | y/y = 1)", True),  # never evaluated: the claim is fine
    ("y = 1 -> (y/y = 1 | true)", True),
])
def test_a_constant_that_decides_a_connective_keeps_the_divisions_read_before_it(problem, defined):
    """The formula constructors simplify `P | true` to true; the reader keeps the connective
    as written when that would drop a division, so it is still checked where evaluated."""
    result = prove(problem)
    assert (result.verdict == "proved") == defined
    if not defined:
        assert result.ill_defined


def test_a_test_that_blocks_every_iteration_is_not_skipped():
    # from x = 1 no iteration can run (?x > 5 fails), and x = 0 does not hold now: false
    result = prove("x = 1 -> <{?x > 5; x := 0;}*> x = 0")
    assert result.verdict != "proved"


@pytest.mark.parametrize("problem", ["!<{x := x + 1;}*> x < 0", "(<{x := x + 1;}*> x >= 2) -> x >= 1"])
def test_a_diamond_loop_in_a_negative_place_is_not_proved_when_false(problem):
    # both false at x = -1 (x < 0 now; x reaches 2 but is not >= 1): read since negative places
    # are supported (test_negative_loops.py), never proved
    assert prove(problem).verdict != "proved"


@pytest.mark.parametrize("problem, why", [
    ("x >= 0 -> <{x := x + 1;}*>[{x := x - 1;}*] x >= 0", "diamond's postcondition"),
    ("x >= 0 -> <{?<{x := x + 1;}*> x > 3; x := x + 1;}*> x >= 2", "formula of its program"),
])
def test_a_diamond_loop_where_fewer_runs_would_prove_too_much_is_refused(problem, why):
    with pytest.raises(KyxError, match="1:") as caught:
        entry(problem)
    assert why in str(caught.value)


def test_nested_box_loops_are_not_refuted_through_an_unrolled_diamond():
    """The negation `<a*>!P` of nested loops would be proved by unrollings that multiply (55 s
    on IJRR17's Theorem 9): left to the run search. A single loop's negation is tried."""
    from certiloop.models.lang.terms import ModelError
    from certiloop.proofs.refute.negation import negation_at

    nested = entry("x >= 0 -> [{{x := x - 1;}*}*] x >= 0")
    with pytest.raises(ModelError, match="left to the run search"):
        negation_at(nested, {"x": 0})
    assert prove("x >= 0 -> [{{x := x - 1;}*}*] x >= 0").verdict != "proved"
    single = entry("x >= 0 -> [{x := x - 1;}*] x >= 0")
    assert len(negation_at(single, {"x": 0})) == 2
