"""Theme 7: quantifiers and modalities inside assumptions and guarantees (∀/∃ over reals,
ints, index sorts and Bools; [a]P and <a>P on either side, nested)."""

from __future__ import annotations

import math

from certiloop.models import (
    And,
    Bool,
    Box,
    Diamond,
    Exists,
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
    havoc,
    loop,
    ode,
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


x, y, z, v = Reals("x y z v")
n, k = Ints("n k")
B = IndexSort("B")
i, j = Var("i", B), Var("j", B)
F = Family("F", B)


def arith(cond):
    def w():
        check(cond)

    return w


# --------------------------------------------------------------------------- ∀ / ∃ in assumptions
def w_fa_true():
    # TRUE: ∀y. x <= y² includes y = 0, so x <= 0.
    g = rng("q-fa")
    for _ in range(SAMPLES):
        xx = -rat(g, 0, 10)  # states satisfying the assumption are exactly x <= 0
        check(all(xx <= yy * yy for yy in (Q(0), Q(1, 3), Q(-2))) and xx <= 0)


@case("q-forall-assumption-true", "true", w_fa_true)
def _():
    # TRUE: ∀y (x <= y²) forces x <= 0.
    return T("q-fa", ForAll(y, x <= y * y), skip(), x <= 0)


@case(
    "q-forall-assumption-false",
    "false",
    arith(all(Q(1) <= yy * yy + 1 for yy in (Q(0), Q(1), Q(-1, 2))) and not (Q(1) <= 0)),
)
def _():
    # FALSE: x = 1 satisfies ∀y (x <= y² + 1) (min at y = 0), and 1 <= 0 fails.
    return T("q-fa-f", ForAll(y, x <= y * y + 1), skip(), x <= 0)


def w_ex_true():
    # TRUE: x = y² with y > 0 is positive.
    g = rng("q-ex")
    for _ in range(SAMPLES):
        yy = rat(g, Q(1, 64), 10)
        check(yy * yy > 0)


@case("q-exists-assumption-true", "true", w_ex_true)
def _():
    # TRUE: ∃y (y > 0 ∧ x = y²) gives x > 0.
    return T("q-ex", Exists(y, And(y > 0, x == y * y)), skip(), x > 0)


@case("q-exists-assumption-false", "false", arith(Q(1, 2) ** 2 == Q(1, 4) and not (Q(1, 4) > 1)))
def _():
    # FALSE: y = 1/2 gives x = 1/4, not > 1.
    return T("q-ex-f", Exists(y, And(y > 0, x == y * y)), skip(), x > 1)


# --------------------------------------------------------------------------- ∃ in guarantees
def w_sqrt_true():
    # TRUE: y = √x works for every x >= 0.
    g = rng("q-sqrt")
    for _ in range(SAMPLES):
        xx = float(rat(g, 0, 100))
        check(abs(math.sqrt(xx) ** 2 - xx) <= 1e-9 * max(1, xx))


@case("q-exists-guarantee-sqrt-true", "true", w_sqrt_true)
def _():
    # TRUE: every x >= 0 has a square root.
    return T("q-sqrt", x >= 0, skip(), Exists(y, y * y == x))


def w_no_sqrt_neg1():
    # FALSE: x = -1 satisfies x >= -1, and y² >= 0 > -1 for every real y (sampled below).
    check(Q(-1) >= -1)
    g = rng("q-sqrt-f")
    for _ in range(SAMPLES):
        yy = rat(g, -100, 100)
        check(yy * yy >= 0 > -1)


@case("q-exists-guarantee-sqrt-false", "false", w_no_sqrt_neg1)
def _():
    # FALSE: x = -1 is allowed and no real y has y² = -1 (y² >= 0).
    return T("q-sqrt-f", x >= -1, skip(), Exists(y, y * y == x))


@case("q-forall-exists-true", "true", randomized("q-fe", lambda g: rat(g, -100, 100), lambda yy: yy + 1 > yy))
def _():
    # TRUE: ∀y ∃z. z > y (take z = y + 1).
    return T("q-fe", x == 0, skip(), And(x == 0, ForAll(y, Exists(z, z > y))))


def w_no_max():
    # FALSE: whatever z, the y = z instance of ∀y. z > y fails.
    g = rng("q-ef")
    for _ in range(SAMPLES):
        zz = rat(g, -100, 100)
        check(not (zz > zz))


@case("q-exists-forall-false", "false", w_no_max)
def _():
    # FALSE: no z is above every y (y = z fails).
    return T("q-ef", x == 0, skip(), And(x == 0, Exists(z, ForAll(y, z > y))))


def w_sqrt2():
    # TRUE: y = √2 > 0 with y² = 2.
    check(abs(math.sqrt(2) ** 2 - 2) < 1e-12 and math.sqrt(2) > 0)


@case("q-exists-irrational-witness-true", "true", w_sqrt2)
def _():
    # TRUE: the witness is √2 (irrational).
    return T("q-sqrt2", x == 2, skip(), Exists(y, And(y > 0, y * y == x)))


# --------------------------------------------------------------------------- Int quantifiers
def w_int_fa():
    # TRUE: 0 <= k <= n -> k² <= n².
    check(all(kk * kk <= nn * nn for nn in range(0, 60) for kk in range(0, nn + 1)))


@case("q-int-forall-true", "true", w_int_fa)
def _():
    # TRUE: squares are monotone on [0, n].
    return T("q-int-fa", n >= 0, skip(), ForAll(k, Implies(And(0 <= k, k <= n), k * k <= n * n)))


@case("q-int-forall-false", "false", arith(not (0 * 0 < 0 * 0)))
def _():
    # FALSE: k = n violates k² < n² (n = 0, k = 0).
    return T("q-int-fa-f", n >= 0, skip(), ForAll(k, Implies(And(0 <= k, k <= n), k * k < n * n)))


@case("q-int-exists-true", "true", arith(2 * 2 == 4))
def _():
    # TRUE: n = 4 = 2·2.
    return T("q-int-ex", n == 4, skip(), Exists(k, 2 * k == n))


@case("q-int-exists-false", "false", arith(all(2 * kk != 3 for kk in range(-100, 101))))
def _():
    # FALSE: 3 is odd.
    return T("q-int-ex-f", n == 3, skip(), Exists(k, 2 * k == n))


# --------------------------------------------------------------------------- index sorts, Bools
@case(
    "q-index-forall-true",
    "true",
    randomized(
        "q-idx",
        lambda g: (lambda n_: ({e: rat(g, Q(1, 64), 5) for e in range(n_)}, rint(g, 0, n_ - 1)))(
            rint(g, 1, 6)
        ),
        lambda s: s[0][s[1]] > 0,
    ),
)
def _():
    # TRUE: ∀j F(j) > 0 -> F(i) > 0.
    return T("q-idx", And(i == i, ForAll(j, F(j) > 0)), skip(), F(i) > 0)


@case("q-index-exists-false", "false", arith(Q(1) > 0 and not (Q(-1) > 0)))
def _():
    # FALSE: family {e1, e2} with F(e1) = 1, F(e2) = -1, i = e2.
    return T("q-idx-f", And(i == i, Exists(j, F(j) > 0)), skip(), F(i) > 0)


@case(
    "q-bool-exists-contradiction-true",
    "true",
    arith(not any(c and not c for c in (True, False))),
    may_reject=True,  # the DSL may refuse quantifiers over Bool symbols (a language restriction)
)
def _():
    # TRUE (vacuous): no Bool c is both true and false.
    c = Bool("c")
    return T("q-bool", And(x == 0, Exists(c, And(c, Not(c)))), skip(), x == 1)


# --------------------------------------------------------------------------- modalities
def w_dia_incr():
    # TRUE: x > 0 -> x + 1 > 1.
    g = rng("q-dia")
    for _ in range(SAMPLES):
        xx = rat(g, Q(1, 64), 10)
        check(xx + 1 > 1)


@case("q-diamond-assign-true", "true", w_dia_incr)
def _():
    # TRUE: <x := x + 1> x > 1 from x > 0.
    return T("q-dia", x > 0, skip(), Diamond(assign(x, x + 1), x > 1))


@case("q-diamond-choice-false", "false", arith(Q(1) != 3 and Q(2) != 3))
def _():
    # FALSE: neither branch makes x = 3.
    return T("q-dia-f", x == 0, skip(), Diamond(choice(assign(x, 1), assign(x, 2)), x == 3))


@case("q-diamond-ode-reach-true", "true", arith(Q(0) + 5 >= 5))
def _():
    # TRUE: following x' = 1 for 5 s reaches 5.
    return T("q-dia-ode", x == 0, skip(), Diamond(ode({x: 1}), x >= 5))


def w_dia_blocked():
    # FALSE: a run of duration τ needs x(τ) = τ <= 3 (domain at the end), so x <= 3 < 5.
    g = rng("q-dia-ode-f")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 10)
        check(tau > 3 or tau < 5)


