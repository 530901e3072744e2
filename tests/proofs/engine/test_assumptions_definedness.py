"""Assumptions written as the literature writes them: the stopping-distance invariant before
`B > 0`. By hand: where B <= 0 the assumptions `x + v^2/(2*B) <= m & v >= 0 & B > 0` are false
whatever the division reads (their conjunct B > 0 is), so the claim holds there; where B > 0
the division is defined. With `B >= 0` instead, B = 0 satisfies every conjunct that can be
evaluated and x/(2*0) cannot: the claim is ill-defined."""

from fractions import Fraction

import pytest

from certiloop.models.lang.programs import assign, choice, loop, ode, seq, test
from certiloop.models.lang.terms import And, Or, Reals
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.checker import check
from certiloop.proofs.core.exact import Undecided, evaluate
from certiloop.proofs.engine.checked import check_proof
from certiloop.proofs.engine.prover import Prover

x, v, a, t, m, big_a, big_b, ep = Reals("x v a t m A B ep")


def _stopping(*assumptions) -> Theorem:
    """Brake (a = -B) or accelerate (a = A) when the stopping point stays before m after one
    period; invariant v >= 0 & x + v^2/(2B) <= m (KeYmaera X's STTT tutorial, divided)."""
    safe = x + v * v / (2 * big_b) + (big_a / big_b + 1) * (big_a / 2 * ep * ep + ep * v) <= m
    ctrl = choice(seq(test(safe), assign(a, big_a)), assign(a, -big_b))
    plant = ode({x: v, v: a, t: 1}, And(v >= 0, t <= ep))
    inv = And(v >= 0, x + v * v / (2 * big_b) <= m)
    return Theorem("user.stopping", And(*assumptions), loop(seq(ctrl, assign(t, 0), plant), inv), x <= m,
                   constants=(m, big_a, big_b, ep))


def _prove(theorem):
    with Prover(jobs=1) as prover:
        return prover.prove(theorem)


STOPPING = x + v * v / (2 * big_b) <= m


@pytest.mark.parametrize("order", ["invariant first", "B > 0 first"])
def test_the_stopping_distance_before_b_positive_proves_and_is_checked(order):
    parts = [STOPPING, v >= 0, big_a > 0, big_b > 0, ep > 0]
    theorem = _stopping(*(parts if order == "invariant first" else parts[::-1]))
    result = _prove(theorem)
    assert result.verdict == "proved", result.reason
    checked = check_proof(result.proof, result.obligations)
    assert checked.accepted, checked.message


def test_a_division_the_other_conjuncts_do_not_guard_is_still_ill_defined():
    result = _prove(_stopping(STOPPING, v >= 0, big_a > 0, big_b >= 0, ep > 0))
    assert result.ill_defined and result.reason.startswith("ill-defined: well-defined: the assumptions")


def test_the_checker_derives_the_same_definedness_leaf():
    """The leaf is `v >= 0 & A > 0 & B > 0 & ep > 0 -> 2*B != 0` (the settled conjuncts, then
    the division's denominator), in the prover's certificate and the checker's derivation."""
    from certiloop.proofs.engine.certificate_writer import certificate

    doc = certificate(_stopping(STOPPING, v >= 0, big_a > 0, big_b > 0, ep > 0), {})
    first = doc["leaves"][0]
    assert first["path"] == "well-defined: the assumptions (no division by 0)"
    assert "(>= |v:v| 0.0) (> |v:A| 0.0) (> |v:B| 0.0) (> |v:ep| 0.0)" in first["smtlib"]
    assert check(doc).status == "accepted"


def test_the_exact_evaluator_reads_a_conjunction_as_the_proof_does():
    """At B = 0: `x/B > 0 & B > 0` is false (B > 0 is), `x/B > 0 | B >= 0` true (B >= 0 is);
    `x/B > 0 & B >= 0` has no value (x/0)."""
    zero = {"x": Fraction(1), "B": Fraction(0)}
    assert evaluate(And(x / big_b > 0, big_b > 0), zero) is False
    assert evaluate(Or(x / big_b > 0, big_b >= 0), zero) is True
    with pytest.raises(Undecided):
        evaluate(And(x / big_b > 0, big_b >= 0), zero)
