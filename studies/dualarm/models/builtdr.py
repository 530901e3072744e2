"""Dual-arm SCARA collision-free motion planner (the dual-arm paper): builtDR as a Hoare triple.

Theorem 1 of the seed:
    {T} BuiltDR {∀ i j k. k < N ∧ i < m ∧ j < n ⇒ P[k][i][j] = (SLarm_k ∩ SRarm_{k,i,j} = Φ → 0 | 1)}

The swept-region intersection test is a computed predicate; here it is the Bool array
`overlap[k][i][j]` (true when the two swept regions intersect), so the triple states that
the state database records exactly the collision predicate over the whole (k, i, j) grid.
"""

from __future__ import annotations

from certiloop.models.lang.conveniences import for_range, if_
from certiloop.models.lang.programs import assign, havoc, seq, test
from certiloop.models.lang.terms import BOOL, INT, And, Array, ForAll, Implies, Ints, Not, Or
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


def _builtdr(row_bound, name: str, expected: str, description: str, extra: int = 0) -> Theorem:
    """extra = 1: every loop runs to its bound inclusive, as Algorithm 1 prints it (D3)."""
    cell = if_(overlap[k][i][j], assign(P[k][i][j], 1), assign(P[k][i][j], 0),
               labels=("regions meet: P := 1", "regions apart: P := 0"))
    columns = for_range(j, 0, n + extra, cell, And(_layers_done(k), _rows_done(i), _cells_done(j)))
    rows = for_range(i, 0, row_bound + extra, columns, And(_layers_done(k), _rows_done(i)))
    layers = for_range(k, 0, N + extra, rows, _layers_done(k))
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
    """Algorithm 1's builtDR fills P[k][i][j] for every cell (Theorem 1 of the dual-arm paper)."""
    return _builtdr(m, "cfmpa.builtdr", "proved", "builtDR records the collision predicate in every "
                    "cell (Hoare triple, quantified invariants)")


def builtdr_skips_last_row() -> Theorem:
    """An off-by-one in the row loop (i < m - 1) leaves the last row of every layer unset."""
    return _builtdr(m - 1, "cfmpa.builtdr_skips_last_row", "refuted",
                    "row loop stops one short: the last row keeps stale values")



def builtdr_inclusive() -> Theorem:
    """Algorithm 1 as printed loops k = 0..N, i = 0..m, j = 0..n inclusively, while Theorem 1
    speaks of k < N, i < m, j < n (D3). The extra layer, row and column are written too (a
    real implementation would index past its arrays); Theorem 1's cells are still all set."""
    return _builtdr(m, "cfmpa.builtdr_inclusive", "proved", "builtDR with Algorithm 1's inclusive loop "
                    "bounds (0..N, 0..m, 0..n): Theorem 1 still holds on k<N, i<m, j<n", extra=1)


# --------------------------------------------------------------------------- Property 8

P2 = Array("P2", (INT, INT, INT), INT)  # D'_R, built from the modified region S'
overlap2 = Array("overlap2", (INT, INT, INT), BOOL)  # S'_k meets SRarm_{k,i,j}
behind = Array("behind", (INT, INT, INT), BOOL)  # S_k - S'_k (the backward half) meets SRarm_{k,i,j}


def _property8(name: str, guarantee, expected: str, description: str) -> Theorem:
    """S'_k ⊆ S_k (`cfmpa.joint_box_monotone` lifted to swept regions) means S_k = S'_k ∪ (S_k - S'_k),
    so S_k meets the subordinate's region exactly when S'_k or the backward half does. One
    arbitrary cell (k, i, j) of the grid gets its entry in D_R (Theorem 1's post, from S) and in
    D'_R (Theorem 3's post, from S'), as builtDR's loop body writes them."""
    in_s = Or(overlap2[k][i][j], behind[k][i][j])
    return Theorem(
        name=name,
        assumptions=And(N >= 0, m >= 0, n >= 0),
        program=seq(havoc(k), havoc(i), havoc(j),
                    test(And(0 <= k, k < N, 0 <= i, i < m, 0 <= j, j < n)),
                    if_(in_s, assign(P[k][i][j], 1), assign(P[k][i][j], 0),
                        labels=("S meets SR: P := 1", "S apart: P := 0")),
                    if_(overlap2[k][i][j], assign(P2[k][i][j], 1), assign(P2[k][i][j], 0),
                        labels=("S' meets SR: P' := 1", "S' apart: P' := 0"))),
        guarantee=guarantee,
        expected=expected,
        constants=(N, m, n),
        description=description,
    )


def property8() -> Theorem:
    """Property 8 as intended (D10; the printed formula is the tautology A ⇒ A): with S' ⊆ S,
    (8a) a cell the original database marks free is free of S' too, so Theorem 1's soundness
    precondition implies Theorem 3's; (8b) P' <= P cell by cell: the modified database has at
    least the original's free cells, which is the paper's efficiency claim."""
    return _property8("cfmpa.property8",
                      And(Implies(P[k][i][j] == 0, Not(overlap2[k][i][j])), P2[k][i][j] <= P[k][i][j]),
                      "proved", "Property 8 as intended: S' ⊆ S gives P=0 ⇒ S' free (8a) and P' <= P (8b)")


def property8_converse() -> Theorem:
    """The converse direction fails: a cell free in the modified database D'_R need not be free
    of the original region S (it may meet only S - S', the half the principal never enters).
    So the two iff-preconditions of Theorems 2 and 4 are incomparable; only the soundness
    halves are ordered."""
    return _property8("cfmpa.property8_converse",
                      Implies(P2[k][i][j] == 0, Not(Or(overlap2[k][i][j], behind[k][i][j]))),
                      "refuted", "converse of Property 8: a cell free for S' may still meet S")
