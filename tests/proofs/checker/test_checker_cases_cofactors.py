"""Two checker cases: a leaf decided case by case (the checker builds the cases from the leaf
itself, proofs/checker/cases.py) and a Darboux link with a rational cofactor (its premise
carries the cofactor's denominator nonzero). Truth by hand mathematics in each docstring."""

import json

from certiloop.api import prove
from certiloop.models.lang.programs import ode, skip
from certiloop.models.lang.terms import And, Or, Reals
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.checker import check
from certiloop.proofs.checker.certificate import CASES
from certiloop.proofs.core.odes import OdeStep
from certiloop.proofs.engine.certificate_writer import certificate

from .test_cases import lane_step

x, z = Reals("x z")


def _lane(bound_after=None) -> Theorem:
    hypotheses, goal = lane_step(bound_after)
    return Theorem("tiny.lane", hypotheses, skip(), goal)


def _certificate(theorem: Theorem) -> dict:
    result = prove(theorem)
    assert result.verdict == "proved", result
    return json.loads(json.dumps(certificate(*result.proof, result.obligations)))


def test_the_prover_records_a_leaf_it_split_and_the_checker_splits_it_alike():
    """The lane step is valid; the prover closes it by four cases. The checker reads the leaf
    as printed, without the prover's constant folding, and needs more z3 units for it."""
    doc = _certificate(_lane())
    split = [leaf for leaf in doc["leaves"] if leaf["decided"] == CASES]
    assert len(split) == 1 and split[0]["weakening"] is None
    outcome = check(doc, rlimit=100_000_000)
    assert outcome.status == "accepted", outcome.message
    assert [i for i, _ in outcome.leaves if i.startswith(split[0]["id"])] == [f"{split[0]['id']}.{k}"
                                                                             for k in range(1, 5)]


def _absolute(t, bound):
    """|t| < bound as the .kyx reader writes it."""
    return Or(And(t >= 0, t < bound), And(t < 0, -t < bound))


def _claimed_by_cases(hypothesis, goal) -> dict:
    doc = json.loads(json.dumps(certificate(Theorem("tiny.split", hypothesis, skip(), goal), {})))
    doc["format"] = "certiloop-certificate/2"
    doc["leaves"] = [dict(leaf, decided=CASES, weakening=None) for leaf in doc["leaves"]]
    return doc


def test_a_leaf_claimed_by_cases_is_decided_case_by_case():
    """|x| < 1 -> |x| < 2 splits on x >= 0 into two valid cases; |x| < 2 -> |x| < 1 is false
    at x = 3/2, which lies in the case x >= 0 (case 1); a leaf without such a disjunction has
    no guard, so it cannot claim cases."""
    outcome = check(_claimed_by_cases(_absolute(x, 1), _absolute(x, 2)))
    assert outcome.status == "accepted", outcome.message
    assert [i for i, _ in outcome.leaves] == ["o1.1", "o1.2"]
    outcome = check(_claimed_by_cases(_absolute(x, 2), _absolute(x, 1)))
    assert outcome.status == "rejected" and "(case 1 of 2): z3 says sat" in outcome.message
    outcome = check(_claimed_by_cases(x >= 0, x >= 0))
    assert outcome.status == "rejected" and "no guard to split on" in outcome.message
    as_stated = json.loads(json.dumps(certificate(Theorem("tiny.split", x >= 0, skip(), x >= 0), {})))
    assert as_stated["format"] == "certiloop-certificate/1"  # no split: the format stays v1


def _decay(cofactor):
    """x >= 0 & z > 0 -> [{x' = x/z, z' = 0 & z > 0}] x >= 0: x(t) = x e^(t/z) >= 0. The
    Darboux identity x' = (1/z) x holds; with 2/z, x' - (2/z) x = -x/z < 0 for x > 0."""
    plant = ode({x: x / z, z: 0}, z > 0)
    t = Theorem("tiny.rational", And(x >= 0, z > 0), plant, x >= 0)
    return json.loads(json.dumps(certificate(t, {plant.key: (OdeStep(x >= 0, "dbx", cofactor),)})))


def test_a_rational_darboux_cofactor_is_checked_with_its_denominator():
    doc = _decay(1 / z)
    assert check(doc).status == "accepted"
    premise = [leaf for leaf in doc["leaves"] if leaf["path"].endswith("derivative condition")]
    assert len(premise) == 1 and "(not (= |v:z@2| 0.0))" in premise[0]["smtlib"]  # z != 0 along the flow
    outcome = check(_decay(2 / z))
    assert outcome.status == "rejected" and "derivative condition" in outcome.message


def test_a_rational_cofactor_whose_denominator_can_vanish_is_rejected():
    """x' = x/(z - 1) with z' = 0 and the domain z > 0: z = 1 is allowed, where the cofactor
    1/(z - 1) has no value, so its premise (z - 1 != 0 inside the domain) fails."""
    plant = ode({x: x / (z - 1), z: 0}, z > 0)
    t = Theorem("tiny.pole", And(x >= 0, z > 0), plant, x >= 0)
    doc = json.loads(json.dumps(certificate(t, {plant.key: (OdeStep(x >= 0, "dbx", 1 / (z - 1)),)})))
    assert check(doc).status == "rejected"
