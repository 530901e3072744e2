"""Dual-arm SCARA collision-free motion planner (seed 002): builtDR as a Hoare triple.

Theorem 1 of the seed:
    {T} BuiltDR {∀ i j k. k < N ∧ i < m ∧ j < n ⇒ P[k][i][j] = (SLarm_k ∩ SRarm_{k,i,j} = Φ → 0 | 1)}

The swept-region intersection test is a computed predicate; here it is the Bool array
`overlap[k][i][j]` (true when the two swept regions intersect), so the triple states that
the state database records exactly the collision predicate over the whole (k, i, j) grid.
"""

from __future__ import annotations

from certiloop.models.lang.programs import assign, for_range, if_
from certiloop.models.lang.terms import BOOL, INT, And, Array, ForAll, Implies, Ints, Not
from certiloop.models.lang.theorem import Theorem

N, m, n = Ints("N m n")
k, i, j = Ints("k i j")
a, b, c = Ints("a b c")
P = Array("P", (INT, INT, INT), INT)
overlap = Array("overlap", (INT, INT, INT), BOOL)


def recorded(kk, ii, jj):
    """P holds the collision predicate at (kk, ii, jj): 1 if the regions meet, else 0."""
    hit = overlap[kk][ii][jj]
    return And(Implies(hit, P[kk][ii][jj] == 1), Implies(Not(hit), P[kk][ii][jj] == 0))


def _layers_done(upto):
    return ForAll((a, b, c), Implies(And(0 <= a, a < upto, 0 <= b, b < m, 0 <= c, c < n),
                                     recorded(a, b, c)))


def _rows_done(upto):
    return ForAll((b, c), Implies(And(0 <= b, b < upto, 0 <= c, c < n), recorded(k, b, c)))


def _cells_done(upto):
    return ForAll(c, Implies(And(0 <= c, c < upto), recorded(k, i, c)))


def _builtdr(row_bound, name: str, expected: str, description: str) -> Theorem:
    cell = if_(overlap[k][i][j], assign(P[k][i][j], 1), assign(P[k][i][j], 0),
               labels=("regions meet: P := 1", "regions apart: P := 0"))
    columns = for_range(j, 0, n, cell, And(_layers_done(k), _rows_done(i), _cells_done(j)))
    rows = for_range(i, 0, row_bound, columns, And(_layers_done(k), _rows_done(i)))
    layers = for_range(k, 0, N, rows, _layers_done(k))
    return Theorem(
        name=name,
        assumptions=And(N >= 0, m >= 0, n >= 0),
        program=layers,
        guarantee=_layers_done(N),
        expected=expected,
        constants=(N, m, n),
        description=description,
    )


def builtdr() -> Theorem:
    """Algorithm 1's builtDR fills P[k][i][j] for every cell (Theorem 1 of seed 002)."""
    return _builtdr(m, "cfmpa.builtdr", "proved", "builtDR records the collision predicate in every "
                    "cell (Hoare triple, quantified invariants)")


def builtdr_skips_last_row() -> Theorem:
    """An off-by-one in the row loop (i < m - 1) leaves the last row of every layer unset."""
    return _builtdr(m - 1, "cfmpa.builtdr_skips_last_row", "refuted",
                    "row loop stops one short: the last row keeps stale values")

