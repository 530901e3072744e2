"""Theme 2: differential invariants, cuts and weakening; flows without a polynomial solution.

Witnesses use the analytic solutions (cos/sin, exp, 1/(1-t), tan), each confirmed against
scipy's solve_ivp; invariant annotations never change a theorem's truth, only its proof."""

from __future__ import annotations

import math

import numpy as np

from certiloop.models import And, Reals, Theorem, assign, havoc, loop, ode, seq, test

from .harness import SAMPLES, Case, Q, check, ivp, rat, rng

CASES: list[Case] = []


def case(id, truth, witness, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


x, y, w, acc, y0, t, b = Reals("x y w acc y0 t b")


# --------------------------------------------------------------------------- dI with a division
def w_div_false():
    # FALSE: x = 1 - s reaches 0 at s = 1 (domain true): x != 0 fails there.
    check(1 - Q(1) == 0)
    end = ivp(lambda _t, z: [-1.0], [1.0], 1.0)
    check(abs(end[0]) < 1e-9)


@case("dI-division-x-times-inv-x-false", "false", w_div_false, may_reject=True)
def _():
    # FALSE (known bug class): the "invariant" x*(1/x) = 1 has Lie derivative 0, but x hits 0 at t = 1.
    return T("dI-div", x == 1, ode({x: -1}, invariants=[x * (1 / x) == 1]), x != 0)


def w_div_domain_false():
    # FALSE: x = 1 - s >= 0 on [0, 1] (domain holds), ends at x = 0, and 0 > 0 fails.
    for s in [Q(k, 64) for k in range(65)]:
        check(1 - s >= 0)
    check(not (1 - Q(1) > 0))


@case("dI-division-with-domain-false", "false", w_div_domain_false, may_reject=True)
def _():
    # FALSE: same bogus invariant, the domain x >= 0 still lets x reach 0.
    return T("dI-div-dom", x == 1, ode({x: -1}, x >= 0, invariants=[x * (1 / x) == 1]), x > 0)


# --------------------------------------------------------------------------- oscillator (cos, sin)
def osc(tau):
    """x' = y, y' = -x from (1, 0): x = cos τ, y = -sin τ (checked against solve_ivp)."""
    return math.cos(tau), -math.sin(tau)


def _cross_osc(tau):
    end = ivp(lambda _t, z: [z[1], -z[0]], [1.0, 0.0], tau)
    check(np.allclose(end, osc(tau), atol=1e-8), end, osc(tau))


def w_osc_true():
    # TRUE: x² + y² = cos² + sin² = 1, so x <= 1 along every run.
    _cross_osc(2.5)
    g = rng("dI-osc")
    for _ in range(SAMPLES):
        xx, yy = osc(float(rat(g, 0, 30)))
        check(abs(xx * xx + yy * yy - 1) < 1e-12 and xx <= 1 + 1e-12)


@case("dI-oscillator-circle-true", "true", w_osc_true)
def _():
    # TRUE: the circle x² + y² = 1 is a dI (derivative 2xy - 2yx = 0), and it bounds x by 1.
    return T("dI-osc", And(x == 1, y == 0), ode({x: y, y: -x}, invariants=[x**2 + y**2 == 1]), x <= 1)


def w_osc_neg():
    # FALSE: τ = π gives x = cos π = -1 < 0.
    _cross_osc(math.pi)
    check(osc(math.pi)[0] < -0.99)


@case("dI-oscillator-wrong-invariant-false", "false", w_osc_neg)
def _():
    # FALSE: x >= 0 is not invariant (its derivative y is negative right away); x reaches -1.
    return T("dI-osc-f", And(x == 1, y == 0), ode({x: y, y: -x}, invariants=[x >= 0]), x >= 0)


@case("dI-oscillator-unannotated-false", "false", w_osc_neg)
def _():
    # FALSE: without annotations; x = cos π = -1 < -1/2.
    return T("dI-osc-f2", And(x == 1, y == 0), ode({x: y, y: -x}), x >= -Q(1, 2))


@case("dI-oscillator-unannotated-true", "true", w_osc_true)
def _():
    # TRUE: the circle holds with no annotation (the engine may well not see it).
    return T("dI-osc-t2", And(x == 1, y == 0), ode({x: y, y: -x}), x <= 1)


def w_osc_init():
    # FALSE: from (1, 0), x² + y² = 1 != 2 at every time (τ = 0 already).
    check(1**2 + 0**2 != 2)


@case("dI-invariant-false-initially-false", "false", w_osc_init)
def _():
    # FALSE: the annotation x² + y² = 2 has a valid derivative condition but fails at the start.
    return T(
        "dI-init", And(x == 1, y == 0), ode({x: y, y: -x}, invariants=[x**2 + y**2 == 2]), x**2 + y**2 == 2
    )


def w_const_init():
    # FALSE: x' = 0 keeps x = 1, and 1 == 2 is false.
    check(Q(1) != 2)


@case("dI-invariant-false-initially-poly-false", "false", w_const_init)
def _():
    # FALSE: x stays 1; the annotation x == 2 (derivative 0 == 0) is false initially.
    return T("dI-init-p", x == 1, ode({x: 0}, invariants=[x == 2]), x == 2)


# --------------------------------------------------------------------------- x' = x² (finite escape)
def w_escape_pos():
    # TRUE: x = 1/(1 - s) on [0, 1): positive and >= 1; the flow exists only for τ < 1.
    end = ivp(lambda _t, z: [z[0] ** 2], [1.0], 0.9)
    check(abs(end[0] - 10.0) < 1e-6)
    g = rng("dI-escape")
    for _ in range(SAMPLES):
        s = rat(g, 0, Q(999, 1000), den=1000)
        xx = 1 / (1 - s)
        check(xx > 0 and xx >= 1 and xx**2 == (1 / (1 - s)) ** 2)


@case("dI-escape-positive-true", "true", w_escape_pos)
def _():
    # TRUE: x > 0 is a dI of x' = x² (derivative x² >= 0).
    return T("dI-esc", x == 1, ode({x: x**2}, invariants=[x > 0]), x > 0)


def w_escape_big():
    # FALSE: τ = 199/200: x = 1/(1 - τ) = 200 > 100.
    check(1 / (1 - Q(199, 200)) == 200)
    end = ivp(lambda _t, z: [z[0] ** 2], [1.0], 0.995)
    check(abs(end[0] - 200.0) < 1e-4)


@case("dI-escape-bounded-false", "false", w_escape_big)
def _():
    # FALSE: x' = x² blows up at t = 1, passing 100 at t = 0.99.
    return T("dI-esc-f", x == 1, ode({x: x**2}), x <= 100)


@case("dI-escape-wrong-invariant-false", "false", w_escape_big)
def _():
    # FALSE: the annotation x <= 100 is not invariant (x² <= 0 fails); x passes 100.
    return T("dI-esc-f2", x == 1, ode({x: x**2}, invariants=[x <= 100]), x <= 100)


# --------------------------------------------------------------------------- x' = x, x' = -x
def w_exp_ge1():
    # TRUE: x = e^s >= 1.
    end = ivp(lambda _t, z: [z[0]], [1.0], 2.0)
    check(abs(end[0] - math.e**2) < 1e-8)
    g = rng("dI-exp")
    for _ in range(SAMPLES):
        check(math.exp(float(rat(g, 0, 20))) >= 1)


@case("dI-exp-lower-bound-true", "true", w_exp_ge1)
def _():
    # TRUE: x >= 1 is a dI of x' = x inside the domain x >= 0 (derivative x >= 0 there).
    return T("dI-exp", x == 1, ode({x: x}, x >= 0, invariants=[x >= 1]), x >= 1)


def w_exp_upper():
    # FALSE: τ = ln 3: x = 3 > 2.
    end = ivp(lambda _t, z: [z[0]], [1.0], math.log(3))
    check(abs(end[0] - 3) < 1e-8)


@case("dI-exp-upper-false", "false", w_exp_upper)
def _():
    # FALSE: x = e^t passes 2 at t = ln 2.
    return T("dI-exp-f", x == 1, ode({x: x}), x <= 2)


def w_decay_pos():
    # TRUE: x = x0 e^{-s} > 0 for x0 > 0.
    g = rng("dI-decay")
    for _ in range(SAMPLES):
        x0, s = float(rat(g, Q(1, 64), 10)), float(rat(g, 0, 30))
        check(x0 * math.exp(-s) > 0)
    end = ivp(lambda _t, z: [-z[0]], [2.0], 3.0)
    check(abs(end[0] - 2 * math.exp(-3)) < 1e-9)


@case("dI-decay-positive-true", "true", w_decay_pos)
def _():
    # TRUE: exponential decay never reaches 0 (needs a Darboux argument, not plain dI).
    return T("dI-decay", x > 0, ode({x: -x}), x > 0)


@case("dI-decay-strict-invariant-true", "true", w_decay_pos)
def _():
    # TRUE: same claim annotated with x > 0, whose plain dI condition (-x >= 0) is not valid.
    return T("dI-decay-inv", x > 0, ode({x: -x}, invariants=[x > 0]), x > 0)


def w_dw_true():
    # TRUE: every state a run reaches satisfies the domain x >= 0.
    g = rng("dW-dom")
    for _ in range(SAMPLES):
        x0, s = float(rat(g, 0, 10)), float(rat(g, 0, 10))
        check(x0 * math.exp(-s) >= 0)


@case("dW-domain-gives-guarantee-true", "true", w_dw_true)
def _():
    # TRUE by differential weakening: the guarantee is the domain.
    return T("dW-dom", x == x, ode({x: -x}, x >= 0), x >= 0)


def w_dw_false():
    # FALSE: x = cos s <= 1 <= 2 along the whole flow (domain holds), and cos π = -1 < 0.
    _cross_osc(math.pi)
    check(all(math.cos(s) <= 2 for s in np.linspace(0, math.pi, 200)))
    check(osc(math.pi)[0] < 0)


@case("dW-domain-too-weak-false", "false", w_dw_false)
def _():
    # FALSE: the domain x <= 2 never binds, and x = cos t goes negative.
    return T("dW-weak", And(x == 1, y == 0), ode({x: y, y: -x}, x <= 2), x >= 0)


# --------------------------------------------------------------------------- tan: self-assumption
def w_tan_false():
    # FALSE: x' = 1 + x² from 0 is tan s; at s = 1/2, x = tan(1/2) ≈ 0.546 != 0.
    end = ivp(lambda _t, z: [1 + z[0] ** 2], [0.0], 0.5)
    check(abs(end[0] - math.tan(0.5)) < 1e-9 and end[0] > 0.5)


@case("dI-self-assumption-x2-le-0-false", "false", w_tan_false)
def _():
    # FALSE: x² <= 0 (x = 0) has derivative 2x(1+x²) <= 0 only if one assumes x = 0 itself.
    return T("dI-self", x == 0, ode({x: 1 + x**2}, invariants=[x**2 <= 0]), x == 0)


def w_poly_self():
    # FALSE: x' = 1 from 0: x = 1 at τ = 1.
    check(Q(1) != 0)


@case("dI-self-assumption-poly-false", "false", w_poly_self)
def _():
    # FALSE: same bogus annotation on x' = 1.
    return T("dI-self-p", x == 0, ode({x: 1}, invariants=[x**2 <= 0]), x == 0)


# --------------------------------------------------------------------------- cuts
def cart(w0, a, tau):
    """y' = w, w' = a: w = w0 + a s, y = y0 + w0 s + a s²/2 (here y0 = 0)."""
    return w0 * tau + a * tau**2 / 2, w0 + a * tau


def w_cart_true():
    # TRUE: with acc >= 0 and w >= 0, w = w0 + a s >= 0 and y - y0 = w0 s + a s²/2 >= 0.
    g = rng("dC-cart")
    for _ in range(SAMPLES):
        w0, a, tau = rat(g, 0, 5), rat(g, 0, 5), rat(g, 0, 10)
        check(cart(w0, a, tau)[0] >= 0)


@case("dC-cart-chain-true", "true", w_cart_true)
def _():
    # TRUE: dC w >= 0, then dI y >= y0.
    return T(
        "dC-cart", And(y == y0, w >= 0, acc >= 0), ode({y: w, w: acc}, invariants=[w >= 0, y >= y0]), y >= y0
    )


@case("dC-cart-chain-wrong-order-true", "true", w_cart_true)
def _():
    # TRUE: same system, cuts in the order that does not go through (y >= y0 first).
    return T(
        "dC-cart-o",
        And(y == y0, w >= 0, acc >= 0),
        ode({y: w, w: acc}, invariants=[y >= y0, w >= 0]),
        y >= y0,
    )


def w_cart_brake():
    # FALSE: w0 = 0, acc = -1, τ = 1: y = y0 - 1/2 < y0.
    check(cart(Q(0), Q(-1), Q(1))[0] == -Q(1, 2))


@case("dC-cart-braking-false", "false", w_cart_brake)
def _():
    # FALSE: braking allowed; the cut w >= 0 is not invariant and y falls below y0.
    return T(
        "dC-cart-f",
        And(y == y0, w >= 0, acc >= -1),
        ode({y: w, w: acc}, invariants=[w >= 0, y >= y0]),
        y >= y0,
    )


def w_cart_loop_false():
    # FALSE: iteration 1: acc := -1, flow 1 s from w = 0: y = y0 - 1/2.
    check(cart(Q(0), Q(-1), Q(1))[0] < 0)


@case("dC-cart-loop-braking-false", "false", w_cart_loop_false)
def _():
    # FALSE: the controller may pick a negative acceleration (test allows acc >= -1).
    return T(
        "dC-cart-loop-f",
        And(y == y0, w >= 0),
        loop(
            seq(havoc(acc), test(acc >= -1), ode({y: w, w: acc}, invariants=[w >= 0, y >= y0])),
            invariant=And(w >= 0, y >= y0),
        ),
        y >= y0,
    )


def w_time_true():
    # TRUE: x = s/2 <= s = t.
    g = rng("dI-time")
    for _ in range(SAMPLES):
        s = rat(g, 0, 100)
        check(s / 2 <= s)


@case("dI-with-clock-true", "true", w_time_true)
def _():
    # TRUE: x <= t is a dI (1/2 <= 1).
    return T("dI-time", And(x == 0, t == 0), ode({x: Q(1, 2), t: 1}, invariants=[x <= t]), x <= t)


def w_strict_lt():
    # FALSE: x' = 1 from 0 reaches x = 1 at τ = 1.
    check(not (Q(1) < 1))


@case("dI-strict-less-false", "false", w_strict_lt)
def _():
    # FALSE: x < 1 is no invariant of x' = 1.
    return T("dI-lt", x == 0, ode({x: 1}, invariants=[x < 1]), x < 1)


def w_neq_true():
    # TRUE: x = e^s != 0.
    g = rng("dI-neq")
    for _ in range(SAMPLES):
        check(math.exp(float(rat(g, 0, 30))) != 0)


@case("dI-disequality-annotation-true", "true", w_neq_true, may_reject=True)
def _():
    # TRUE: e^t != 0; a != annotation may be refused (not a dI the engine supports).
    return T("dI-neq", x == 1, ode({x: x}, invariants=[x != 0]), x != 0)


def w_loop_decay_true():
    # TRUE: every flow of x' = -x keeps x's sign (x0 e^{-s}), and the reset only sets x := 1.
    g = rng("dI-loop-decay")
    for _ in range(SAMPLES):
        xx = Q(1)
        for _k in range(rint_(g)):
            xx = 1 if g.random() < 0.3 else xx * Q(math.exp(-float(rat(g, 0, 3))))
        check(xx > 0)


def rint_(g):
    return int(g.integers(0, 6))


@case("dI-loop-decay-positive-true", "true", w_loop_decay_true)
def _():
    # TRUE: x stays positive through resets and decays (the loop invariant x > 0 needs dI + domain).
    return T(
        "dI-loop",
        x == 1,
        loop(seq(choice_reset(), ode({x: -x}, x >= 0, invariants=[x > 0])), invariant=x > 0),
        x > 0,
    )


def choice_reset():
    from certiloop.models import choice, skip

    return choice(assign(x, 1), skip())


def w_darboux_false():
    # FALSE: x' = b x with b = -1: x = e^{-s}, below 1/2 after s = ln 2 < 1.
    check(math.exp(-1.0) < 0.5)
    end = ivp(lambda _t, z: [-z[0]], [1.0], 1.0)
    check(end[0] < 0.5)


@case("dI-param-rate-false", "false", w_darboux_false)
def _():
    # FALSE: with an unknown rate b (here -1) x decays below 1/2.
    return T("dI-rate-f", And(x == 1, b >= -1), ode({x: b * x}), x >= Q(1, 2))


def w_param_rate_true():
    # TRUE: b >= 0 makes x = e^{bs} >= 1.
    g = rng("dI-rate")
    for _ in range(SAMPLES):
        bb, s = float(rat(g, 0, 3)), float(rat(g, 0, 5))
        check(math.exp(bb * s) >= 1)


@case("dI-param-rate-true", "true", w_param_rate_true)
def _():
    # TRUE: x >= 1 with derivative b x >= 0 inside the domain x >= 0 (b >= 0).
    return T("dI-rate", And(x == 1, b >= 0), ode({x: b * x}, x >= 0, invariants=[x >= 1]), x >= 1)


# --------------------------------------------------------------------------- the nonzero rule (sign kept)
def saddle(x0, y0, tau):
    """x' = y, y' = x from (x0, y0): x = x0 cosh τ + y0 sinh τ, y = x0 sinh τ + y0 cosh τ."""
    return (x0 * math.cosh(tau) + y0 * math.sinh(tau), x0 * math.sinh(tau) + y0 * math.cosh(tau))


def _cross_saddle(x0, y0, tau):
    end = ivp(lambda _t, z: [z[1], z[0]], [x0, y0], tau)
    check(np.allclose(end, saddle(x0, y0, tau), atol=1e-8), end, saddle(x0, y0, tau))


def w_saddle_branch_true():
    # TRUE: from x = 0, y >= 1, y = y0 cosh τ >= 1 for all τ.
    _cross_saddle(0.0, 1.5, 2.0)
    g = rng("dI-saddle")
    for _ in range(SAMPLES):
        yy = saddle(0.0, float(rat(g, 1, 4)), float(rat(g, 0, 6)))[1]
        check(yy >= 0)


@case("dI-nonzero-saddle-branch-true", "true", w_saddle_branch_true)
def _():
    # TRUE: y^2 - x^2 >= 1 is kept (a first integral), so y never vanishes and keeps its sign;
    # y' = x has no sign, so only the nonzero rule (or luck) proves y >= 0.
    return T("dI-nz", And(x == 0, y >= 1), ode({x: y, y: x}, invariants=[y**2 - x**2 >= 1]), y >= 0)


def w_saddle_cross_false():
    # FALSE: from (-1, 1/2), y = -sinh τ + cosh τ / 2 < 0 at τ = 1.
    _cross_saddle(-1.0, 0.5, 1.0)
    check(saddle(-1.0, 0.5, 1.0)[1] < -0.4)


@case("dI-nonzero-saddle-crossing-false", "false", w_saddle_cross_false)
def _():
    # FALSE: the weaker level y^2 - x^2 >= -1 (it does hold) lets y pass through 0.
    return T("dI-nz-f", And(x == -1, y == Q(1, 2)), ode({x: y, y: x}, invariants=[y**2 - x**2 >= -1]), y >= 0)


def w_rise_false():
    # FALSE: x' = 1 from x = -1 gives x = 1/2 > 0 at τ = 3/2.
    check(-1 + Q(3, 2) > 0)


@case("dI-nonzero-rise-through-zero-false", "false", w_rise_false)
def _():
    # FALSE: the annotation y = 2 holds and tells nothing about x, which crosses 0.
    return T("dI-nz-rise", And(x == -1, y == 2), ode({x: 1, y: 0}, invariants=[y == 2]), x <= 0)