@case("q-diamond-ode-domain-blocks-false", "false", w_dia_blocked)
def _():
    # FALSE: inside x <= 3 every reachable state has x <= 3 < 5.
    return T("q-dia-ode-f", x == 0, skip(), Diamond(ode({x: 1}, x <= 3), x >= 5))


def w_no_run():
    # FALSE: y² = -1 has no real solution (y² >= 0), so the diamond has no run.
    g = rng("q-dia-none")
    for _ in range(SAMPLES):
        yy = rat(g, -100, 100)
        check(yy * yy != -1)


@case("q-diamond-no-run-false", "false", w_no_run)
def _():
    # FALSE: ?y² = -1 has no run, so <..> anything is false.
    return T("q-dia-none", x == 0, skip(), Diamond(seq(havoc(y), test(y * y == -1)), x == x))


def w_box_asm_true():
    # TRUE: [x' = v] x >= 0 from x = 0 means v·τ >= 0 for all τ >= 0 (τ = 1: v >= 0).
    check(all((vv * 1 >= 0) == (vv >= 0) for vv in (Q(-1), Q(0), Q(2))))


@case("q-box-ode-assumption-true", "true", w_box_asm_true)
def _():
    # TRUE: an assumption that every flow stays nonnegative forces v >= 0.
    return T("q-box-asm", And(x == 0, Box(ode({x: v}), x >= 0)), skip(), v >= 0)


