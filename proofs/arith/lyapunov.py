"""Lyapunov certificates for linear discrete maps x+ = A x: a numeric solver proposes, an exact
check decides (outside the trusted core: a certificate only counts once `check_discrete_lyapunov`
accepts it in exact rationals; the library's theorem then re-proves the same facts in z3).

* `propose_discrete_lyapunov(A, rate)`: cvxpy SDP (P >= I, rate P - A^T P A >= delta I,
  smallest trace), rounded entrywise to rationals. It may fail or round badly; it decides nothing.
* `check_discrete_lyapunov(A, P, rate)`: sympy, exact: P symmetric and positive definite, and
  rate P - A^T P A positive definite (Sylvester: every leading principal minor > 0), i.e.
  V(x) = x^T P x > 0 and V(A x) < rate V(x) for every x != 0. Returns the failures ([] = valid).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Sequence

import sympy

Matrix = Sequence[Sequence[Fraction | int]]


def _exact(M: Matrix) -> sympy.Matrix:
    return sympy.Matrix([[sympy.Rational(Fraction(x).numerator, Fraction(x).denominator) for x in row]
                         for row in M])


def _not_positive_definite(M: sympy.Matrix) -> str:
    """'' if the symmetric M is positive definite (all leading principal minors > 0), else why not."""
    for k in range(1, M.rows + 1):
        minor = M[:k, :k].det()
        if minor <= 0:
            return f"leading {k}x{k} minor is {minor} <= 0"
    return ""


def check_discrete_lyapunov(A: Matrix, P: Matrix, rate: Fraction | int = 1) -> list[str]:
    """The reasons P is not a certificate that V(x) = x^T P x decreases by the factor `rate`
    along x+ = A x (empty when it is one), decided in exact rationals."""
    a, p, r = _exact(A), _exact(P), sympy.Rational(Fraction(rate).numerator, Fraction(rate).denominator)
    if a.rows != a.cols or p.shape != a.shape:
        return [f"shapes do not match: A is {a.shape}, P is {p.shape}"]
    failures = []
    if p != p.T:
        failures.append("P is not symmetric")
    elif why := _not_positive_definite(p):
        failures.append(f"P is not positive definite: {why}")
    if not 0 < r <= 1:
        failures.append(f"rate {r} is not in (0, 1]")
    if p == p.T and (why := _not_positive_definite(r * p - a.T * p * a)):
        failures.append(f"rate*P - A^T P A is not positive definite: {why}")
    return failures


def propose_discrete_lyapunov(A: Matrix, rate: Fraction | int = 1, denominator: int = 1000,
                              delta: float = 1e-3) -> list[list[Fraction]] | None:
    """A candidate P from an SDP (cvxpy, any installed SDP solver), rounded to rationals with
    denominators <= `denominator` and symmetrised; None when the solver finds none."""
    import cvxpy as cp  # heavy: only for regenerating certificates, never when proving
    import numpy as np

    a = np.array([[float(x) for x in row] for row in A])
    n = a.shape[0]
    P = cp.Variable((n, n), symmetric=True)
    constraints = [P >> np.eye(n), float(rate) * P - a.T @ P @ a >> delta * np.eye(n)]
    problem = cp.Problem(cp.Minimize(cp.trace(P)), constraints)
    try:
        problem.solve()
    except cp.error.SolverError:
        return None
    if P.value is None or problem.status not in ("optimal", "optimal_inaccurate"):
        return None
    value = (P.value + P.value.T) / 2
    value = value / min(value[i][i] for i in range(n))  # scale-free: readable rationals
    return [[Fraction(float(value[i][j])).limit_denominator(denominator) for j in range(n)] for i in range(n)]
