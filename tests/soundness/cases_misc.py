"""Theme 11: odds and ends a careful verification engineer tries — empty and trivial programs,
true/false/contradictory assumptions, huge and tiny constants, floats (the DSL reads a float
by its shortest decimal: 0.1 is 1/10), negative zero, infinities, many branches, long
sequences, Bool connectives, the `expected` field, declared constants."""

from __future__ import annotations

from fractions import Fraction

from certiloop.models import (
    FALSE,
    TRUE,
    And,
    Family,
    ForAll,
    Iff,
    Implies,
    IndexSort,
    Int,
    Ite,
    Not,
    Or,
    Reals,
    Theorem,
    Var,
    assign,
    branch,
    choice,
    havoc,
    if_,
    loop,
    seq,
    skip,
    test,
)

from .harness import SAMPLES, Case, Q, check, randomized, rat, rng

CASES: list[Case] = []


def case(id, truth, witness, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


x, y, z, c = Reals("x y z c")


def arith(cond):
    def w():
        check(cond)

    return w


# --------------------------------------------------------------------------- trivial programs
@case(
    "misc-empty-sequence-true",
    "true",
    randomized("empty-seq", lambda g: rat(g, Q(1, 64), 10), lambda xx: xx > 0),
)
def _():
    # TRUE: an empty sequence does nothing, so x > 0 stays.
    return T("empty-seq", x > 0, seq(), x > 0)


@case("misc-skip-true", "true", randomized("skip", lambda g: rat(g, Q(1, 64), 10), lambda xx: xx > 0))
def _():
    # TRUE: skip keeps the assumption.
    return T("skip", x > 0, skip(), x > 0)


@case("misc-true-assumptions-false", "false", arith(not (Q(-1) > 0)))
def _():
    # FALSE: x := * may pick -1.
    return T("true-asm", TRUE, havoc(x), x > 0)


@case(
    "misc-false-assumptions-true",
    "true",
    randomized("false-asm", lambda g: rat(g, -9, 9), lambda _xx: not False),
)
def _():
    # TRUE (vacuous): no initial state.
    return T("false-asm", FALSE, assign(x, 1), x == 2)


@case(
    "misc-contradictory-assumptions-true",
    "true",
    randomized("contra", lambda g: rat(g, -9, 9), lambda xx: not (xx > 0 and xx < 0)),
)
def _():
    # TRUE (vacuous): x > 0 ∧ x < 0 is unsatisfiable.
    return T("contra", And(x > 0, x < 0), skip(), x == 7)


@case(
    "misc-test-false-true", "true", randomized("test-false", lambda g: rat(g, -9, 9), lambda _xx: not False)
)
def _():
    # TRUE (vacuous): ?false has no run.
    return T("test-false", x == 0, test(FALSE), x == 7)


@case("misc-guarantee-false-false", "false", arith(Q(0) == 0 and not False))
def _():
    # FALSE: x = 0 is a state where the program runs and `false` fails.
    return T("guar-false", x == 0, skip(), FALSE)


@case("misc-guarantee-true-true", "true", randomized("guar-true", lambda g: rat(g, -9, 9), lambda _xx: True))
def _():
    # TRUE: the guarantee `true` holds after any program.
    return T("guar-true", x == 0, seq(havoc(x), loop(assign(x, x * x - 7))), TRUE)


# --------------------------------------------------------------------------- big and small numbers
BIG = 10**30


@case("misc-huge-constant-true", "true", arith(BIG + 1 > BIG and BIG * BIG >= 10**60))
def _():
    # TRUE: x = 10³⁰: x + 1 > x and x² >= 10⁶⁰.
    return T("huge", x == BIG, skip(), And(x + 1 > x, x * x >= 10**60))


@case("misc-huge-constant-false", "false", arith(not (BIG * BIG > 10**60)))
def _():
    # FALSE: x² = 10⁶⁰ exactly, not more.
    return T("huge-f", x == BIG, skip(), x * x > 10**60)


@case("misc-huge-plus-tiny-false", "false", arith(Q(BIG) + Fraction("1e-30") != BIG))
def _():
    # FALSE: 10³⁰ + 10⁻³⁰ != 10³⁰ in exact arithmetic.
    return T("huge-tiny", x == BIG, assign(y, x + 1e-30), y == x)


@case("misc-tiny-constant-true", "true", arith(Fraction("1e-30") > 0 and Fraction("1e-30") * BIG == 1))
def _():
    # TRUE: x = 10⁻³⁰ > 0 and 10³⁰ x = 1.
    return T("tiny", x == 1e-30, skip(), And(x > 0, BIG * x == 1))


@case("misc-tiny-constant-false", "false", arith(Fraction("1e-30") != 0))
def _():
    # FALSE: 10⁻³⁰ is not 0.
    return T("tiny-f", x == 1e-30, skip(), x == 0)


@case("misc-decimal-floats-true", "true", arith(Fraction("0.1") + Fraction("0.2") == Fraction("0.3")))
def _():
    # TRUE in the DSL's reading: 0.1 + 0.2 = 0.3 as decimals.
    return T("decimals", And(x == 0.1, y == 0.2), skip(), And(x + y == 0.3, 10 * x == 1))


@case("misc-third-as-float-false", "false", arith(3 * Fraction(str(1 / 3)) != 1))
def _():
    # FALSE: the float 1/3 is the decimal 0.3333333333333333, and 3 times it is not 1.
    return T("third", x == 1 / 3, skip(), 3 * x == 1)


@case("misc-sqrt2-as-float-false", "false", arith(Fraction(str(2**0.5)) ** 2 != 2))
def _():
    # FALSE: 1.4142135623730951 squared is not exactly 2.
    return T("sqrt2f", x == 2**0.5, skip(), x * x == 2)


@case("misc-negative-zero-true", "true", arith(Fraction(str(-0.0)) == 0))
def _():
    # TRUE: -0.0 is 0.
    return T("negzero", x == -0.0, skip(), And(x == 0, x >= 0, -x == 0))


@case("misc-infinity-constant-ill", "ill-formed", None)
def _():
    # ILL-FORMED: infinity is not a real number.
    return T("inf", x == float("inf"), skip(), x > 0)


@case("misc-nan-constant-ill", "ill-formed", None)
def _():
    # ILL-FORMED: NaN is not a real number.
    return T("nan", x == float("nan"), skip(), x == x)


@case("misc-python-bool-in-term-ill", "ill-formed", None)
def _():
    # ILL-FORMED: a Python bool is not a number.
    return T("pybool", x == 0, assign(y, x + True), y == 1)


@case("misc-bigint-true", "true", arith(2**64 + 1 > 2**64 and (2**64) ** 2 == 2**128))
def _():
    # TRUE: exact big integers.
    n = Int("n")
    return T("bigint", n == 2**64, skip(), And(n + 1 > n, n * n == 2**128))


# --------------------------------------------------------------------------- many branches, long sequences
@case("misc-twenty-branches-true", "true", arith(all(k <= 19 for k in range(20))))
def _():
    # TRUE: every branch sets x to some k <= 19.
    return T("br20", x == 0, choice(*(branch(f"k{k}", assign(x, k)) for k in range(20))), x <= 19)


@case("misc-twenty-branches-false", "false", arith(not (19 <= 18)))
def _():
    # FALSE: the last branch sets x = 19 > 18.
    return T("br20-f", x == 0, choice(*(branch(f"k{k}", assign(x, k)) for k in range(20))), x <= 18)


@case("misc-duplicate-labels-false", "false", arith(Q(2) != 1))
def _():
    # FALSE: two branches share a label; the second sets x = 2.
    return T("duplab", x == 0, choice(branch("a", assign(x, 1)), branch("a", assign(x, 2))), x == 1)


@case("misc-long-sequence-true", "true", arith(sum(1 for _ in range(60)) == 60))
def _():
    # TRUE: sixty increments from 0.
    return T("seq60", x == 0, seq(*(assign(x, x + 1) for _ in range(60))), x == 60)


@case("misc-long-sequence-false", "false", arith(60 != 59))
def _():
    # FALSE: sixty increments give 60, not 59.
    return T("seq60-f", x == 0, seq(*(assign(x, x + 1) for _ in range(60))), x == 59)


# --------------------------------------------------------------------------- connectives
def w_iff():
    # TRUE: y := x·x + 1 > 0 always, so (x > 0 <-> x > 0 ∧ y > 0).
    g = rng("misc-iff")
    for _ in range(SAMPLES):
        xx = rat(g, -5, 5)
        yy = xx * xx + 1
        check((xx > 0) == (xx > 0 and yy > 0))


@case("misc-iff-true", "true", w_iff)
def _():
    # TRUE: y > 0 always, so the equivalence holds.
    return T("iff", x == x, assign(y, x * x + 1), Iff(x > 0, And(x > 0, y > 0)))


@case("misc-iff-false", "false", arith((Q(0) >= 0) != (Q(0) > 0)))
def _():
    # FALSE: at x = 0, x >= 0 holds but x > 0 does not.
    return T("iff-f", x == x, skip(), Iff(x >= 0, x > 0))


def w_ite():
    # TRUE: the if sets y = 1 when x > 0, else y = -1.
    g = rng("misc-ite")
    for _ in range(SAMPLES):
        xx = rat(g, -5, 5)
        yy = 1 if xx > 0 else -1
        check((yy == 1) if xx > 0 else (yy == -1))


@case("misc-ite-true", "true", w_ite)
def _():
    # TRUE: Ite describes the if.
    return T("ite", x == x, if_(x > 0, assign(y, 1), assign(y, -1)), Ite(x > 0, y == 1, y == -1))


def w_ite_swapped():
    # FALSE: x = 1: the if sets y = 1, and Ite(x > 0, y = -1, y = 1) needs y = -1.
    xx = Q(1)
    yy = 1 if xx > 0 else -1
    check(not ((yy == -1) if xx > 0 else (yy == 1)))


@case("misc-ite-swapped-false", "false", w_ite_swapped)
def _():
    # FALSE: x = 1 gives y = 1, the swapped Ite wants -1.
    return T("ite-f", x == x, if_(x > 0, assign(y, 1), assign(y, -1)), Ite(x > 0, y == -1, y == 1))


@case(
    "misc-nested-implications-true",
    "true",
    randomized(
        "imp",
        lambda g: (rat(g, -5, 5), rat(g, -5, 5)),
        lambda s: not (s[0] > 0) or not (s[1] > 0) or s[0] * s[1] > 0,
    ),
)
def _():
    # TRUE: x > 0 -> (y > 0 -> xy > 0).
    return T("imp", And(x == x, y == y), skip(), Implies(x > 0, Implies(y > 0, x * y > 0)))


@case("misc-double-negation-false", "false", arith(not (Q(0) > 0)))
def _():
    # FALSE: ¬¬(x > 0) is x > 0, false at 0.
    return T("notnot", x >= 0, skip(), Not(Not(x > 0)))


@case("misc-self-square-true", "true", randomized("sq", lambda g: rat(g, -50, 50), lambda xx: xx * xx >= 0))
def _():
    # TRUE: x := x² is nonnegative.
    return T("sq", x == x, assign(x, x * x), x >= 0)


@case(
    "misc-havoc-test-equal-true",
    "true",
    randomized("heq", lambda g: (lambda yy: (yy, yy))(rat(g, -9, 9)), lambda s: s[0] == s[1]),
)
def _():
    # TRUE: x := *; ?x = y leaves x = y.
    return T("heq", y == y, seq(havoc(x), test(x == y)), x == y)


@case("misc-havoc-forgets-false", "false", arith(Q(5) != 0))
def _():
    # FALSE: x := * forgets x = 0 (x = 5).
    return T("hforget", x == 0, havoc(x), x == 0)


# --------------------------------------------------------------------------- annotations
@case(
    "misc-expected-refuted-but-true",
    "true",
    randomized("exp-r", lambda g: rat(g, -50, 50), lambda xx: xx * xx + 1 > 0),
)
def _():
    # TRUE: x² + 1 > 0; the author's `expected="refuted"` must not change the verdict.
    return T("exp-r", x == x, assign(y, x * x + 1), y > 0, expected="refuted")


@case("misc-expected-proved-but-false", "false", arith(not (Q(0) * 0 + 0 > 0)))
def _():
    # FALSE: x = 0 gives y = 0; expected="proved" (the default) must not change that.
    return T("exp-p", x == x, assign(y, x * x), y > 0, expected="proved")


@case("misc-constant-assigned-ill", "ill-formed", None)
def _():
    # ILL-FORMED: c is declared constant but assigned.
    return T("const", c > 0, assign(c, 0), c >= 0, constants=(c,))


def w_or_assumption():
    # FALSE: x = -1 satisfies x > 0 ∨ x < 0 and x > 0 fails.
    check((Q(-1) > 0 or Q(-1) < 0) and not (Q(-1) > 0))


@case("misc-disjunctive-assumption-false", "false", w_or_assumption)
def _():
    # FALSE: the second disjunct allows negative x.
    return T("or-asm", Or(x > 0, x < 0), skip(), x > 0)


@case(
    "misc-zeroth-power-true",
    "true",
    randomized("pow0", lambda g: rat(g, Q(1, 64), 50), lambda xx: xx**0 == 1),
)
def _():
    # TRUE: x⁰ = 1 for x > 0.
    return T("pow0", x > 0, skip(), x**0 == 1)


# --------------------------------------------------------------------------- abbreviations
# Theorem.abbreviations let the prover rewrite atoms in named quantities: a generalisation
# that must never make a false claim provable, whatever the SSA versions and indices.

B = IndexSort("B")
i, j, bb = Var("i", B), Var("j", B), Var("b", B)
F, G = Family("F", B), Family("G", B)


@case("misc-abbrev-after-havoc-false", "false", arith(Q(-1) - 0 < 0))
def _():
    # FALSE: x - y >= 0 initially, then x := y - 1 (x := * picks it): x - y = -1.
    return T("abbr-h", x - y >= 0, havoc(x), x - y >= 0, abbreviations={"d": x - y})


def w_abbrev_guarded():
    # TRUE: the test re-establishes x >= y after x := *.
    g = rng("abbr-h-t")
    for _ in range(SAMPLES):
        yy = rat(g, -5, 5)
        xx = yy + rat(g, 0, 5)  # the choices that pass ?x >= y
        check(xx - yy >= 0)


@case("misc-abbrev-after-havoc-guarded-true", "true", w_abbrev_guarded)
def _():
    # TRUE: x := *; ?x >= y keeps x - y >= 0.
    return T("abbr-h-t", x - y >= 0, seq(havoc(x), test(x >= y)), x - y >= 0, abbreviations={"d": x - y})


@case("misc-abbrev-loop-false", "false", arith(Q(-1) >= -1 and not (Q(-1) >= 0)))
def _():
    # FALSE: one iteration picks x = y - 1 (passes ?x - y >= -1), violating x - y >= 0.
    return T(
        "abbr-loop",
        x - y >= 0,
        loop(seq(havoc(x), test(x - y >= -1)), invariant=x - y >= -1),
        x - y >= 0,
        abbreviations={"d": x - y},
    )


def w_abbrev_family_false():
    # FALSE: one element e with F(e) = G(e) = 0: F(e) := G(e) - 1 gives F(e) - G(e) = -1.
    f, g_ = {0: Q(0)}, {0: Q(0)}
    check(f[0] - g_[0] >= 0)
    f[0] = g_[0] - 1
    check(not (f[0] - g_[0] >= 0))


@case("misc-abbrev-family-false", "false", w_abbrev_family_false)
def _():
    # FALSE: lowering F(i) below G(i) breaks ∀j F(j) - G(j) >= 0 (abbreviation d(b) = F(b) - G(b)).
    return T(
        "abbr-fam",
        And(i == i, ForAll(j, F(j) - G(j) >= 0)),
        assign(F(i), G(i) - 1),
        ForAll(j, F(j) - G(j) >= 0),
        abbreviations={"d": F(bb) - G(bb)},
    )


def w_abbrev_family_true():
    # TRUE: F(i) := G(i) + 1 keeps F - G >= 0 at i, and other elements are untouched.
    g = rng("abbr-fam-t")
    for _ in range(SAMPLES):
        size = int(g.integers(1, 6))
        gg = {e: rat(g, -5, 5) for e in range(size)}
        ff = {e: gg[e] + rat(g, 0, 3) for e in range(size)}
        ii = int(g.integers(0, size))
        ff[ii] = gg[ii] + 1
        check(all(ff[e] - gg[e] >= 0 for e in range(size)))


@case("misc-abbrev-family-true", "true", w_abbrev_family_true)
def _():
    # TRUE: the update keeps every difference nonnegative.
    return T(
        "abbr-fam-t",
        And(i == i, ForAll(j, F(j) - G(j) >= 0)),
        assign(F(i), G(i) + 1),
        ForAll(j, F(j) - G(j) >= 0),
        abbreviations={"d": F(bb) - G(bb)},
    )


@case("misc-abbrev-product-false", "false", arith(Q(1) * 1 >= 1 and not (Q(1) * 0 >= 1)))
def _():
    # FALSE: x = y = 1, then y := y - 1 gives xy = 0 < 1 (abbreviation e = xy).
    return T("abbr-prod", And(x * y >= 1, x > 0), assign(y, y - 1), x * y >= 1, abbreviations={"e": x * y})
