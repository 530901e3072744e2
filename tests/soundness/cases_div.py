"""Theme 3: division and well-definedness.

A theorem that divides by something that can be 0 where it is evaluated is ill-formed: no
verdict about it means anything (z3 reads x/0 as an arbitrary number), so it must be
rejected (or left unknown), never proved or refuted. Divisions that are guarded (the divisor
is provably nonzero where it is evaluated) are fine and must not be held against a theorem.
Witnesses of ill-formed cases exhibit a reachable state whose divisor is 0."""

from __future__ import annotations

from certiloop.models import (
    And,
    Box,
    Diamond,
    Exists,
    ForAll,
    Ints,
    Reals,
    Theorem,
    assign,
    choice,
    havoc,
    loop,
    ode,
    seq,
    skip,
    test,
)

from .harness import SAMPLES, Case, Q, check, rat, rint, rng

CASES: list[Case] = []


def case(id, truth, witness, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


x, y, b, c, t = Reals("x y b c t")
n, m = Ints("n m")


def zero_reachable(*conds):
    """Ill-formedness witness: the listed facts hold together with a zero divisor."""

    def w():
        check(all(conds), "the state with a zero divisor must satisfy the assumptions")

    return w


# --------------------------------------------------------------------------- plain divisions
def w_recip_pos():
    # TRUE: b > 0 -> 1/b > 0.
    g = rng("div-recip")
    for _ in range(SAMPLES):
        bb = rat(g, Q(1, 64), 100)
        check(1 / bb > 0)


@case("div-assign-safe-true", "true", w_recip_pos)
def _():
    # TRUE: y := 1/b with b > 0 gives y > 0.
    return T("div-assign", b > 0, assign(y, 1 / b), y > 0)


@case("div-assign-maybe-zero-ill", "ill-formed", zero_reachable(Q(0) >= 0))
def _():
    # ILL-FORMED: b >= 0 allows b = 0, and y := 1/b divides by it.
    return T("div-assign-0", b >= 0, assign(y, 1 / b), y >= 0)


@case("div-test-unconstrained-ill", "ill-formed", zero_reachable(True))
def _():
    # ILL-FORMED: the test 1/b > 0 is evaluated at b = 0 for some initial state.
    return T("div-test-0", x == 0, test(1 / b > 0), x == 0)


@case("div-guarantee-safe-true", "true", w_recip_pos)
def _():
    # TRUE: the guarantee 1/b > 0 is well-defined (b > 0) and holds.
    return T("div-guar", b > 0, skip(), 1 / b > 0)


def w_recip_lt1():
    # FALSE: b = 1/2: 1/b = 2, not < 1.
    check(Q(1, 2) > 0 and not (1 / Q(1, 2) < 1))


@case("div-guarantee-false", "false", w_recip_lt1)
def _():
    # FALSE: 1/b < 1 fails for b = 1/2.
    return T("div-guar-f", b > 0, skip(), 1 / b < 1)


# --------------------------------------------------------------------------- under binders/modalities
@case("div-forall-shadows-safe-name-ill", "ill-formed", zero_reachable(True))
def _():
    # ILL-FORMED: the bound b of ∀b. b*(1/b) = 1 ranges over 0 (the free b > 0 is another symbol).
    return T("div-forall-shadow", And(b > 0, x > 0, ForAll(b, b * (1 / b) == 1)), skip(), x > 1)


@case("div-forall-unguarded-ill", "ill-formed", zero_reachable(True))
def _():
    # ILL-FORMED: ∀c. c*(1/c) = 1 divides by c = 0.
    return T("div-forall", And(x > 0, ForAll(c, c * (1 / c) == 1)), skip(), x > 1)


@case("div-exists-guarantee-shadow-ill", "ill-formed", zero_reachable(True))
def _():
    # ILL-FORMED: the guarantee ∃b. b*(1/b) = 0 can only hold at b = 0, where it divides by 0.
    return T("div-exists-shadow", And(b > 0, x > 0), skip(), Exists(b, b * (1 / b) == 0))


@case("div-box-assumption-ill", "ill-formed", zero_reachable(Q(0) == 0))
def _():
    # ILL-FORMED: [b := 0](b*(1/b) = 1) in the assumptions divides by 0.
    return T("div-box-asm", And(b > 0, x > 0, Box(assign(b, 0), b * (1 / b) == 1)), skip(), x > 1)


@case("div-diamond-assumption-ill", "ill-formed", zero_reachable(Q(0) == 0))
def _():
    # ILL-FORMED: <b := 0>(b*(1/b) = 1) divides by 0.
    return T("div-dia-asm", And(b > 0, x > 0, Diamond(assign(b, 0), b * (1 / b) == 1)), skip(), x > 1)


@case("div-box-guarantee-writes-divisor-ill", "ill-formed", zero_reachable(Q(1) > 0, Q(1) - 1 == 0))
def _():
    # ILL-FORMED: [b := b - 1](1/b > 0) with b = 1 divides by 0 inside the box.
    return T("div-box-guar", b > 0, skip(), Box(assign(b, b - 1), 1 / b > 0))


@case("div-box-guarantee-zero-product-ill", "ill-formed", zero_reachable(Q(1) > 0, Q(1) - 1 == 0))
def _():
    # ILL-FORMED: [b := b - 1](b*(1/b) = 1) at b = 1 is 0*(1/0).
    return T("div-box-guar2", b > 0, skip(), Box(assign(b, b - 1), b * (1 / b) == 1))


# --------------------------------------------------------------------------- ODEs
def w_ode_rhs():
    # TRUE: x = s/b and t = s <= 1, so x <= 1/b.
    g = rng("div-ode")
    for _ in range(SAMPLES):
        bb, s = rat(g, Q(1, 16), 10), rat(g, 0, 1)
        check(s / bb <= 1 / bb)


@case("div-ode-rhs-safe-true", "true", w_ode_rhs)
def _():
    # TRUE: x' = 1/b with b > 0 constant, for at most 1 s from x = 0.
    return T("div-ode", And(b > 0, x == 0, t == 0), ode({x: 1 / b, t: 1}, t <= 1), x <= 1 / b)


@case("div-ode-rhs-divisor-evolves-ill", "ill-formed", zero_reachable(1 - Q(1) == 0))
def _():
    # ILL-FORMED: x' = 1/y with y' = -1 from y = 1: y = 0 at t = 1 (domain true).
    return T("div-ode-0", And(y == 1, x == 0), ode({x: 1 / y, y: -1}), x >= 0)


def w_ode_dom():
    # TRUE: the domain x/b <= 1 means x <= b (b > 0).
    g = rng("div-ode-dom")
    for _ in range(SAMPLES):
        bb = rat(g, Q(1, 16), 10)
        s = rat(g, 0, bb)  # durations allowed by the domain
        check(s / bb <= 1 and s <= bb)


@case("div-ode-domain-safe-true", "true", w_ode_dom)
def _():
    # TRUE: x' = 1 from 0 inside x/b <= 1 stays <= b.
    return T("div-ode-dom", And(b > 0, x == 0), ode({x: 1}, x / b <= 1), x <= b)


def w_ode_dom_false():
    # FALSE: b = 2: x may reach 2 > 1.
    check(Q(2) / 2 <= 1 and not (Q(2) <= 1))


@case("div-ode-domain-false", "false", w_ode_dom_false)
def _():
    # FALSE: the domain lets x grow to b, which may exceed 1.
    return T("div-ode-dom-f", And(b > 0, x == 0), ode({x: 1}, x / b <= 1), x <= 1)


def w_dI_div_true():
    # TRUE: x = s, b > 0: x/b >= 0.
    g = rng("div-dI")
    for _ in range(SAMPLES):
        check(rat(g, 0, 10) / rat(g, Q(1, 8), 10) >= 0)


@case("div-dI-safe-divisor-true", "true", w_dI_div_true)
def _():
    # TRUE: the dI x/b >= 0 divides by the constant b > 0 (derivative 1/b >= 0).
    return T("div-dI", And(b > 0, x == 0), ode({x: 1}, invariants=[x / b >= 0]), x >= 0)


# --------------------------------------------------------------------------- guarded divisions
def w_sum_pos():
    # TRUE: b, c > 0 -> b + c > 0 -> 1/(b+c) > 0.
    g = rng("div-sum")
    for _ in range(SAMPLES):
        bb, cc = rat(g, Q(1, 64), 10), rat(g, Q(1, 64), 10)
        check(1 / (bb + cc) > 0)


@case("div-guarded-sum-true", "true", w_sum_pos)
def _():
    # TRUE: 1/(b+c) is well-defined (b + c > 0) and positive — a division that must be allowed.
    return T("div-sum", And(b > 0, c > 0), assign(y, 1 / (b + c)), y > 0)


def w_sum_lt1():
    # FALSE: b = c = 1/4: y = 2.
    check(1 / (Q(1, 4) + Q(1, 4)) == 2)


@case("div-guarded-sum-false", "false", w_sum_lt1)
def _():
    # FALSE: 1/(b+c) < 1 fails for b = c = 1/4 (well-formed, just false).
    return T("div-sum-f", And(b > 0, c > 0), assign(y, 1 / (b + c)), y < 1)


def w_sq1():
    # TRUE: x² + 1 >= 1 > 0, so 0 < 1/(x²+1) <= 1.
    g = rng("div-sq1")
    for _ in range(SAMPLES):
        xx = rat(g, -100, 100)
        check(0 < 1 / (xx * xx + 1) <= 1)


@case("div-square-plus-one-true", "true", w_sq1)
def _():
    # TRUE: the divisor x² + 1 is never 0.
    return T("div-sq1", x == x, assign(y, 1 / (x * x + 1)), y <= 1)


def w_havoc_guard():
    # TRUE: the test makes b > 0 before 1/b is computed.
    g = rng("div-havoc")
    for _ in range(SAMPLES):
        bb = rat(g, -10, 10)
        if bb > 0:
            check(1 / bb > 0)


@case("div-after-guarding-test-true", "true", w_havoc_guard)
def _():
    # TRUE: b := *; ?b > 0; y := 1/b — the division only runs where b > 0.
    return T("div-havoc", x == 0, seq(havoc(b), test(b > 0), assign(y, 1 / b)), y > 0)


def w_inc_div():
    # TRUE: b > 0, b := b + 1 > 1, y = 1/b in (0, 1).
    g = rng("div-inc")
    for _ in range(SAMPLES):
        bb = rat(g, Q(1, 64), 10) + 1
        check(0 < 1 / bb < 1)


@case("div-written-still-positive-true", "true", w_inc_div)
def _():
    # TRUE: the divisor is written (b := b + 1) but stays > 1.
    return T("div-inc", b > 0, seq(assign(b, b + 1), assign(y, 1 / b)), And(y > 0, y < 1))


@case("div-written-to-zero-ill", "ill-formed", zero_reachable(Q(1) > 0, Q(1) - 1 == 0))
def _():
    # ILL-FORMED: b = 1 then b := b - 1 = 0, then 1/b.
    return T("div-dec", b > 0, seq(assign(b, b - 1), assign(y, 1 / b)), y > 0)


@case("div-other-branch-zeroes-ill", "ill-formed", zero_reachable(True))
def _():
    # ILL-FORMED: the first branch sets b := 0 before 1/b.
    return T("div-branch", b > 0, seq(choice(assign(b, 0), skip()), assign(y, 1 / b)), y > 0)


@case("div-loop-invariant-divisor-ill", "ill-formed", zero_reachable(Q(1) - 1 == 0))
def _():
    # ILL-FORMED: after one iteration from b = 1, b = 0 and the invariant divides by it.
    return T("div-loop", b > 0, loop(assign(b, b - 1), invariant=1 / b != 0), b == b)


def w_nested():
    # TRUE: 1/(1/b) = b for b != 0.
    g = rng("div-nested")
    for _ in range(SAMPLES):
        bb = rat(g, Q(1, 64), 50)
        check(1 / (1 / bb) == bb)


@case("div-nested-reciprocal-true", "true", w_nested)
def _():
    # TRUE: y := 1/(1/b) equals b.
    return T("div-nested", b > 0, assign(y, 1 / (1 / b)), y == b)


def w_int_div():
    # TRUE: real division: (n/m)*m = n for m > 0 (e.g. 7/2*2 = 7).
    g = rng("div-int")
    for _ in range(SAMPLES):
        nn, mm = rint(g, -50, 50), rint(g, 1, 50)
        check(Q(nn, mm) * mm == nn)


@case("div-int-operands-real-division-true", "true", w_int_div)
def _():
    # TRUE: n/m with Int operands is real division, so (n/m)*m = n.
    return T("div-int", And(m > 0, n == n), skip(), (n / m) * m == n)


def w_int_half():
    # TRUE: 7/2 = 3.5 > 3 (real division, not floor division).
    check(Q(7, 2) > 3)


@case("div-int-seven-halves-true", "true", w_int_half)
def _():
    # TRUE: n = 7, m = 2: n/m = 7/2 > 3 (an integer division would give 3).
    return T("div-int2", And(n == 7, m == 2, m > 0), skip(), n / m > 3)


@case("div-by-constant-zero-ill", "ill-formed", zero_reachable(True))
def _():
    # ILL-FORMED: division by the literal 0.
    return T("div-lit0", x == 1, assign(y, x / 0), y == y)


@case("div-by-zero-expression-ill", "ill-formed", zero_reachable(2 - 2 == 0))
def _():
    # ILL-FORMED: the divisor 2 - 2 is the constant 0 in disguise.
    return T("div-expr0", x == 1, assign(y, x / (2 - x * 0 - 2 + 0 * x)), y == y)


@case("div-by-negative-zero-float-ill", "ill-formed", zero_reachable(-0.0 == 0))
def _():
    # ILL-FORMED: -0.0 is 0.
    return T("div-negzero", x == 1, assign(y, x / -0.0), y == y)


@case("div-by-b-minus-b-ill", "ill-formed", zero_reachable(True))
def _():
    # ILL-FORMED: b - b = 0 although b > 0.
    return T("div-bmb", b > 0, assign(y, 1 / (b - b)), y == y)
