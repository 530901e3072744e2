"""Theme 8: families over index sorts, Int-indexed arrays, stores then reads at possibly equal
indices (aliasing), index-valued families, whole-family havoc, and foreach loops with
quantified invariants. Witnesses enumerate small finite families with dicts."""

from __future__ import annotations

import itertools

from certiloop.models import (
    BOOL,
    INT,
    TRUE,
    And,
    Array,
    Family,
    ForAll,
    Implies,
    IndexSort,
    Ints,
    Not,
    Or,
    Reals,
    Theorem,
    Var,
    assign,
    choice,
    for_range,
    foreach,
    havoc,
    seq,
    skip,
    test,
)

from .harness import SAMPLES, Case, Q, check, randomized, rat, rint, rng

CASES: list[Case] = []


def case(id, truth, witness, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


B = IndexSort("B")
i, j, l_, i2, e0 = (Var(nm, B) for nm in ("i", "j", "l", "i2", "e0"))
F = Family("F", B)
G = Family("G", B)
done = Family("done", B, BOOL)
active = Family("active", B, BOOL)
nxt = Family("nxt", B, B)
A = Array("A", INT)
P = Array("P", (INT, INT))
D = Array("D", (B, B))
k, m, n, a, b = Ints("k m n a b")
x, c = Reals("x c")


def arith(cond):
    def w():
        check(cond)

    return w


def _store_nxt(g):
    """nxt(i) := j on a random index-valued family: (nxt, i, j)."""
    size = rint(g, 1, 5)
    f = {e: rint(g, 0, size - 1) for e in range(size)}
    ii, jj = rint(g, 0, size - 1), rint(g, 0, size - 1)
    f[ii] = jj
    return f, ii, jj


def _havoc_positive(g):
    """F := * then ?∀j F(j) > 0: only all-positive families pass; (F, i)."""
    size = rint(g, 1, 6)
    while True:
        f = {e: rat(g, -1, 5) for e in range(size)}
        if all(val > 0 for val in f.values()):
            return f, rint(g, 0, size - 1)


def _havoc_cell(g):
    """F(j) = 0, i != j, then F(i) := *: (F, i, j)."""
    size = rint(g, 2, 6)
    ii, jj = rng_pair(g, size)
    f = {e: rat(g, -5, 5) for e in range(size)}
    f[jj] = Q(0)
    f[ii] = rat(g, -5, 5)
    return f, ii, jj


def rng_pair(g, size):
    ii = rint(g, 0, size - 1)
    jj = (ii + rint(g, 1, size - 1)) % size
    return ii, jj


def _congruent(g):
    size = rint(g, 1, 6)
    ii = rint(g, 0, size - 1)
    return {e: rat(g, -5, 5) for e in range(size)}, ii, ii


def small_families():
    """Every (size, i, j) with a universe of 1..3 elements."""
    for size in (1, 2, 3):
        for ii in range(size):
            for jj in range(size):
                yield size, ii, jj


# --------------------------------------------------------------------------- stores and reads
def w_store_same():
    # TRUE: after F(i) := 1, F(i) = 1 in every family.
    for size, ii, _ in small_families():
        f = {e: Q(0) for e in range(size)}
        f[ii] = Q(1)
        check(f[ii] == 1)


@case("fam-store-read-same-true", "true", w_store_same)
def _():
    # TRUE: read after write at the same index.
    return T("fam-rw", i == i, assign(F(i), 1), F(i) == 1)


@case("fam-store-read-other-false", "false", arith({0: Q(1), 1: Q(0)}[1] != 1))
def _():
    # FALSE: family {e0, e1}, i = e0, j = e1, F = 0: F(j) stays 0.
    return T("fam-rw-f", And(i == i, j == j, F(j) == 0), assign(F(i), 1), F(j) == 1)


def w_store_eq():
    # TRUE: i = j, so writing F(i) writes F(j).
    for size, ii, jj in small_families():
        if ii == jj:
            f = {e: Q(0) for e in range(size)}
            f[ii] = Q(1)
            check(f[jj] == 1)


@case("fam-store-read-equal-index-true", "true", w_store_eq)
def _():
    # TRUE: i = j is assumed.
    return T("fam-rw-eq", i == j, assign(F(i), 1), F(j) == 1)


def w_alias_false():
    # FALSE: i = j: F(i) := 1; F(j) := 2 leaves F(i) = 2.
    f = {0: Q(0)}
    f[0] = Q(1)
    f[0] = Q(2)
    check(f[0] != 1)


@case("fam-aliasing-overwrite-false", "false", w_alias_false)
def _():
    # FALSE: the second store may hit the same element.
    return T("fam-alias", And(i == i, j == j), seq(assign(F(i), 1), assign(F(j), 2)), F(i) == 1)


def w_alias_true():
    # TRUE: either i != j (F(i) keeps 1) or i = j.
    for size, ii, jj in small_families():
        f = {e: Q(0) for e in range(size)}
        f[ii], f[jj] = Q(1), Q(2)
        check(f[ii] == 1 or ii == jj)


@case("fam-aliasing-disjunction-true", "true", w_alias_true)
def _():
    # TRUE: F(i) = 1 unless i = j.
    return T("fam-alias-t", And(i == i, j == j), seq(assign(F(i), 1), assign(F(j), 2)), Or(F(i) == 1, i == j))


@case("fam-aliasing-distinct-true", "true", w_alias_true)
def _():
    # TRUE: with i != j assumed, F(i) keeps 1.
    return T("fam-alias-d", Not(i == j), seq(assign(F(i), 1), assign(F(j), 2)), F(i) == 1)


def w_arr_shift():
    # TRUE: k != k + 1, so A[k] keeps 5.
    g = rng("arr-shift")
    for _ in range(SAMPLES):
        kk = rint(g, -50, 50)
        arr = {}
        arr[kk], arr[kk + 1] = 5, 6
        check(arr[kk] == 5)


@case("arr-int-adjacent-cells-true", "true", w_arr_shift)
def _():
    # TRUE: A[k] := 5; A[k+1] := 6 leaves A[k] = 5.
    return T("arr-shift", k == k, seq(assign(A[k], 5), assign(A[k + 1], 6)), A[k] == 5)


def w_arr_alias():
    # FALSE: k = m = 0: A[0] := 5; A[0] := 6 leaves A[0] = 6 != 5.
    arr = {0: 0}
    arr[0] = 5
    arr[0] = 6
    check(arr[0] != 5)


@case("arr-int-alias-false", "false", w_arr_alias)
def _():
    # FALSE: m = k: the second store overwrites A[k] with 6.
    return T("arr-alias", And(k == k, m == m), seq(assign(A[k], 5), assign(A[m], 6)), A[k] == 5)


def w_parity():
    # TRUE: 2k (even) != 2m + 1 (odd).
    check(all(2 * kk != 2 * mm + 1 for kk in range(-40, 41) for mm in range(-40, 41)))


@case("arr-int-parity-cells-true", "true", w_parity)
def _():
    # TRUE: even and odd cells never alias.
    return T(
        "arr-parity", And(k == k, m == m), seq(assign(A[2 * k], 1), assign(A[2 * m + 1], 2)), A[2 * k] == 1
    )


def w_transpose():
    # FALSE: a = 0, b = 1, P = 0 everywhere (so P[b][a] = 0 holds initially); P[0][1] := 1.
    grid_ = {(p_, q_): 0 for p_ in range(2) for q_ in range(2)}
    check(grid_[1, 0] == 0)
    grid_[0, 1] = 1
    check(grid_[1, 0] != 1)


@case("arr-2d-transpose-false", "false", w_transpose)
def _():
    # FALSE: a = 0, b = 1, P = 0: P[0][1] := 1 leaves P[1][0] = 0.
    return T("arr-2d", And(a == 0, b == 1, P[b][a] == 0), assign(P[a][b], 1), P[b][a] == 1)


@case(
    "arr-2d-diagonal-true",
    "true",
    randomized(
        "arr-2d-diag",
        lambda g: (lambda a_: ({(a_, a_): 1}, a_))(rint(g, -20, 20)),
        lambda s: s[0][(s[1], s[1])] == 1,
    ),
)
def _():
    # TRUE: a = b, so P[a][b] and P[b][a] are the same cell.
    return T("arr-2d-t", a == b, assign(P[a][b], 1), P[b][a] == 1)


# --------------------------------------------------------------------------- index-valued families
def w_nxt_fix():
    # TRUE: ∀j nxt(j) != j implies nxt(i) != i (instance j = i).
    for size in (2, 3):
        for f in itertools.product(range(size), repeat=size):
            if all(f[e] != e for e in range(size)):
                check(all(f[e] != e for e in range(size)))


@case("fam-index-valued-no-fixpoint-true", "true", w_nxt_fix)
def _():
    # TRUE: a family of elements without fixed points has none at i.
    return T("nxt-fix", And(i == i, ForAll(j, Not(nxt(j) == j))), skip(), Not(nxt(i) == i))


def w_nxt_false():
    # FALSE: universe {0,1,2}, nxt = (1, 2, 0), i = 0, j = 1: nxt(i) = j but nxt(j) = 2 != 0.
    f = (1, 2, 0)
    check(f[0] == 1 and f[1] != 0)


@case("fam-index-valued-not-symmetric-false", "false", w_nxt_false)
def _():
    # FALSE: nxt(i) = j does not give nxt(j) = i.
    return T("nxt-sym", nxt(i) == j, skip(), nxt(j) == i)


@case(
    "fam-index-valued-store-true",
    "true",
    randomized("nxt-store", lambda g: _store_nxt(g), lambda s: s[0][s[1]] == s[2]),
)
def _():
    # TRUE: nxt(i) := j then nxt(i) = j.
    return T("nxt-store", And(i == i, j == j), assign(nxt(i), j), nxt(i) == j)


def w_nxt_id():
    # TRUE: nxt the identity: nxt(nxt(i)) = i.
    for size in (1, 2, 3):
        f = {e: e for e in range(size)}
        check(all(f[f[e]] == e for e in range(size)))


@case("fam-index-valued-nested-read-true", "true", w_nxt_id)
def _():
    # TRUE: nested read through the identity.
    return T("nxt-nest", And(i == i, ForAll(j, nxt(j) == j)), skip(), nxt(nxt(i)) == i)


@case("fam-index-valued-nested-read-false", "false", w_nxt_false)
def _():
    # FALSE: universe {0,1,2}, nxt = (1, 2, 0): nxt(nxt(0)) = 2 != 0 although no fixed point.
    return T("nxt-nest-f", And(i == i, ForAll(j, Not(nxt(j) == j))), skip(), nxt(nxt(i)) == i)


def w_done_other():
    # FALSE: family {0, 1}, i = 0, j = 1, done all false: done(0) := true leaves done(1) false.
    dn = {0: False, 1: False}
    check(not dn[1])
    dn[0] = True
    check(not dn[1])


@case("fam-bool-store-other-false", "false", w_done_other)
def _():
    # FALSE: done(i) := true leaves done(j) false for j != i.
    return T("done-f", And(i == i, Not(done(j))), assign(done(i), TRUE), done(j))


# --------------------------------------------------------------------------- whole-family havoc
@case(
    "fam-havoc-then-test-true",
    "true",
    randomized("fam-havoc", lambda g: _havoc_positive(g), lambda s: s[0][s[1]] > 0),
)
def _():
    # TRUE: F := *; ?∀j F(j) > 0 leaves F(i) > 0.
    return T("fam-havoc", i == i, seq(havoc(F), test(ForAll(j, F(j) > 0))), F(i) > 0)


@case("fam-havoc-forgets-false", "false", arith(Q(0) != 7))
def _():
    # FALSE: F := * may set F(i) = 7.
    return T("fam-havoc-f", F(i) == 0, havoc(F), F(i) == 0)


@case(
    "fam-havoc-cell-keeps-others-true",
    "true",
    randomized("fam-havoc-cell", lambda g: _havoc_cell(g), lambda s: s[0][s[2]] == 0),
)
def _():
    # TRUE: F(i) := * changes only cell i, and j != i.
    return T("fam-havoc-cell", And(F(j) == 0, Not(i == j)), havoc(F(i)), F(j) == 0)


@case(
    "fam-congruence-true",
    "true",
    randomized("fam-cong", lambda g: _congruent(g), lambda s: s[0][s[1]] == s[0][s[2]]),
)
def _():
    # TRUE: equal indices read equal values.
    return T("fam-cong", And(i == j, F(i) == F(i)), skip(), F(i) == F(j))


def w_sym_2d():
    # TRUE: a symmetric D has D(i, i2) = D(i2, i).
    for size in (1, 2):
        for vals in itertools.product((0, 1), repeat=size * size):
            d = {(p, q): vals[p * size + q] for p in range(size) for q in range(size)}
            if all(d[p, q] == d[q, p] for p in range(size) for q in range(size)):
                check(all(d[p, q] == d[q, p] for p in range(size) for q in range(size)))


@case("fam-two-index-symmetric-true", "true", w_sym_2d)
def _():
    # TRUE: a 2-index family assumed symmetric is symmetric at (i, i2).
    return T(
        "fam-2idx", And(i == i, i2 == i2, ForAll((j, l_), D[j][l_] == D[l_][j])), skip(), D[i][i2] == D[i2][i]
    )


# --------------------------------------------------------------------------- foreach
def foreach_order(size, g):
    """The order in which a foreach over {0..size-1} visits its elements: any permutation."""
    return [int(e) for e in g.permutation(size)]


def w_mark_all():
    # TRUE: every element is visited once and set to 0.
    g = rng("foreach-all")
    for _ in range(SAMPLES):
        size = rint(g, 1, 7)
        f = {e: rat(g, -5, 5) for e in range(size)}
        for e in foreach_order(size, g):
            f[e] = Q(0)
        check(all(val == 0 for val in f.values()))


INV0 = ForAll(j, Implies(done(j), F(j) == 0))


@case("foreach-set-all-zero-true", "true", w_mark_all)
def _():
    # TRUE: foreach visits every element: F = 0 everywhere afterwards.
    return T("fe-all", TRUE, foreach(i, done, assign(F(i), 0), INV0), ForAll(j, F(j) == 0))


@case("foreach-writes-one-false", "false", arith(Q(1) != 0))
def _():
    # FALSE: one element: the body sets F(e) = 1, not 0.
    return T(
        "fe-one",
        TRUE,
        foreach(i, done, assign(F(i), 1), ForAll(j, Implies(done(j), F(j) == 1))),
        ForAll(j, F(j) == 0),
    )


def w_fixed_elem():
    # FALSE: family {e0}: visiting e0 sets F(e0) := 0 then F(e0) := 1; F(e0) = 1 != 0.
    f = {0: Q(3)}
    f[0] = Q(0)
    f[0] = Q(1)
    check(f[0] != 0)


@case("foreach-clobbers-fixed-element-false", "false", w_fixed_elem)
def _():
    # FALSE: the body also writes F(e0) := 1 for a fixed element e0.
    return T(
        "fe-clobber",
        e0 == e0,
        foreach(i, done, seq(assign(F(i), 0), assign(F(e0), 1)), TRUE),
        ForAll(j, F(j) == 0),
    )


def w_where():
    # TRUE: active elements are set to 0, inactive ones untouched (not claimed).
    g = rng("foreach-where")
    for _ in range(SAMPLES):
        size = rint(g, 1, 6)
        act = {e: bool(g.random() < 0.5) for e in range(size)}
        f = {e: rat(g, -5, 5) for e in range(size)}
        for e in g.permutation(size):
            if act[int(e)]:
                f[int(e)] = Q(0)
        check(all(f[e] == 0 for e in range(size) if act[e]))


INV_ACT = ForAll(j, Implies(done(j), And(active(j), F(j) == 0)))


@case("foreach-where-active-true", "true", w_where)
def _():
    # TRUE: foreach over the active elements zeroes exactly those.
    return T(
        "fe-where",
        TRUE,
        foreach(i, done, assign(F(i), 0), INV_ACT, where=lambda e: active(e)),
        ForAll(j, Implies(active(j), F(j) == 0)),
    )


@case("foreach-where-active-false", "false", arith(Q(5) != 0))
def _():
    # FALSE: one inactive element e with F(e) = 5 keeps it.
    return T(
        "fe-where-f",
        TRUE,
        foreach(i, done, assign(F(i), 0), INV_ACT, where=lambda e: active(e)),
        ForAll(j, F(j) == 0),
    )


def w_min():
    # TRUE: c := 1; c := min(c, F(e)) for every e gives c <= F(j) for all j.
    g = rng("foreach-min")
    for _ in range(SAMPLES):
        size = rint(g, 1, 6)
        f = {e: rat(g, -5, 5) for e in range(size)}
        cc = Q(1)
        for e in g.permutation(size):
            cc = min(cc, f[int(e)])
        check(all(cc <= f[e] for e in range(size)) and cc <= 1)


MIN_STEP = choice(seq(test(F(i) >= c), skip()), seq(test(F(i) < c), assign(c, F(i))))


@case("foreach-min-true", "true", w_min)
def _():
    # TRUE: running minimum over the family.
    return T(
        "fe-min",
        TRUE,
        seq(assign(c, 1), foreach(i, done, MIN_STEP, And(c <= 1, ForAll(j, Implies(done(j), c <= F(j)))))),
        ForAll(j, c <= F(j)),
    )


def w_last_wins():
    # FALSE: family {e0, e1}, F = (1, 2), visiting e0 then e1: c = 2 > F(e0) = 1.
    f = {0: Q(1), 1: Q(2)}
    cc = Q(1)
    for e in (0, 1):
        cc = f[e]
    check(not (cc <= f[0]))


@case("foreach-last-wins-false", "false", w_last_wins)
def _():
    # FALSE: c := F(i) for every element keeps only the last value.
    return T(
        "fe-last", TRUE, seq(assign(c, 1), foreach(i, done, assign(c, F(i)), TRUE)), ForAll(j, c <= F(j))
    )


# --------------------------------------------------------------------------- Int arrays + for_range
def w_fill():
    # TRUE: A[q] = q for 0 <= q < n after the fill.
    g = rng("fill")
    for _ in range(SAMPLES):
        nn = rint(g, 0, 30)
        arr = {q: rint(g, -9, 9) for q in range(-3, 40)}
        for q in range(nn):
            arr[q] = q
        check(all(arr[q] == q for q in range(nn)))


FILLED = lambda hi: ForAll(m, Implies(And(0 <= m, m < hi), A[m] == m))  # noqa: E731


@case("arr-fill-range-true", "true", w_fill)
def _():
    # TRUE: for k in [0, n): A[k] := k fills the prefix.
    return T("fill", n >= 0, for_range(k, 0, n, assign(A[k], k), invariant=FILLED(k)), FILLED(n))


@case("arr-fill-range-includes-n-false", "false", arith(Q(7) != 0))
def _():
    # FALSE: n = 0 and A[0] = 7: the claim about m <= n covers the unfilled cell A[n].
    return T(
        "fill-f",
        And(n >= 0, A[n] == 7),
        for_range(k, 0, n, assign(A[k], k), invariant=FILLED(k)),
        ForAll(m, Implies(And(0 <= m, m <= n), A[m] == m)),
    )
