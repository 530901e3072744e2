"""The SDP Lyapunov certificate of the paper's 4 ms Euler RCM dynamics: cvxpy proposes, the exact
check decides, wrong certificates are rejected, and the library theorem uses the checked matrix."""

import warnings
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models import library
from certiloop.proofs.arith.lyapunov import check_discrete_lyapunov, propose_discrete_lyapunov
from certiloop.studies.rcm.models import lyapunov as L


def _V(P, z):
    return sum(P[i][j] * z[i] * z[j] for i in range(2) for j in range(2))


def _apply(A, z):
    return [A[i][0] * z[0] + A[i][1] * z[1] for i in range(2)]


def test_the_stored_certificate_passes_the_exact_check():
    assert check_discrete_lyapunov(L.EULER_A, L.EULER_P, L.EULER_RATE) == []


def test_cvxpy_proposes_a_certificate_that_passes_the_exact_check():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        P = propose_discrete_lyapunov(L.EULER_A, L.EULER_RATE)
    assert P is not None and all(isinstance(x, Fraction) for row in P for x in row)
    assert check_discrete_lyapunov(L.EULER_A, P, L.EULER_RATE) == []


def test_an_infeasible_rate_is_rejected_even_when_the_solver_returns_a_matrix():
    # the Euler map's eigenvalue is 0.9 (a Jordan block): no V shrinks by 0.8 a period
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        P = propose_discrete_lyapunov(L.EULER_A, Fraction(4, 5))
    if P is not None:
        failures = check_discrete_lyapunov(L.EULER_A, P, Fraction(4, 5))
        assert any("not positive definite" in f for f in failures)


@pytest.mark.parametrize("why,A,P,rate", [
    ("stiff gains", L.euler_matrix(600), L.EULER_P, 1),
    ("not positive definite", L.EULER_A, [[-x for x in row] for row in L.EULER_P], L.EULER_RATE),
    ("not symmetric", L.EULER_A, [[L.EULER_P[0][0], 0], [L.EULER_P[1][0], 1]], L.EULER_RATE),
    ("too fast a rate", L.EULER_A, L.EULER_P, Fraction(4, 5)),
    ("identity", L.EULER_A, [[1, 0], [0, 1]], 1),
    ("rate above 1", L.EULER_A, L.EULER_P, 2),
])
def test_wrong_certificates_are_rejected(why, A, P, rate):
    assert check_discrete_lyapunov(A, P, rate) != [], why


def test_a_rejected_certificate_has_a_state_where_it_fails():
    """Independent of the Sylvester check: an explicit state where V does not shrink."""
    A, P = L.euler_matrix(600), L.EULER_P
    z = [Fraction(0), Fraction(1)]
    assert _V(P, _apply(A, z)) > _V(P, z)
    A, P = L.EULER_A, [[1, 0], [0, 1]]
    z = [Fraction(1), Fraction(0)]
    assert _V(P, _apply(A, z)) > _V(P, z)


@settings(max_examples=200, deadline=None)
@given(x=st.fractions(-10, 10, max_denominator=1000), v=st.fractions(-10, 10, max_denominator=1000))
def test_the_accepted_certificate_shrinks_on_every_sampled_state(x, v):
    z = [x, v]
    if z == [0, 0]:
        return
    assert _V(L.EULER_P, z) > 0
    assert _V(L.EULER_P, _apply(L.EULER_A, z)) < L.EULER_RATE * _V(L.EULER_P, z)


def test_the_theorem_uses_the_checked_matrix():
    text = str(library.get("rcm.constraint_euler_lyapunov").assumptions)
    assert "187247/577" in text and "18958/735" in text
