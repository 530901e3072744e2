"""Darboux polynomials of affine ODEs by linear algebra (search, outside the trusted core).

For x' = A x + b with rational A and b, every left eigenvector c of A with a rational
eigenvalue λ != 0 gives a Darboux polynomial p = c.x + c.b/λ: p' = c.(A x + b) = λ c.x + c.b
= λ p. Its sign never changes along a flow, so `p >= 0` and `p <= 0` are candidate invariant
atoms for the planner (odeplan), which the core then proves or drops with its own exact rules
(a Darboux identity, dbx with cofactor λ). Nothing here decides anything.
"""

from __future__ import annotations

import sympy

from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import Node, cmp
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy


def darboux_atoms(ode: ODE) -> list[Node]:
    """`p >= 0` and `p <= 0` for each linear Darboux polynomial found, or [] when the system is
    not affine with rational coefficients."""
    table = SympyTable()
    xs = [table.symbol(v) for v in ode.variables]
    rhs = {v.name: sympy.expand(to_sympy(f, table)) for v, f in ode.eqs}
    A, b = sympy.zeros(len(xs), len(xs)), sympy.zeros(len(xs), 1)
    for i, v in enumerate(ode.variables):
        f = rhs[v.name]
        if not f.is_polynomial(*xs) or sympy.Poly(f, *xs).total_degree() > 1:
            return []
        row = [f.coeff(x, 1) for x in xs] + [f.subs({x: 0 for x in xs})]
        if not all(c.is_Rational for c in row):
            return []  # a parameter or an irrational number: eigenvectors left to a person
        A[i, :], b[i] = sympy.Matrix([row[:-1]]), row[-1]
    atoms = []
    for value, _, vectors in A.T.eigenvects():
        if not value.is_Rational or value == 0:
            continue
        for c in vectors:
            c = c / max(abs(x) for x in c if x != 0)  # a readable scale
            p = sum(ci * xi for ci, xi in zip(c, xs)) + (c.T * b)[0] / value
            term = from_sympy(sympy.expand(p), table)
            atoms += [cmp(">=", term, 0), cmp("<=", term, 0)]
    return atoms