def w_box_v0():
    # FALSE: x = 0, v = 0: every flow keeps x = 0 >= -1 (the assumption holds), and v > 0 fails.
    g = rng("q-box-asm-f")
    for _ in range(SAMPLES):
        check(0 + 0 * rat(g, 0, 100) >= -1)
    check(not (Q(0) > 0))


@case("q-box-ode-assumption-false", "false", w_box_v0)
def _():
    # FALSE: v = 0 satisfies [x' = v] x >= -1 from x = 0, and v > 0 fails.
    return T("q-box-asm-f", And(x == 0, Box(ode({x: v}), x >= -1)), skip(), v > 0)


@case(
    "q-box-havoc-guarantee-true",
    "true",
    randomized("q-box-h", lambda g: rat(g, -100, 100), lambda yy: yy * yy >= 0),
)
def _():
    # TRUE: [y := *] y² >= 0.
    return T("q-box-h", x == 0, skip(), And(x == 0, Box(havoc(y), y * y >= 0)))


@case("q-box-assign-guarantee-false", "false", arith(not (Q(0) - 1 >= 0)))
def _():
    # FALSE: x = 0 -> [x := x - 1] x >= 0 fails.
    return T("q-box-a", x >= 0, skip(), Box(assign(x, x - 1), x >= 0))


def w_box_or():
    # FALSE: x = 0: y = -1 violates y >= x and z = 2 violates z <= x + 1.
    check(not (Q(-1) >= 0) and not (Q(2) <= 0 + 1))


