"""Eigenvalue ghosts for linear flows (search, outside the trusted core).

A pair of a flow's variables that moves linearly, `u' = a11*u + a12*w, w' = a21*u + a22*w`,
with coefficients that are parameters (an overdamped door: `x' = y, y' = a*x + b*y`), has the
Darboux forms `q = w1*u + w2*w`, `q' = l*q`, for each real eigenvalue l of the matrix and
left eigenvector (w1, w2): `(a21, l - a11)` or `(l - a22, a12)`. The eigenvalue is a root of
`l^2 - (a11+a22)*l + (a11*a22 - a12*a21)`, irrational in general, so Darboux search over the
rationals cannot find it. KeYmaera X's archive proves the door with the same ghost
(`cut(\\exists w w = (-b+(b^2+4*a)^(1/2))/2)`).

Each option is the theorem with a ghost constant for one root (the smaller or the larger:
`2*l <= trace` or `>=`) and the forms' sign conditions added to the flow's annotations. The
core proves that the root exists under the assumptions and checks every annotation, so an
option is only a hint: a wrong one fails to prove.
"""

from __future__ import annotations

from dataclasses import replace
from itertools import combinations

import sympy

from certiloop.models.lang.programs import ODE, Choice, Loop, Program, Seq
from certiloop.models.lang.terms import And, Node, Real, cmp
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy
from certiloop.proofs.engine.odeplan import odes_of

MAX_OPTIONS = 2  # whole proof attempts: the smaller and the larger root of one pair


def ghost_options(theorem: Theorem) -> list[Theorem]:
    """Theorems with an eigenvalue ghost and its Darboux forms, for the first linear pair of
    the program's flows whose eigenvalues are not rational numbers (those Darboux search
    finds)."""
    for flow in odes_of(theorem.program):
        for pair in _linear_pairs(flow):
            name = theorem.unused_name("eig")
            options = [_option(theorem, flow, pair, name, side) for side in ("<=", ">=")]
            return options[:MAX_OPTIONS]
    return []


def _linear_pairs(flow: ODE):
    """((u, w), matrix, table) in sympy for each pair of the flow's variables whose rates are
    linear in the pair alone, the matrix's entries free of the flow's variables, the
    eigenvalues possibly real and not rational numbers."""
    table = SympyTable()
    moving = {v.payload: table.symbol(v) for v in flow.variables}
    rates = {v.payload: sympy.expand(to_sympy(f, table)) for v, f in flow.eqs}
    for u, w in combinations([v.payload for v in flow.variables], 2):
        pair = (moving[u], moving[w])
        others = set(moving.values()) - set(pair)
        matrix = []
        for name in (u, w):
            rate = rates[name]
            if rate.free_symbols & others or not rate.is_polynomial(*pair):
                break
            poly = sympy.Poly(rate, *pair)
            if poly.total_degree() != 1 or any(sum(m) != 1 for m in poly.monoms()):
                break
            matrix.append([poly.coeff_monomial(pair[0]), poly.coeff_monomial(pair[1])])
        else:
            (a11, a12), (a21, a22) = matrix
            discriminant = sympy.expand((a11 - a22) ** 2 + 4 * a12 * a21)
            if discriminant.is_number and (discriminant < 0 or sympy.sqrt(discriminant).is_rational):
                continue  # complex, or rational eigenvalues (Darboux search over QQ has them)
            yield pair, matrix, table


def _option(theorem: Theorem, flow: ODE, found, name: str, side: str) -> Theorem:
    (u, w), ((a11, a12), (a21, a22)), table = found
    eig = table.symbol(Real(name))
    trace = a11 + a22

    def term(e) -> Node:
        return from_sympy(sympy.expand(e), table)

    fact = And(cmp("==", term(eig ** 2 - trace * eig + a11 * a22 - a12 * a21), 0),
               cmp(side, term(2 * eig), term(trace)))
    atoms: dict[tuple, Node] = {}
    for w1, w2 in ((a21, eig - a11), (eig - a22, a12)):
        form = sympy.expand(w1 * u + w2 * w)
        if form == 0:
            continue
        for atom in (cmp(">=", term(form), 0), cmp("<=", term(form), 0)):
            atoms.setdefault(atom.key, atom)
    hinted = replace(flow, invariants=(*atoms.values(), *flow.invariants))
    program = _with_flow(theorem.program, flow, hinted)
    return replace(theorem, program=program, ghosts=(*theorem.ghosts, (name, fact)))


def _with_flow(p: Program, old: ODE, new: ODE) -> Program:
    """p with each occurrence of the flow `old` replaced by `new` (annotations differ only)."""
    if isinstance(p, ODE):
        return new if p.key == old.key else p
    if isinstance(p, Seq):
        return replace(p, parts=tuple(_with_flow(q, old, new) for q in p.parts))
    if isinstance(p, Choice):
        return replace(p, alternatives=tuple(_with_flow(q, old, new) for q in p.alternatives))
    if isinstance(p, Loop):
        return replace(p, body=_with_flow(p.body, old, new))
    return p
