"""Theme 6: loops — inductive and non-inductive true invariants, no invariant (the guarantee
is used), nested loops, loops inside choices, for_range, unsafe loops that need several
iterations. Witnesses simulate runs with random iteration counts and choices."""

from __future__ import annotations

from certiloop.models import (
    And,
    Ints,
    Reals,
    Theorem,
    assign,
    choice,
    for_range,
    havoc,
    loop,
    ode,
    seq,
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


x, y, z, v, s, tmp = Reals("x y z v s tmp")
k, n, m = Ints("k n m")


def counter(limit_ok):
    """x = 0; x := x + 1 repeated: x = number of iterations."""

    def w():
        g = rng(f"counter-{limit_ok}")
        for _ in range(SAMPLES):
            iters = rint(g, 0, 40)
            check(limit_ok(Q(iters)))

    return w


def _repeat_identity(iters):
    """x = 0, then x := x `iters` times."""
    xx = Q(0)
    for _ in range(iters):
        xx = xx
    return xx


def run_violates(final, bad):
    def w():
        check(bad(final), final)

    return w


# --------------------------------------------------------------------------- invariants
@case("loop-inductive-true", "true", counter(lambda xx: xx >= 0))
def _():
    # TRUE: x >= 0 is preserved by x := x + 1.
    return T("ind", x >= 0, loop(assign(x, x + 1), invariant=x >= 0), x >= 0)


def w_xy():
    # TRUE: y starts at 1 and grows, x grows by y >= 1: x >= 0 always.
    g = rng("loop-xy")
    for _ in range(SAMPLES):
        xx, yy = Q(0), Q(1)
        for _k in range(rint(g, 0, 30)):
            xx, yy = xx + yy, yy + 1
        check(xx >= 0)


@case("loop-true-not-inductive-true", "true", w_xy)
def _():
    # TRUE: x >= 0 holds but is not inductive alone (needs y >= 0).
    return T(
        "noind", And(x == 0, y == 1), loop(seq(assign(x, x + y), assign(y, y + 1)), invariant=x >= 0), x >= 0
    )


@case("loop-no-invariant-inductive-guarantee-true", "true", counter(lambda xx: xx >= 0))
def _():
    # TRUE: no annotation; the guarantee x >= 0 is itself inductive.
    return T("noinv", x >= 0, loop(assign(x, x + 1)), x >= 0)


@case("loop-no-invariant-non-inductive-true", "true", w_xy)
def _():
    # TRUE: no annotation, and the guarantee alone is not inductive.
    return T("noinv2", And(x == 0, y == 1), loop(seq(assign(x, x + y), assign(y, y + 1))), x >= 0)


@case("loop-unsafe-after-2-false", "false", run_violates(Q(2), lambda xx: not (xx <= 1)))
def _():
    # FALSE: two iterations give x = 2 > 1.
    return T("u2", x == 0, loop(assign(x, x + 1), invariant=x >= 0), x <= 1)


@case("loop-unsafe-after-3-false", "false", run_violates(Q(3), lambda xx: not (xx <= 2)))
def _():
    # FALSE: three iterations give x = 3 > 2.
    return T("u3", x == 0, loop(assign(x, x + 1), invariant=x >= 0), x <= 2)


@case("loop-unsafe-after-5-false", "false", run_violates(Q(5), lambda xx: not (xx <= 4)))
def _():
    # FALSE: five iterations give x = 5 > 4 (deeper than the default unrolling).
    return T("u5", x == 0, loop(assign(x, x + 1)), x <= 4)


def w_nested_true():
    # TRUE: x only grows from 0, y copies x.
    g = rng("nested")
    for _ in range(SAMPLES):
        xx, yy = Q(0), Q(0)
        for _o in range(rint(g, 0, 6)):
            xx += rint(g, 0, 6)
            yy = xx
        check(yy >= 0)


@case("loop-nested-true", "true", w_nested_true)
def _():
    # TRUE: nested loops that only increase x; y := x after each inner loop.
    inner = loop(assign(x, x + 1), invariant=x >= 0, label="inner")
    return T(
        "nested", And(x == 0, y == 0), loop(seq(inner, assign(y, x)), invariant=And(x >= 0, y >= 0)), y >= 0
    )


@case("loop-nested-false", "false", run_violates(Q(-1), lambda yy: not (yy >= 0)))
def _():
    # FALSE: one outer iteration with one inner decrement: y = -1.
    inner = loop(assign(x, x - 1), label="inner")
    return T("nested-f", And(x == 0, y == 0), loop(seq(inner, assign(y, x))), y >= 0)


@case("loop-in-choice-false", "false", run_violates(Q(-1), lambda xx: not (xx >= 0)))
def _():
    # FALSE: the second branch's loop decrements once: x = -1.
    return T("choice-loop", x == 0, choice(loop(assign(x, x + 1)), loop(assign(x, x - 1))), x >= 0)


def w_choice_loops_true():
    # TRUE: from x >= 0, x + 1 and x² keep x >= 0.
    g = rng("choice-loop-t")
    for _ in range(SAMPLES):
        xx = rat(g, 0, 3)
        branch = g.random() < 0.5
        for _k in range(rint(g, 0, 5)):
            xx = xx + 1 if branch else xx * xx
        check(xx >= 0)


@case("loop-in-choice-true", "true", w_choice_loops_true)
def _():
    # TRUE: both loops keep x >= 0.
    return T(
        "choice-loop-t",
        x >= 0,
        choice(loop(assign(x, x + 1), invariant=x >= 0), loop(assign(x, x * x), invariant=x >= 0)),
        x >= 0,
    )


# --------------------------------------------------------------------------- for_range
def w_for_true():
    # TRUE: n >= 0 iterations of s := s + 2 from 0 give s = 2n.
    g = rng("for")
    for _ in range(SAMPLES):
        nn = rint(g, 0, 50)
        ss = Q(0)
        for _k in range(0, nn):
            ss += 2
        check(ss == 2 * nn)


@case("for-range-sum-true", "true", w_for_true)
def _():
    # TRUE: for k in [0, n): s := s + 2, with n >= 0, ends with s = 2n.
    return T(
        "for", And(s == 0, n >= 0), for_range(k, 0, n, assign(s, s + 2), invariant=s == 2 * k), s == 2 * n
    )


def w_for_neg():
    # FALSE: n = -1: the loop does not run (k := 0, ?0 >= -1), s = 0 != -2.
    check(Q(0) != 2 * (-1))


@case("for-range-negative-bound-false", "false", w_for_neg)
def _():
    # FALSE: without n >= 0, an empty range leaves s = 0 != 2n.
    return T("for-neg", s == 0, for_range(k, 0, n, assign(s, s + 2), invariant=s == 2 * k), s == 2 * n)


def w_for_off():
    # FALSE: n = 0: s = 0 != 2.
    check(Q(0) != 2 * 0 + 2)


@case("for-range-off-by-one-false", "false", w_for_off)
def _():
    # FALSE: claims one iteration too many.
    return T(
        "for-off",
        And(s == 0, n >= 0),
        for_range(k, 0, n, assign(s, s + 2), invariant=s == 2 * k),
        s == 2 * n + 2,
    )


def w_for_nested_count():
    # TRUE: n·m iterations of c := c + 1 in two nested ranges.
    g = rng("for2")
    for _ in range(SAMPLES):
        nn, mm = rint(g, 0, 12), rint(g, 0, 12)
        c = sum(1 for _a in range(nn) for _b in range(mm))
        check(c == nn * mm)


@case("for-range-nested-count-true", "true", w_for_nested_count)
def _():
    # TRUE: nested for_range counts n*m (invariants s = k*m + ... stated per level).
    from certiloop.models import Int

    kk, jj = Int("kk"), Int("jj")
    inner = for_range(jj, 0, m, assign(s, s + 1), invariant=s == kk * m + jj, label="inner")
    return T(
        "for2",
        And(s == 0, n >= 0, m >= 0),
        for_range(kk, 0, n, inner, invariant=s == kk * m, label="outer"),
        s == n * m,
    )


# --------------------------------------------------------------------------- tests in the body
def w_bounded_true():
    # TRUE: the test x < 3 stops the counter at 3.
    check(all(min(i, 3) <= 3 for i in range(50)))


@case("loop-guarded-counter-true", "true", w_bounded_true)
def _():
    # TRUE: ?x < 3; x := x + 1 can only run while x < 3.
    return T("guard", x == 0, loop(seq(test(x < 3), assign(x, x + 1)), invariant=And(x >= 0, x <= 3)), x <= 3)


@case("loop-guarded-counter-false", "false", run_violates(Q(3), lambda xx: not (xx <= 2)))
def _():
    # FALSE: three iterations reach x = 3 > 2.
    return T("guard-f", x == 0, loop(seq(test(x < 3), assign(x, x + 1))), x <= 2)


def w_ode_loop_true():
    # TRUE: each flow adds v·τ with v >= 0, τ >= 0.
    g = rng("loop-ode")
    for _ in range(SAMPLES):
        xx = rat(g, 0, 5)
        for _k in range(rint(g, 0, 6)):
            xx += rat(g, 0, 5) * rat(g, 0, 5)
        check(xx >= 0)


@case("loop-ode-nonnegative-velocity-true", "true", w_ode_loop_true)
def _():
    # TRUE: x' = v with a chosen v >= 0 never decreases x.
    return T("loop-ode", x >= 0, loop(seq(havoc(v), test(v >= 0), ode({x: v})), invariant=x >= 0), x >= 0)


@case("loop-ode-negative-velocity-false", "false", run_violates(Q(0) + Q(-1) * 1, lambda xx: xx < 0))
def _():
    # FALSE: v = -1 for 1 s from x = 0 gives x = -1.
    return T("loop-ode-f", x == 0, loop(seq(havoc(v), test(v >= -1), ode({x: v})), invariant=x >= 0), x >= 0)


def w_havoc_sq():
    # TRUE: x² <= 1 -> x <= 1.
    g = rng("loop-havoc")
    for _ in range(SAMPLES):
        xx = rat(g, -1, 1)
        check(xx * xx <= 1 and xx <= 1)


@case("loop-havoc-test-true", "true", w_havoc_sq)
def _():
    # TRUE: every chosen x has x² <= 1.
    return T("loop-havoc", x == 0, loop(seq(havoc(x), test(x * x <= 1))), x <= 1)


@case(
    "loop-invariant-false-initially-true",
    "true",
    lambda: check(all(_repeat_identity(it) == 0 for it in range(50))),
)
def _():
    # TRUE: x := x keeps x = 0; the annotation x == 1 is wrong, the theorem is not.
    return T("inv-init", x == 0, loop(assign(x, x), invariant=x == 1), x == 0)


@case("loop-invariant-too-weak-true", "true", counter(lambda xx: xx >= 0))
def _():
    # TRUE: x >= -5 is inductive but does not give x >= 0; the theorem holds anyway.
    return T("inv-weak", x == 0, loop(assign(x, x + 1), invariant=x >= -5), x >= 0)


@case("loop-then-code-false", "false", run_violates(1 - Q(2), lambda yy: yy < 0))
def _():
    # FALSE: two iterations then y := 1 - x = -1.
    return T("then", x == 0, seq(loop(assign(x, x + 1), invariant=x >= 0), assign(y, 1 - x)), y >= 0)


def w_swap():
    # TRUE: swapping preserves x + y = 3.
    g = rng("swap")
    for _ in range(SAMPLES):
        xx, yy = Q(1), Q(2)
        for _k in range(rint(g, 0, 9)):
            xx, yy = yy, xx
        check(xx + yy == 3)


@case("loop-swap-true", "true", w_swap)
def _():
    # TRUE: tmp := x; x := y; y := tmp keeps the sum.
    return T(
        "swap",
        And(x == 1, y == 2),
        loop(seq(assign(tmp, x), assign(x, y), assign(y, tmp)), invariant=x + y == 3),
        x + y == 3,
    )


def w_fib():
    # FALSE: (1,1) -> (1,2) -> (2,3) -> (3,5): y = 5 > 4 after 3 iterations.
    xx, yy = 1, 1
    for _ in range(3):
        xx, yy = yy, xx + yy
    check(yy == 5)


@case("loop-fibonacci-false", "false", w_fib)
def _():
    # FALSE: Fibonacci pairs pass 4 at the third iteration.
    return T("fib", And(x == 1, y == 1), loop(seq(assign(tmp, x + y), assign(x, y), assign(y, tmp))), y <= 4)


def w_doubling():
    # TRUE: n is a power of two, never 6.
    check(all(2**e != 6 for e in range(200)))


@case("loop-int-doubling-never-6-true", "true", w_doubling)
def _():
    # TRUE: powers of two are never 6 (no simple inductive invariant states this).
    return T("dbl", n == 1, loop(assign(n, 2 * n)), n != 6)


def w_halving():
    # TRUE: x = 1/2^k > 0.
    check(all(Q(1, 2**e) > 0 for e in range(200)))


@case("loop-halving-positive-true", "true", w_halving)
def _():
    # TRUE: repeated halving stays positive.
    return T("halve", x == 1, loop(assign(x, x / 2), invariant=x > 0), x > 0)


def w_halving_false():
    # FALSE: after 1 iteration x = 1/2 < 1.
    check(Q(1, 2) < 1)


@case("loop-halving-stays-one-false", "false", w_halving_false)
def _():
    # FALSE: one halving gives 1/2.
    return T("halve-f", x == 1, loop(assign(x, x / 2), invariant=x > 0), x >= 1)
