"""abs, min and max in an ODE's right-hand side (models/kyx/lifting.py, `signed`): |a| is g*a
for a sign g chosen before the flow, the domain keeps g*a > 0, and the side condition asks the
domain to keep a != 0.

Every verdict has an independent witness: scipy integrates the ORIGINAL flow, with numpy's
abs/min/max, never the signed one certiloop reasons about, or a closed form checks it by hand.
The two mutants named at their tests (no side condition; no pin in the domain) were run and
each made its test fail."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from certiloop.falsify.search import Options, falsify
from certiloop.models.kyx import KyxError, read_entries
from certiloop.models.lang.programs import ODE, Choice
from certiloop.proofs.engine import Prover


def entry(problem: str, variables: str = "Real x, v, t;"):
    (e,) = read_entries(f'ArchiveEntry "e" ProgramVariables {variables} End. Problem {problem} End. End.')
    if e.error:
        raise KyxError(e.error)
    return e.theorem


def prove(problem: str):
    with Prover(jobs=1) as p:
        return p.prove(entry(problem))


def search(problem: str, examples: int = 300):
    return falsify(entry(problem), Options(max_examples=examples, seed=0, database=None))


def original(rhs, start, until):
    """The original flow's solution at `until` (scipy, numpy's abs/min/max)."""
    sol = solve_ivp(lambda _t, y: [rhs(y[0])], (0.0, until), [start], rtol=1e-10, atol=1e-12,
                    dense_output=True)
    assert sol.success
    return sol


def test_the_sign_is_chosen_before_the_flow_and_pinned_in_its_domain():
    theorem = entry("x = 1 -> [{x' = -abs(x) & x > 0}] x <= 1")
    choose, flow = theorem.program.parts[-2:]
    assert isinstance(choose, Choice) and len(choose.alternatives) == 2 and isinstance(flow, ODE)
    assert "sign*x>0" in str(flow.domain).replace(" ", "")
    (what, condition), = theorem.defined_if
    assert "keeps one sign" in what and "x != 0" in str(condition)


@pytest.mark.parametrize("claim, rhs, start, holds", [
    # x = e^-t stays in (0, 1]
    ("x = 1 -> [{x' = -abs(x) & x > 0}] x <= 1", lambda x: -abs(x), 1.0, lambda x: x <= 1 + 1e-9),
    # x' = |x| from -1: x = -e^-t rises towards 0 and stays below it
    ("x = -1 -> [{x' = abs(x) & x < 0}] x >= -1", lambda x: abs(x), -1.0, lambda x: x >= -1 - 1e-9),
    # v > 3 keeps 2 - v below -1, so max(-1, 2 - v) = -1: v falls
    ("v = 4 -> [{v' = max(-1, 2 - v) & v > 3}] v <= 4", lambda v: max(-1.0, 2 - v), 4.0,
     lambda v: v <= 4 + 1e-9),
    # v < 1 keeps 2 - v above 1, so min(1, 2 - v) = 1: v rises from 0 at rate 1
    ("v = 0 -> [{v' = min(1, 2 - v) & v < 1}] v >= 0", lambda v: min(1.0, 2 - v), 0.0,
     lambda v: v >= -1e-9),
    # nested: x > 1 keeps |x| - 1 = x - 1 > 0; the outer side condition may use that the inner
    # sign is 1 or -1 (a red team found it unknown when the sign could be any real)
    ("x = 2 -> [{x' = -abs(abs(x) - 1) & x > 1}] x <= 2", lambda x: -abs(abs(x) - 1), 2.0,
     lambda x: x <= 2 + 1e-9),
    # min(v, v) is v: no sign, no side condition
    ("v = 0 -> [{v' = min(v, v) + 1}] v >= 0", lambda v: min(v, v) + 1, 0.0, lambda v: v >= -1e-9),
])
def test_claims_inside_one_case_are_proved_and_scipy_agrees(claim, rhs, start, holds):
    assert prove(claim).verdict == "proved"
    sol = original(rhs, start, 0.9)
    assert all(holds(x) for x in sol.y[0])


def test_a_constant_under_abs_needs_no_side_condition():
    theorem = entry("x = 0 -> [{x' = abs(v)}] x >= 0")
    assert not theorem.defined_if
    assert prove("x = 0 -> [{x' = abs(v)}] x >= 0").verdict == "proved"
    assert prove("x = 0 -> [{x' = -abs(v)}] x >= 0").verdict != "proved"  # false for v = 1


@pytest.mark.parametrize("claim, rhs, start, bound", [
    # x = e^t passes 2 at t = ln 2
    ("x = 1 -> [{x' = abs(x) & x > 0}] x <= 2", lambda x: abs(x), 1.0, lambda x: x > 2),
    # v < 1/2 keeps max(1, v) = 1: v = t passes 1/4
    ("v = 0 -> [{v' = max(1, v) & v < 1/2}] v <= 1/4", lambda v: max(1.0, v), 0.0, lambda v: v > 0.25),
    # x = 1 + e^t: the nested twin of the proved claim, growing
    ("x = 2 -> [{x' = abs(abs(x) - 1) & x > 1}] x <= 2", lambda x: abs(abs(x) - 1), 2.0, lambda x: x > 2),
])
def test_false_claims_get_a_validated_counterexample_that_scipy_repeats(claim, rhs, start, bound):
    assert prove(claim).verdict != "proved"
    found = search(claim)
    assert found.found and found.validated, found.check
    end = found.run.checkpoints[-1]
    sol = original(rhs, start, float(end.time))
    assert bound(sol.y[0][-1])


def test_a_flow_that_may_reach_the_switching_point_is_unknown_not_proved():
    # true (x = e^-t never reaches 0), but the domain does not keep x != 0: the side condition fails
    result = prove("x = 1 -> [{x' = -abs(x)}] x <= 1")
    assert result.verdict == "unknown"
    failed = [o for o in result.obligations if o.verdict != "proved"]
    assert failed and all("keeps one sign" in o.path for o in failed), [o.path for o in failed]


def test_a_false_claim_past_the_switching_point_is_not_proved():
    # FALSE: x' = |x| + 1 from -1 gives x = 1 - 2e^-t up to t = ln 2, where x = 0, then
    # x = e^(t - ln 2) - 1, which passes 0. The mutant without the side condition proves it
    # (the pin g*x > 0 keeps the signed runs below 0).
    claim = "x = -1 -> [{x' = abs(x) + 1}] x <= 0"
    assert prove(claim).verdict != "proved"
    sol = original(lambda x: abs(x) + 1, -1.0, 1.0)
    assert sol.y[0][-1] > 0


def test_a_true_claim_past_the_switching_point_is_not_refuted():
    # TRUE: on the run above x(2) = e^(2 - ln 2) - 1 = e^2/2 - 1 > 1, and x only grows. Without
    # the pin g*x > 0 the signed flow keeps g = -1 past x = 0 (x = 1 - 2e^-t < 1): the mutant
    # refutes it.
    claim = "x = -1 & t = 0 -> [{x' = abs(x) + 1, t' = 1}] (t >= 2 -> x >= 1)"
    assert math.exp(2) / 2 - 1 > 1
    sol = original(lambda x: abs(x) + 1, -1.0, 2.0)
    assert sol.y[0][-1] >= 1 and np.all(np.diff(sol.y[0]) > 0)
    assert prove(claim).verdict != "refuted"
    assert not search(claim).found


@pytest.mark.parametrize("problem, why", [
    ("x >= 0 -> [{x' = sqrt(abs(x))}] x >= 0", "holds abs/min/max"),
    ("x >= 0 -> [{x' = abs(x'), t' = 1}] x >= 0", "differential symbol"),
])
def test_what_is_refused(problem, why):
    with pytest.raises(KyxError, match=why):
        entry(problem)