@case("q-box-or-box-false", "false", w_box_or)
def _():
    # FALSE: neither [y := *] y >= x nor [z := *] z <= x + 1 holds (y = x - 1, z = x + 2).
    return T("q-box-or", x == 0, skip(), Or(Box(havoc(y), y >= x), Box(havoc(z), z <= x + 1)))


@case(
    "q-box-or-box-true", "true", randomized("q-box-or", lambda g: rat(g, -100, 100), lambda zz: zz * zz >= 0)
)
def _():
    # TRUE: the second disjunct [z := *] z² >= 0 holds.
    return T("q-box-or-t", x == 0, skip(), Or(Box(havoc(y), y >= x), Box(havoc(z), z * z >= 0)))


@case(
    "q-dia-of-box-true", "true", randomized("q-dia-box", lambda g: rat(g, -100, 100), lambda zz: 0 <= zz * zz)
)
def _():
    # TRUE: <y := *>[z := *] y <= z² with y = 0.
    return T("q-dia-box", x == 0, skip(), Diamond(havoc(y), Box(havoc(z), y <= z * z)))


def w_dia_box_f():
    # FALSE: for every y the choice z = y - 1 violates y <= z.
    g = rng("q-dia-box-f")
    for _ in range(SAMPLES):
        yy = rat(g, -100, 100)
        check(not (yy <= yy - 1))


@case("q-dia-of-box-false", "false", w_dia_box_f)
def _():
    # FALSE: no y is below every z (z = y - 1).
    return T("q-dia-box-f", x == 0, skip(), Diamond(havoc(y), Box(havoc(z), y <= z)))


@case("q-forall-over-havocked-box-false", "false", arith(not (Q(-1) > 0)))
def _():
    # FALSE: ∀y (y > 0 -> [y := *] y > 0) fails: the box picks y = -1.
    return T("q-fa-box", x == 0, skip(), ForAll(y, Implies(y > 0, Box(havoc(y), y > 0))))


@case(
    "q-box-left-of-implication-true",
    "true",
    randomized("q-box-imp", lambda g: rat(g, -100, 100), lambda xx: not (xx + 1 <= xx)),
)
def _():
    # TRUE: [y := *] y <= x is false, so the implication holds.
    return T("q-box-imp", x == 0, skip(), Implies(Box(havoc(y), y <= x), x > 5))


@case("q-diamond-left-of-implication-false", "false", arith(Q(0) <= 0 and not (Q(0) > 5)))
def _():
    # FALSE: <y := *> y <= x holds (y = x), and x > 5 fails at x = 0.
    return T("q-dia-imp", x == 0, skip(), Implies(Diamond(havoc(y), y <= x), x > 5))


def w_box_ode_guar():
    # TRUE: x = v τ >= 0 for v >= 0, τ >= 0.
    g = rng("q-box-ode")
    for _ in range(SAMPLES):
        check(rat(g, 0, 10) * rat(g, 0, 10) >= 0)


@case("q-box-ode-guarantee-true", "true", w_box_ode_guar)
def _():
    # TRUE: [x' = v] x >= 0 from x = 0 with v >= 0.
    return T("q-box-ode", And(x == 0, v >= 0), skip(), Box(ode({x: v}), x >= 0))


@case("q-box-in-loop-invariant-true", "true", arith(all(i_ >= 0 for i_ in range(30))))
def _():
    # TRUE: x only grows from 0; the invariant [y := x] y >= 0 is x >= 0.
    return T("q-box-inv", x == 0, loop(assign(x, x + 1), invariant=Box(assign(y, x), y >= 0)), x >= 0)


@case("q-box-after-program-false", "false", arith(not (Q(1) + 1 <= 1)))
def _():
    # FALSE: after x := 1, [x := x + 1] x <= 1 fails.
    return T("q-box-after", x == 0, assign(x, 1), Box(assign(x, x + 1), x <= 1))
