"""The RCM paper: a numeric Lyapunov certificate for the paper's discretised RCM constraint dynamics.

(25) with alpha = beta = 25, integrated by explicit Euler at h = 4 ms, is the linear map
z+ = A z on z = (x_c, x_c'), A = [[1, h], [-h a^2, 1 - 2 a h]]. The matrix P below was proposed
by an SDP (cvxpy: P >= I, rate P - A^T P A > 0, smallest trace; regenerate with
`certiloop.proofs.arith.lyapunov.propose_discrete_lyapunov(EULER_A, EULER_RATE)`), rounded to
rationals and accepted by the exact check `check_discrete_lyapunov` (sympy, Sylvester) before it
was stored here. The theorem then proves, in z3 over the rationals, the same facts as loop
obligations: V(z) = z^T P z decreases by `rate` every period, and |x_c|^2 <= (P^-1)_11 V.
Nothing here calls a numeric solver when proving.
"""

from __future__ import annotations

from fractions import Fraction

from certiloop.models.lang.programs import assign, loop, seq
from certiloop.models.lang.terms import And, Reals
from certiloop.models.lang.theorem import Theorem
from certiloop.studies.rcm.models.constraint import ALPHA, H

EULER_RATE = Fraction(361, 400)   # 0.95^2 per period: e^(-12.8 t) at 250 Hz (spectral radius 0.9)


def euler_matrix(a: int) -> list[list[Fraction]]:
    """The paper's explicit Euler step of (25) with alpha = beta = a at h = 4 ms."""
    return [[Fraction(1), H], [-H * a * a, 1 - 2 * a * H]]


EULER_A = euler_matrix(ALPHA)
# proposed by cvxpy (Clarabel), rounded, checked exactly (tests/studies/rcm/test_rcm_lyapunov.py re-checks)
EULER_P = [[Fraction(187247, 577), Fraction(9479, 735)], [Fraction(9479, 735), Fraction(1)]]

xc, vc, x_old, gs, W0 = Reals("xc vc x_old gs W0")


def _quadratic(P, x, v):
    return P[0][0] * x * x + 2 * P[0][1] * x * v + P[1][1] * v * v


def _lyapunov(name: str, a: int, expected: str, description: str) -> Theorem:
    P = EULER_P
    V = _quadratic(P, xc, vc)
    inv11 = P[1][1] / (P[0][0] * P[1][1] - P[0][1] ** 2)   # (P^-1)_11: x^2 <= inv11 V for P > 0
    step = seq(assign(x_old, xc), assign(xc, xc + H * vc), assign(vc, vc + H * (-2 * a * vc - a * a * x_old)),
               assign(gs, EULER_RATE * gs))
    return Theorem(
        name=name,
        assumptions=And(W0 == V, gs == 1),
        program=loop(step, invariant=And(V <= gs * W0, gs >= 0), label="Euler loop"),
        guarantee=And(V <= gs * W0, xc * xc <= inv11 * gs * W0),
        expected=expected,
        constants=(W0,),
        unroll=3,
        description=description,
    )


def constraint_euler_lyapunov() -> Theorem:
    """(25) by the paper's 4 ms explicit Euler: the SDP certificate V = z^T P z shrinks by
    0.95^2 a period, so |x_c|^2 <= (P^-1)_11 V0 0.95^(2k) after k periods."""
    return _lyapunov("rcm.constraint_euler_lyapunov", ALPHA, "proved",
                     "(25), 4 ms Euler: cvxpy Lyapunov matrix, checked exactly, V shrinks 0.95² a period")


def constraint_euler_lyapunov_stiff() -> Theorem:
    """The same certificate claimed for alpha = beta = 600 (a h = 2.4 > 2): the map is unstable,
    the certificate fails and a run breaks the bound."""
    return _lyapunov("rcm.constraint_euler_lyapunov_stiff", 600, "refuted",
                     "the 4 ms certificate reused at α = β = 600 (αh = 2.4): V grows, the bound fails")
