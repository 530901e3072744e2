"""Theme 9: nonlinear arithmetic and algebraic numbers — counterexamples that need √2, ∛2
or the golden ratio; true polynomial inequalities (AM-GM, Motzkin, perfect powers) and
their subtly false neighbours. Algebraic witnesses are exact (sympy, no certiloop)."""

from __future__ import annotations

import sympy

from certiloop.models import And, Or, Reals, Theorem, havoc, ode, seq, skip, test

from .harness import SAMPLES, Case, Q, check, rat, rng

CASES: list[Case] = []


def case(id, truth, witness, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


x, y, a, b, c, t = Reals("x y a b c t")
S2 = sympy.sqrt(2)


def exact(cond):
    """A sympy boolean decided exactly."""

    def w():
        check(bool(sympy.simplify(cond)) is True, cond)

    return w


def all_of(*conds):
    def w():
        for cnd in conds:
            check(bool(sympy.simplify(cnd)) is True, cnd)

    return w


# --------------------------------------------------------------------------- √2
@case("nl-sqrt2-fourth-power-true", "true", all_of(sympy.expand(S2**4) == 4, sympy.expand((-S2) ** 4) == 4))
def _():
    # TRUE: x² = 2 -> x⁴ = 4.
    return T("sq2-4", x == x, seq(havoc(x), test(x * x == 2)), x**4 == 4)


@case("nl-sqrt2-sign-false", "false", all_of(sympy.expand((-S2) ** 2) == 2, -S2 < 0))
def _():
    # FALSE: x = -√2 passes the test and is negative.
    return T("sq2-sign", x == x, seq(havoc(x), test(x * x == 2)), x > 0)


@case("nl-sqrt2-upper-false", "false", all_of(S2 > sympy.Rational(14142, 10000)))
def _():
    # FALSE: √2 = 1.41421... > 1.4142 (the counterexample is irrational).
    return T("sq2-up", And(x * x == 2, x > 0), skip(), x <= Q(14142, 10000))


@case(
    "nl-sqrt2-bracket-true",
    "true",
    all_of(sympy.Rational(14142, 10000) ** 2 < 2, sympy.Rational(14143, 10000) ** 2 > 2),
)
def _():
    # TRUE: 1.4142² < 2 < 1.4143², so √2 lies strictly between.
    return T("sq2-br", And(x * x == 2, x > 0), skip(), And(x > Q(14142, 10000), x < Q(14143, 10000)))


@case(
    "nl-sqrt2-two-roots-differ-false",
    "false",
    all_of(sympy.expand(S2**2) == 2, sympy.expand((-S2) ** 2) == 2, S2 != -S2),
)
def _():
    # FALSE: x = √2, y = -√2.
    return T("sq2-xy", And(x * x == 2, y * y == 2), skip(), x == y)


@case(
    "nl-sqrt2-two-roots-up-to-sign-true",
    "true",
    all_of(*(sympy.Or(sympy.Eq(xx, yy), sympy.Eq(xx, -yy)) for xx in (S2, -S2) for yy in (S2, -S2))),
)
def _():
    # TRUE: x² = y² means (x - y)(x + y) = 0.
    return T("sq2-xy-t", And(x * x == 2, y * y == 2), skip(), Or(x == y, x == -y))


@case("nl-sqrt2-not-rational-true", "true", all_of(Q(7, 5) ** 2 != 2, Q(-7, 5) ** 2 != 2))
def _():
    # TRUE: 7/5 squared is 49/25 != 2.
    return T("sq2-rat", x * x == 2, skip(), x != Q(7, 5))


@case("nl-sqrt2-product-false", "false", all_of(sympy.expand(S2 * -S2) == -2))
def _():
    # FALSE: x = √2, y = -√2 gives xy = -2, not 2.
    return T("sq2-prod", And(x * x == 2, y * y == 2), skip(), x * y == 2)


# --------------------------------------------------------------------------- ∛2, golden ratio
C2 = sympy.root(2, 3)


@case(
    "nl-cbrt2-lower-true",
    "true",
    all_of(*(r > sympy.Rational(5, 4) for r in sympy.real_roots(sympy.Symbol("w") ** 3 - 2))),
)
def _():
    # TRUE: 1.25³ = 1.953 < 2, so the real cube root of 2 exceeds 1.25 (x³ increasing).
    return T("cb2", x**3 == 2, skip(), x > Q(5, 4))


@case("nl-cbrt2-upper-false", "false", all_of(C2**3 == 2, C2 < sympy.Rational(126, 100)))
def _():
    # FALSE: 1.26³ = 2.000376 > 2, so ∛2 < 1.26.
    return T("cb2-f", x**3 == 2, skip(), x > Q(126, 100))


PHI_NEG = (1 - sympy.sqrt(5)) / 2


@case(
    "nl-golden-negative-root-false", "false", all_of(sympy.expand(PHI_NEG**2 - PHI_NEG - 1) == 0, PHI_NEG < 0)
)
def _():
    # FALSE: x = (1 - √5)/2 ≈ -0.618 solves x² = x + 1 and is negative.
    return T("gold", x * x == x + 1, skip(), x > 0)


@case("nl-golden-roots-bracket-true", "true", all_of(PHI_NEG > -1, (1 + sympy.sqrt(5)) / 2 < 2))
def _():
    # TRUE: both roots (1 ± √5)/2 lie in (-1, 2).
    return T("gold-t", x * x == x + 1, skip(), And(x > -1, x < 2))


# --------------------------------------------------------------------------- inequalities
def sampled(pred, pre=lambda *_: True, lo=-10, hi=10, arity=2, den=64):
    def w():
        g = rng(f"nl-{pred.__name__}-{lo}-{hi}")
        for _ in range(SAMPLES):
            vals = [rat(g, lo, hi, den) for _k in range(arity)]
            if pre(*vals):
                check(pred(*vals), vals)

    return w


def amgm(xx, yy):
    return (xx + yy) ** 2 >= 4 * xx * yy


@case("nl-amgm-true", "true", sampled(amgm))
def _():
    # TRUE: (x + y)² - 4xy = (x - y)² >= 0.
    return T("amgm", And(x == x, y == y), skip(), (x + y) ** 2 >= 4 * x * y)


def cubes(xx, yy):
    return xx**3 + yy**3 >= xx**2 * yy + xx * yy**2


@case("nl-sum-of-cubes-true", "true", sampled(cubes, pre=lambda xx, yy: xx + yy >= 0))
def _():
    # TRUE: x³ + y³ - x²y - xy² = (x + y)(x - y)² >= 0 when x + y >= 0.
    return T("cubes", x + y >= 0, skip(), x**3 + y**3 >= x**2 * y + x * y**2)


@case("nl-sum-of-cubes-false", "false", all_of(not cubes(Q(-2), Q(0))))
def _():
    # FALSE: x = -2, y = 0: -8 >= 0 fails (x + y >= 0 dropped).
    return T("cubes-f", And(x == x, y == y), skip(), x**3 + y**3 >= x**2 * y + x * y**2)


def quartic(xx):
    return xx**4 - 4 * xx**3 + 6 * xx**2 - 4 * xx + 1 >= 0


@case("nl-perfect-fourth-power-true", "true", sampled(quartic, arity=1))
def _():
    # TRUE: the polynomial is (x - 1)⁴.
    return T("quart", x == x, skip(), x**4 - 4 * x**3 + 6 * x**2 - 4 * x + 1 >= 0)


@case(
    "nl-perfect-fourth-power-shifted-false",
    "false",
    all_of(Q(1) ** 4 - 4 * Q(1) ** 3 + 6 * Q(1) ** 2 - 4 * Q(1) + Q(99, 100) < 0),
)
def _():
    # FALSE: (x - 1)⁴ - 1/100 is negative at x = 1.
    return T("quart-f", x == x, skip(), x**4 - 4 * x**3 + 6 * x**2 - 4 * x + Q(99, 100) >= 0)


def motzkin(xx, yy):
    return xx**4 * yy**2 + xx**2 * yy**4 - 3 * xx**2 * yy**2 + 1 >= 0


@case("nl-motzkin-true", "true", sampled(motzkin, lo=-3, hi=3))
def _():
    # TRUE: Motzkin's polynomial is nonnegative (AM-GM on x⁴y², x²y⁴, 1), though not a sum of squares.
    return T("motzkin", And(x == x, y == y), skip(), x**4 * y**2 + x**2 * y**4 - 3 * x**2 * y**2 + 1 >= 0)


@case("nl-motzkin-shifted-false", "false", all_of(1 + 1 - 3 + Q(99, 100) < 0))
def _():
    # FALSE: at x = y = 1 the value is 1 + 1 - 3 + 0.99 < 0.
    return T(
        "motzkin-f",
        And(x == x, y == y),
        skip(),
        x**4 * y**2 + x**2 * y**4 - 3 * x**2 * y**2 + Q(99, 100) >= 0,
    )


@case(
    "nl-product-positive-true",
    "true",
    sampled(lambda xx, yy: xx * yy > 0, pre=lambda xx, yy: xx > 0 and yy > 0),
)
def _():
    # TRUE: product of positives.
    return T("prod", And(x > 0, y > 0), skip(), x * y > 0)


@case("nl-product-nonnegative-false", "false", all_of(not (Q(1) * 0 > 0)))
def _():
    # FALSE: y = 0 makes xy = 0.
    return T("prod-f", And(x > 0, y >= 0), skip(), x * y > 0)


def disc(aa, bb, cc, xx):
    return aa * xx * xx + bb * xx + cc > 0


def w_disc():
    # TRUE: a > 0 and b² < 4ac: a x² + b x + c = a (x + b/2a)² + (4ac - b²)/4a > 0.
    g = rng("nl-disc")
    for _ in range(SAMPLES):
        aa, bb, xx = rat(g, Q(1, 8), 5), rat(g, -5, 5), rat(g, -10, 10)
        cc = bb * bb / (4 * aa) + rat(g, Q(1, 64), 5)  # makes b² < 4ac by construction
        check(bb * bb < 4 * aa * cc and disc(aa, bb, cc, xx))


@case("nl-discriminant-negative-true", "true", w_disc)
def _():
    # TRUE: no real root when the discriminant is negative and a > 0.
    return T("disc", And(a > 0, b * b < 4 * a * c, x == x), skip(), a * x * x + b * x + c > 0)


@case(
    "nl-discriminant-zero-false", "false", all_of(Q(2) ** 2 <= 4 * 1 * 1, not disc(Q(1), Q(2), Q(1), Q(-1)))
)
def _():
    # FALSE: a = 1, b = 2, c = 1 (b² = 4ac), x = -1 gives 0.
    return T("disc-f", And(a > 0, b * b <= 4 * a * c, x == x), skip(), a * x * x + b * x + c > 0)


@case("nl-high-degree-true", "true", sampled(lambda xx: (xx * xx + 1) ** 5 >= 1, arity=1))
def _():
    # TRUE: (x² + 1)⁵ >= 1.
    return T("deg10", x == x, skip(), (x * x + 1) ** 5 >= 1)


# --------------------------------------------------------------------------- irrational durations
@case("nl-ode-irrational-crossing-false", "false", all_of(S2 >= 0, sympy.expand(S2**2) == 2))
def _():
    # FALSE: x' = 2t, t' = 1 from 0: x = t², which equals 2 at the irrational time √2.
    return T("ode-irr", And(x == 0, t == 0), ode({x: 2 * t, t: 1}), x != 2)


def w_irr_dom():
    # TRUE: x = s² with the domain x <= 2, and t = s: t² = x <= 2.
    g = rng("nl-irr-dom")
    for _ in range(SAMPLES):
        s = rat(g, 0, Q(14142, 10000))  # durations with s² <= 2
        check(s * s <= 2)


@case("nl-ode-irrational-domain-true", "true", w_irr_dom)
def _():
    # TRUE: the domain x <= 2 stops the flow at t = √2.
    return T("ode-irr-t", And(x == 0, t == 0), ode({x: 2 * t, t: 1}, x <= 2), t * t <= 2)


@case("nl-ode-irrational-domain-false", "false", all_of(S2 > sympy.Rational(14142, 10000)))
def _():
    # FALSE: the flow may run to t = √2 > 1.4142.
    return T("ode-irr-f", And(x == 0, t == 0), ode({x: 2 * t, t: 1}, x <= 2), t <= Q(14142, 10000))
