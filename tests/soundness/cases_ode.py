"""Theme 1: closed-form ODE solutions (chains of integrators, accumulators, many variables,
constants in right-hand sides, time, evolution domains along the whole flow, boundary starts).

Closed forms are derived by hand (comments) and every witness cross-checks the derivation
against scipy's numerical integration before using it with exact Fractions."""

from __future__ import annotations

from certiloop.models import And, Real, Reals, Theorem, assign, ode, seq

from .harness import SAMPLES, Case, Q, check, crosscheck, rat, rng

CASES: list[Case] = []


def case(id, truth, witness, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


# --------------------------------------------------------------------------- 3-D double integrator
px, py, pz, vx, vy, vz, ax, ay, az, q, t = Reals("px py pz vx vy vz ax ay az q t")
AT_REST = And(px == 0, py == 0, pz == 0, vx == 0, vy == 0, vz == 0, ax == 0, ay == 0, az == 1, q == 0, t == 0)
FLOW3D = {px: vx, py: vy, pz: vz, vx: ax, vy: ay, vz: az, q: pz + vz, t: 1}


def accum3d(tau):
    """At rest, az = 1: vz = τ, pz = τ²/2, q = ∫(pz + vz) = τ³/6 + τ²/2, t = τ."""
    tau = Q(tau)
    return {"pz": tau**2 / 2, "vz": tau, "q": tau**3 / 6 + tau**2 / 2, "t": tau}


def _cross3d():
    crosscheck(
        lambda y: [y[1], 1.0, y[0] + y[1]],
        [0, 0, 0],
        Q(5, 2),
        lambda s: [accum3d(s)["pz"], accum3d(s)["vz"], accum3d(s)["q"]],
    )


def w_accum3d_false():
    # FALSE: at τ = 2, q = 8/6 + 2 = 10/3, so 2q = 20/3 < 8 = t³.
    _cross3d()
    s = accum3d(2)
    check(not (2 * s["q"] >= s["t"] ** 3), s)


@case("ode-3d-accum-2q-ge-t3-false", "false", w_accum3d_false)
def _():
    # FALSE: 2q = τ³/3 + τ² < τ³ once τ > 3/2 (known engine bug class: accumulator q' = pz + vz).
    return T("ode-3d-accum-2q", AT_REST, ode(FLOW3D), 2 * q >= t**3)


def w_accum3d_true():
    # TRUE: 6q = τ³ + 3τ² exactly for every τ >= 0.
    _cross3d()
    g = rng("ode-3d-accum-6q")
    for _ in range(SAMPLES):
        s = accum3d(rat(g, 0, 20))
        check(6 * s["q"] <= s["t"] ** 3 + 3 * s["t"] ** 2, s)


@case("ode-3d-accum-6q-le-true", "true", w_accum3d_true)
def _():
    # TRUE: 6q = t³ + 3t² along the whole flow (hand-integrated, cross-checked numerically).
    return T("ode-3d-accum-6q", AT_REST, ode(FLOW3D), 6 * q <= t**3 + 3 * t**2)


@case("ode-3d-accum-6q-eq-true", "true", w_accum3d_true)
def _():
    # TRUE: the exact identity 6q = t³ + 3t² (same witness, equality is what it checks).
    return T("ode-3d-accum-6q-eq", AT_REST, ode(FLOW3D), 6 * q == t**3 + 3 * t**2)


def w_3d_xy_true():
    # TRUE: ax = ay = 0 and vx = vy = 0 at rest keep px, py at 0; pz = τ²/2 >= 0.
    g = rng("ode-3d-xy")
    for _ in range(SAMPLES):
        s = accum3d(rat(g, 0, 20))
        check(s["pz"] >= 0 and 2 * s["pz"] == s["t"] ** 2)


@case("ode-3d-planar-true", "true", w_3d_xy_true)
def _():
    # TRUE: x/y stay at 0, 2pz = t² (free fall upwards from rest with az = 1).
    return T("ode-3d-planar", AT_REST, ode(FLOW3D), And(px == 0, py == 0, 2 * pz == t**2, pz >= 0))


# --------------------------------------------------------------------------- general accumulator
x, v, a, x0, v0 = Reals("x v a x0 v0")
ACC_PRE = And(x == x0, v == v0, q == 0, t == 0)


def acc_general(x0_, v0_, a_, tau):
    """x' = v, v' = a, q' = x + v, t' = 1 from (x0, v0, q = 0, t = 0):
    v = v0 + aτ, x = x0 + v0τ + aτ²/2, q = x0τ + v0τ²/2 + aτ³/6 + v0τ + aτ²/2."""
    tau = Q(tau)
    return {
        "x": x0_ + v0_ * tau + a_ * tau**2 / 2,
        "v": v0_ + a_ * tau,
        "q": x0_ * tau + v0_ * tau**2 / 2 + a_ * tau**3 / 6 + v0_ * tau + a_ * tau**2 / 2,
        "t": tau,
    }


def _cross_acc(x0_, v0_, a_):
    crosscheck(
        lambda y: [y[1], float(a_), y[0] + y[1]],
        [x0_, v0_, 0],
        Q(3),
        lambda s: [acc_general(x0_, v0_, a_, s)[k] for k in ("x", "v", "q")],
    )


def w_acc_true():
    # TRUE: the closed form above, at random starts, accelerations and durations.
    g = rng("ode-acc-general")
    _cross_acc(Q(1, 2), Q(-3, 4), Q(5, 4))
    for _ in range(SAMPLES):
        x0_, v0_, a_, tau = rat(g, -5, 5), rat(g, -5, 5), rat(g, -5, 5), rat(g, 0, 10)
        s = acc_general(x0_, v0_, a_, tau)
        check(s["q"] == x0_ * tau + v0_ * tau**2 / 2 + a_ * tau**3 / 6 + v0_ * tau + a_ * tau**2 / 2)


@case("ode-accum-general-true", "true", w_acc_true)
def _():
    # TRUE: q' = x + v integrates to x0 t + v0 t²/2 + a t³/6 + v0 t + a t²/2.
    return T(
        "ode-accum-general",
        ACC_PRE,
        ode({x: v, v: a, q: x + v, t: 1}),
        q == x0 * t + v0 * t**2 / 2 + a * t**3 / 6 + v0 * t + a * t**2 / 2,
    )


def w_acc_false():
    # FALSE: x0 = v0 = 0, a = 1, τ = 1: q = 1/6 + 1/2 = 2/3, the guarantee claims 1/6.
    _cross_acc(0, 0, 1)
    s = acc_general(Q(0), Q(0), Q(1), 1)
    check(s["q"] == Q(2, 3) and s["q"] != Q(1, 6))


@case("ode-accum-general-missing-term-false", "false", w_acc_false)
def _():
    # FALSE: drops the a t²/2 that v contributes to q (a = 1, t = 1 shows it).
    return T(
        "ode-accum-missing",
        ACC_PRE,
        ode({x: v, v: a, q: x + v, t: 1}),
        q == x0 * t + v0 * t**2 / 2 + a * t**3 / 6 + v0 * t,
    )


# same system, names that sort the other way round (b is the position, a the velocity)
b_, a_v, c_q, d_t = Reals("b a c d")


def w_acc_renamed_true():
    # TRUE: same closed form as ode-accum-general with x0 = v0 = 0, acceleration 1.
    g = rng("ode-accum-renamed")
    _cross_acc(0, 0, 1)
    for _ in range(SAMPLES):
        s = acc_general(Q(0), Q(0), Q(1), rat(g, 0, 10))
        check(6 * s["q"] == s["t"] ** 3 + 3 * s["t"] ** 2)


@case("ode-accum-renamed-true", "true", w_acc_renamed_true)
def _():
    # TRUE: b' = a, a' = 1, c' = b + a from rest: 6c = d³ + 3d² (d is time).
    return T(
        "ode-accum-renamed",
        And(b_ == 0, a_v == 0, c_q == 0, d_t == 0),
        ode({c_q: b_ + a_v, b_: a_v, a_v: 1, d_t: 1}),
        6 * c_q == d_t**3 + 3 * d_t**2,
    )


def w_acc_renamed_false():
    # FALSE: τ = 3: c = 27/6 + 9/2 = 9, while the guarantee claims 2c >= 27 (i.e. c >= 13.5).
    _cross_acc(0, 0, 1)
    s = acc_general(Q(0), Q(0), Q(1), 3)
    check(s["q"] == 9 and not (2 * s["q"] >= s["t"] ** 3))


@case("ode-accum-renamed-false", "false", w_acc_renamed_false)
def _():
    # FALSE: 2c = d³/3 + d² < d³ for d > 3/2.
    return T(
        "ode-accum-renamed-f",
        And(b_ == 0, a_v == 0, c_q == 0, d_t == 0),
        ode({c_q: b_ + a_v, b_: a_v, a_v: 1, d_t: 1}),
        2 * c_q >= d_t**3,
    )


# --------------------------------------------------------------------------- product of solutions
r_ = Real("r")


def w_product_true():
    # TRUE: v = τ, x = τ²/2, r' = x v = τ³/2, so r = τ⁴/8.
    crosscheck(lambda y: [y[1], 1.0, y[0] * y[1]], [0, 0, 0], Q(2), lambda s: [s**2 / 2, s, s**4 / 8])
    g = rng("ode-product")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 10)
        check(8 * (tau**4 / 8) == tau**4)


@case("ode-product-rhs-true", "true", w_product_true)
def _():
    # TRUE: r' = x*v with x = t²/2, v = t gives r = t⁴/8.
    return T(
        "ode-product",
        And(x == 0, v == 0, r_ == 0, t == 0),
        ode({x: v, v: 1, r_: x * v, t: 1}),
        8 * r_ == t**4,
    )


def w_product_false():
    # FALSE: τ = 2: r = 2, x·v = 2·2 = 4 > r... the guarantee r >= x*v fails (2 < 4).
    check(Q(2) ** 4 / 8 == 2 and not (Q(2) >= (Q(2) ** 2 / 2) * 2))


@case("ode-product-rhs-false", "false", w_product_false)
def _():
    # FALSE: r = t⁴/8 < x v = t³/2 for 0 < t < 4.
    return T(
        "ode-product-f", And(x == 0, v == 0, r_ == 0, t == 0), ode({x: v, v: 1, r_: x * v, t: 1}), r_ >= x * v
    )


# --------------------------------------------------------------------------- chain of integrators
x1, x2, x3, x4 = Reals("x1 x2 x3 x4")
CHAIN = {x1: x2, x2: x3, x3: x4, x4: 1, t: 1}
CHAIN_PRE = And(x1 == 0, x2 == 0, x3 == 0, x4 == 0, t == 0)


def w_chain_true():
    # TRUE: from rest, x4 = τ, x3 = τ²/2, x2 = τ³/6, x1 = τ⁴/24.
    crosscheck(
        lambda y: [y[1], y[2], y[3], 1.0], [0, 0, 0, 0], Q(3), lambda s: [s**4 / 24, s**3 / 6, s**2 / 2, s]
    )
    g = rng("ode-chain4")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 10)
        check(24 * (tau**4 / 24) == tau**4)


@case("ode-chain4-true", "true", w_chain_true)
def _():
    # TRUE: fourth integral of 1 is t⁴/24.
    return T("ode-chain4", CHAIN_PRE, ode(CHAIN), And(24 * x1 == t**4, 6 * x2 == t**3))


def w_chain_false():
    # FALSE: τ = 1: x1 = 1/24 > 1/30.
    check(Q(1, 24) > Q(1, 30))


@case("ode-chain4-false", "false", w_chain_false)
def _():
    # FALSE: x1 = t⁴/24 exceeds t⁴/30 at every t > 0.
    return T("ode-chain4-f", CHAIN_PRE, ode(CHAIN), 30 * x1 <= t**4)


p_, j_, p0, a0 = Reals("p j p0 a0")


def w_jerk_true():
    # TRUE: p' = v, v' = a, a' = j: p = p0 + v0τ + a0τ²/2 + jτ³/6 (random starts, j, τ).
    crosscheck(
        lambda y: [y[1], y[2], 0.75],
        [1, -2, 0.5],
        Q(2),
        lambda s: [
            1 - 2 * s + Q(1, 2) * s**2 / 2 + Q(3, 4) * s**3 / 6,
            -2 + Q(1, 2) * s + Q(3, 4) * s**2 / 2,
            Q(1, 2) + Q(3, 4) * s,
        ],
    )
    g = rng("ode-jerk")
    for _ in range(SAMPLES):
        P0, V0, A0, J, tau = (rat(g, -4, 4) for _ in range(5))
        tau = abs(tau)
        p = P0 + V0 * tau + A0 * tau**2 / 2 + J * tau**3 / 6
        check(6 * p == 6 * P0 + 6 * V0 * tau + 3 * A0 * tau**2 + J * tau**3)


@case("ode-jerk-chain-true", "true", w_jerk_true)
def _():
    # TRUE: third-order chain from arbitrary (p0, v0, a0) with constant jerk j.
    return T(
        "ode-jerk",
        And(p_ == p0, v == v0, a == a0, t == 0),
        ode({p_: v, v: a, a: j_, t: 1}),
        6 * p_ == 6 * p0 + 6 * v0 * t + 3 * a0 * t**2 + j_ * t**3,
    )


def w_jerk_false():
    # FALSE: p0 = v0 = 0, a0 = 1, j = 1, τ = 1: p = 1/2 + 1/6 = 2/3, claimed 1/2 + 1/3 = 5/6.
    p = Q(1, 2) + Q(1, 6)
    check(6 * p == 4 and 6 * p != 3 + 2)


@case("ode-jerk-chain-false", "false", w_jerk_false)
def _():
    # FALSE: uses j t³/3 instead of j t³/6.
    return T(
        "ode-jerk-f",
        And(p_ == p0, v == v0, a == a0, t == 0),
        ode({p_: v, v: a, a: j_, t: 1}),
        6 * p_ == 6 * p0 + 6 * v0 * t + 3 * a0 * t**2 + 2 * j_ * t**3,
    )


# --------------------------------------------------------------------------- twelve variables
A = {k: Real(f"a{k}") for k in range(1, 13)}
c_ = Real("c")
TWELVE = {
    A[1]: A[2],
    A[2]: A[10] + A[11],
    A[10]: A[11],
    A[11]: A[12],
    A[12]: 0,
    A[3]: 1,
    A[4]: A[3],
    A[5]: A[3] + A[4],
    A[6]: c_,
    A[7]: A[6] + A[5],
    A[8]: 0,
    A[9]: A[8],
}
TWELVE_PRE = And(*(A[k] == (1 if k == 12 else 0) for k in range(1, 13)), c_ == 2)


def twelve(tau):
    """a12 = 1, a11 = τ, a10 = τ²/2, a2 = τ³/6 + τ²/2, a1 = τ⁴/24 + τ³/6; a3 = τ,
    a4 = τ²/2, a5 = τ²/2 + τ³/6, a6 = 2τ, a7 = τ² + τ³/6 + τ⁴/24, a8 = a9 = 0."""
    s = Q(tau)
    return {
        1: s**4 / 24 + s**3 / 6,
        2: s**3 / 6 + s**2 / 2,
        3: s,
        4: s**2 / 2,
        5: s**2 / 2 + s**3 / 6,
        6: 2 * s,
        7: s**2 + s**3 / 6 + s**4 / 24,
        8: 0,
        9: 0,
        10: s**2 / 2,
        11: s,
        12: 1,
    }


def _cross_twelve():
    def rhs(y):
        a = {k: y[k - 1] for k in range(1, 13)}
        d = {
            1: a[2],
            2: a[10] + a[11],
            10: a[11],
            11: a[12],
            12: 0,
            3: 1,
            4: a[3],
            5: a[3] + a[4],
            6: 2,
            7: a[6] + a[5],
            8: 0,
            9: a[8],
        }
        return [d[k] for k in range(1, 13)]

    crosscheck(rhs, [0] * 11 + [1], Q(5, 2), lambda s: [twelve(s)[k] for k in range(1, 13)])


def w_twelve_true():
    # TRUE: the closed forms above (a10/a11 sort before a2 by name; a3 is time).
    _cross_twelve()
    g = rng("ode-12")
    for _ in range(SAMPLES):
        s = twelve(rat(g, 0, 10))
        check(
            24 * s[1] == s[3] ** 4 + 4 * s[3] ** 3 and 24 * s[7] == 24 * s[3] ** 2 + 4 * s[3] ** 3 + s[3] ** 4
        )


@case("ode-12vars-true", "true", w_twelve_true)
def _():
    # TRUE: 24 a1 = a3⁴ + 4a3³ and 24 a7 = 24a3² + 4a3³ + a3⁴ (twelve variables, names a1..a12).
    return T(
        "ode-12",
        TWELVE_PRE,
        ode(TWELVE),
        And(24 * A[1] == A[3] ** 4 + 4 * A[3] ** 3, 24 * A[7] == 24 * A[3] ** 2 + 4 * A[3] ** 3 + A[3] ** 4),
    )


def w_twelve_false():
    # FALSE: τ = 3: a1 = 81/24 + 27/6 = 63/8, but 8 a1 >= a3⁴ claims 63 >= 81.
    _cross_twelve()
    s = twelve(3)
    check(s[1] == Q(63, 8) and not (8 * s[1] >= s[3] ** 4))


@case("ode-12vars-false", "false", w_twelve_false)
def _():
    # FALSE: a1 = t⁴/24 + t³/6 < t⁴/8 once t > 2.
    return T("ode-12-f", TWELVE_PRE, ode(TWELVE), 8 * A[1] >= A[3] ** 4)


def w_twelve_false2():
    # FALSE: τ = 1: a7 = 1 + 1/6 + 1/24 = 29/24 but 24 a7 <= 24 claims 29 <= 24.
    _cross_twelve()
    s = twelve(1)
    check(s[7] == Q(29, 24) and not (24 * s[7] <= 24))


@case("ode-12vars-a7-false", "false", w_twelve_false2)
def _():
    # FALSE: a7 = t² + t³/6 + t⁴/24 exceeds t² (a3 = t) for every t > 0.
    return T("ode-12-f2", TWELVE_PRE, ode(TWELVE), a7_le())


def a7_le():
    return A[7] <= A[3] ** 2


# --------------------------------------------------------------------------- constants in the rhs
y_, d_, e_ = Reals("y d e")


def w_const_true():
    # TRUE: y' = e, x' = c y + d from 0: y = eτ, x = c e τ²/2 + dτ.
    crosscheck(
        lambda z: [3 * z[1] + 0.5, -2.0], [0, 0], Q(2), lambda s: [3 * (-2) * s**2 / 2 + Q(1, 2) * s, -2 * s]
    )
    g = rng("ode-const")
    for _ in range(SAMPLES):
        c, d, e, tau = rat(g, -5, 5), rat(g, -5, 5), rat(g, -5, 5), rat(g, 0, 8)
        xx = c * e * tau**2 / 2 + d * tau
        check(2 * xx == c * e * tau**2 + 2 * d * tau)


@case("ode-const-rhs-true", "true", w_const_true)
def _():
    # TRUE: 2x = c e t² + 2 d t.
    return T(
        "ode-const",
        And(x == 0, y_ == 0, t == 0),
        ode({x: c_ * y_ + d_, y_: e_, t: 1}),
        2 * x == c_ * e_ * t**2 + 2 * d_ * t,
    )


def w_const_false():
    # FALSE: c = e = 0, d = 1, τ = 1: x = 1 but the guarantee says 2x = 0.
    check(2 * Q(1) != 0)


@case("ode-const-rhs-false", "false", w_const_false)
def _():
    # FALSE: forgets the constant drift d.
    return T(
        "ode-const-f",
        And(x == 0, y_ == 0, t == 0),
        ode({x: c_ * y_ + d_, y_: e_, t: 1}),
        2 * x == c_ * e_ * t**2,
    )


# --------------------------------------------------------------------------- domains along the flow
def w_middle_true():
    # TRUE: x = 2s - s² > 0 on (0, 2), so the domain x <= 0 only admits τ = 0, where v = 2.
    crosscheck(lambda z: [z[1], -2.0], [0, 2], Q(3), lambda s: [2 * s - s**2, 2 - 2 * s])
    g = rng("ode-mid")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 6, den=256)
        if tau == 0:
            continue
        s = min(tau, Q(1))  # a time in (0, τ] where the domain fails
        check(2 * s - s**2 > 0)  # so τ is not a valid duration


@case("ode-domain-holds-at-ends-not-middle-true", "true", w_middle_true)
def _():
    # TRUE: domain x <= 0 holds at s = 0 and s = 2 but not between: only the 0-length run exists.
    return T("ode-mid", And(x == 0, v == 2), ode({x: v, v: -2}, x <= 0), v == 2)


def w_middle_false():
    # FALSE: τ = 2: x(s) = 2s - s² <= 1 on [0, 2] (max 1 at s = 1), and v(2) = -2 < 0.
    for s in [Q(k, 64) for k in range(129)]:
        check(2 * s - s**2 <= 1)
    check(2 - 2 * 2 < 0)


@case("ode-domain-max-touches-false", "false", w_middle_false)
def _():
    # FALSE: the domain x <= 1 is touched (not crossed) at s = 1; the run to s = 2 ends with v = -2.
    return T("ode-mid-f", And(x == 0, v == 2), ode({x: v, v: -2}, x <= 1), v >= 0)


def w_gap_true():
    # TRUE: any τ > 1 has s = (1 + min(τ, 2))/2 in (1, 2) ∩ (0, τ], where (s-1)(s-2) < 0, so
    # it is no valid duration; every valid τ <= 1 ends with t = τ <= 1.
    g = rng("ode-gap")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 5, den=128)
        if tau > 1:
            s = (1 + min(tau, Q(2))) / 2
            check(1 < s < 2 and s <= tau and (s - 1) * (s - 2) < 0)
        else:
            check(tau <= 1)


@case("ode-domain-gap-quadratic-true", "true", w_gap_true)
def _():
    # TRUE: the domain (t-1)(t-2) >= 0 is false on (1, 2): the clock cannot get past 1.
    return T("ode-gap", t == 0, ode({t: 1}, (t - 1) * (t - 2) >= 0), t <= 1)


def w_gap_cubic_true():
    # TRUE: (x-1)(x-2)(x+5) < 0 on (1, 2) (two factors of opposite sign, one positive).
    g = rng("ode-gap3")
    for _ in range(SAMPLES):
        s = rat(g, 1, 2, den=1024)
        if 1 < s < 2:
            check((s - 1) * (s - 2) * (s + 5) < 0)


@case("ode-domain-gap-cubic-true", "true", w_gap_cubic_true)
def _():
    # TRUE: cubic domain true at x = 0 and x = 3 but false on (1, 2): x never exceeds 1.
    return T("ode-gap3", x == 0, ode({x: 1}, (x - 1) * (x - 2) * (x + 5) >= 0), x <= 1)


def w_gap_cubic_false():
    # FALSE: x = 1 is reached (domain value 0 there), and 1 <= 1/2 fails.
    check((Q(1) - 1) * (Q(1) - 2) * (Q(1) + 5) >= 0)
    for s in [Q(k, 64) for k in range(65)]:
        check((s - 1) * (s - 2) * (s + 5) >= 0)


@case("ode-domain-gap-cubic-false", "false", w_gap_cubic_false)
def _():
    # FALSE: the flow may run to x = 1 (domain holds on [0, 1]).
    return T("ode-gap3-f", x == 0, ode({x: 1}, (x - 1) * (x - 2) * (x + 5) >= 0), x <= Q(1, 2))


def w_boundary_true():
    # TRUE: x = -s²/2 < 0 for s > 0, so from x = 0 only the 0-length run satisfies x >= 0.
    g = rng("ode-bstart")
    for _ in range(SAMPLES):
        s = rat(g, 0, 5, den=256)
        if s > 0:
            check(-(s**2) / 2 < 0)


@case("ode-boundary-start-true", "true", w_boundary_true)
def _():
    # TRUE: starts on the boundary of x >= 0 moving out: no positive duration is allowed.
    return T("ode-bstart", And(x == 0, v == 0), ode({x: v, v: -1}, x >= 0), And(x == 0, v == 0))


def w_boundary_false():
    # FALSE: x = s - s²/2 >= 0 on [0, 2] and v(2) = 1 - 2 = -1 < 0.
    for s in [Q(k, 64) for k in range(129)]:
        check(s - s**2 / 2 >= 0)
    check(1 - Q(2) < 0)


@case("ode-boundary-start-inward-false", "false", w_boundary_false)
def _():
    # FALSE: starts on the boundary moving in, comes back to it at s = 2 with v = -1.
    return T("ode-bstart-f", And(x == 0, v == 1), ode({x: v, v: -1}, x >= 0), v >= 0)


def w_strict_start_true():
    # TRUE: the domain t < 1 is false at the start (t = 1): the ODE has no run at all.
    check(not (Q(1) < 1))


@case("ode-domain-false-at-start-true", "true", w_strict_start_true)
def _():
    # TRUE: vacuous — no run exists when the domain fails initially, so x == 5 is never violated.
    return T("ode-strict0", And(t == 1, x == 0), ode({x: 1, t: 1}, t < 1), x == 5)


def w_strict_end_true():
    # TRUE: with t' = 1 from 0 and domain t < 1, every reachable state has t < 1, x = t < 1.
    g = rng("ode-strict1")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 1, den=512)
        if tau < 1:
            check(tau < 1)


@case("ode-strict-domain-never-reaches-true", "true", w_strict_end_true)
def _():
    # TRUE: a strict domain is never reached: x = t < 1.
    return T("ode-strict1", And(t == 0, x == 0), ode({x: 1, t: 1}, t < 1), x < 1)


B_, T_ = Reals("b T")


def w_brake_true():
    # TRUE: p - p0 = v0 s - b s²/2 <= v0²/(2b) (maximum of a concave parabola) for all s.
    g = rng("ode-brake")
    for _ in range(SAMPLES):
        V0, b, tau = rat(g, 0, 10), rat(g, 1, 10, den=8) / 2, rat(g, 0, 20)
        if V0 - b * tau < 0:
            tau = V0 / b  # the domain v >= 0 stops the flow there
        check(V0 * tau - b * tau**2 / 2 <= V0**2 / (2 * b))


@case("ode-brake-stopping-distance-true", "true", w_brake_true)
def _():
    # TRUE: braking from v0 >= 0 with b > 0 travels at most v0²/(2b).
    return T(
        "ode-brake",
        And(p_ == p0, v == v0, v0 >= 0, B_ > 0),
        ode({p_: v, v: -B_}, v >= 0),
        p_ <= p0 + v0**2 / (2 * B_),
    )


def w_brake_false():
    # FALSE: v0 = 2, b = 1, τ = 2 (v = 0 at the end, domain holds): p - p0 = 4 - 2 = 2 > 4/4 = 1.
    for s in [Q(k, 32) for k in range(65)]:
        check(2 - s >= 0)
    check(2 * 2 - Q(1) * 4 / 2 == 2 and not (2 <= Q(4) / 4))


@case("ode-brake-half-distance-false", "false", w_brake_false)
def _():
    # FALSE: claims only v0²/(4b).
    return T(
        "ode-brake-f",
        And(p_ == p0, v == v0, v0 >= 0, B_ > 0),
        ode({p_: v, v: -B_}, v >= 0),
        p_ <= p0 + v0**2 / (4 * B_),
    )


def w_clock_false():
    # FALSE: τ = 5 keeps t <= 5 along the flow and ends with x = 5 > 4.
    check(Q(5) <= 5 and not (Q(5) <= 4))


@case("ode-clock-domain-false", "false", w_clock_false)
def _():
    # FALSE: the clock domain t <= 5 lets x reach 5.
    return T("ode-clock-f", And(x == 0, t == 0), ode({x: 1, t: 1}, t <= 5), x <= 4)


def w_clock_seq_true():
    # TRUE: after t := 0 and the flow, x grows by exactly t <= T_ <= ... x = x0 + t, t <= 3.
    g = rng("ode-clock-seq")
    for _ in range(SAMPLES):
        X0, tau = rat(g, -5, 5), rat(g, 0, 3)
        check(X0 + tau <= X0 + 3)


@case("ode-clock-reset-true", "true", w_clock_seq_true)
def _():
    # TRUE: the clock is reset before the flow, so x grows by at most 3.
    return T("ode-clock-seq", x == x0, seq(assign(t, 0), ode({x: 1, t: 1}, t <= 3)), x <= x0 + 3)


# --------------------------------------------------------------------------- padded systems
# The same accumulator x' = v, v' = a, q' = x + v with extra variables around it: large
# systems are where an implementation that orders or renames its symbols can go wrong.
W = [Real(f"w{k}") for k in range(13)]


def w_padded_true():
    # TRUE: the padding does not touch x, v, q: 6q = a t³ + 3a t² + 6 v0 t + 3 v0 t² from x = 0.
    g = rng("ode-padded")
    _cross_acc(0, Q(1, 3), Q(-2))
    for _ in range(SAMPLES):
        V0, a_, tau = rat(g, -5, 5), rat(g, -5, 5), rat(g, 0, 10)
        s = acc_general(Q(0), V0, a_, tau)
        check(6 * s["q"] == a_ * tau**3 + 3 * a_ * tau**2 + 6 * V0 * tau + 3 * V0 * tau**2)


PAD_PRE = And(x == 0, v == v0, q == 0, t == 0)
PAD_GOAL = 6 * q == a * t**3 + 3 * a * t**2 + 6 * v0 * t + 3 * v0 * t**2


@case("ode-padded-7-before-true", "true", w_padded_true)
def _():
    # TRUE: seven constant variables w0..w6 listed before the accumulator.
    return T("ode-pad7", PAD_PRE, ode({**{w: 0 for w in W[:7]}, x: v, v: a, q: x + v, t: 1}), PAD_GOAL)


@case("ode-padded-9-after-true", "true", w_padded_true)
def _():
    # TRUE: nine clocks w0..w8 listed after the accumulator.
    return T("ode-pad9", PAD_PRE, ode({x: v, v: a, q: x + v, t: 1, **{w: 1 for w in W[:9]}}), PAD_GOAL)


def w_padded_false():
    # FALSE: v0 = 0, a = 1, τ = 2: q = 8/6 + 2 = 10/3 so 2q = 20/3 < 8 = a t³.
    s = acc_general(Q(0), Q(0), Q(1), 2)
    check(s["q"] == Q(10, 3) and not (2 * s["q"] >= 8))


@case("ode-padded-12-after-false", "false", w_padded_false)
def _():
    # FALSE: 2q = t³/3 + t² < t³ for t > 3/2 (a = 1, v0 = 0), twelve clocks listed after.
    return T(
        "ode-pad12-f",
        And(x == 0, v == 0, a == 1, q == 0, t == 0),
        ode({x: v, v: a, q: x + v, t: 1, **{w: 1 for w in W[:12]}}),
        2 * q >= a * t**3,
    )


@case("ode-padded-8-before-false", "false", w_padded_false)
def _():
    # FALSE: same claim, eight constants listed before.
    return T(
        "ode-pad8-f",
        And(x == 0, v == 0, a == 1, q == 0, t == 0),
        ode({**{w: 0 for w in W[:8]}, x: v, v: a, q: x + v, t: 1}),
        2 * q >= a * t**3,
    )


@case("ode-padded-10-after-exact-true", "true", w_padded_true)
def _():
    # TRUE: exact q with ten clocks after (the clocks also equal t: not claimed).
    return T("ode-pad10", PAD_PRE, ode({x: v, v: a, q: x + v, t: 1, **{w: 1 for w in W[:10]}}), PAD_GOAL)


# --------------------------------------------------------------------------- domains: !=, ∨, strict vertex
def w_neq_true():
    # TRUE: the domain x != 1 fails at s = 1, so every run has τ < 1 and ends with x = τ < 1.
    g = rng("ode-neq")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 3, den=256)
        if tau >= 1:
            check(Q(1) <= tau)  # s = 1 lies in [0, τ] and violates x != 1: not a run
        else:
            check(tau < 1)


@case("ode-domain-disequality-true", "true", w_neq_true)
def _():
    # TRUE: the flow cannot cross x = 1 inside the domain x != 1.
    return T("ode-neq", x == 0, ode({x: 1}, x != 1), x < 1)


@case(
    "ode-domain-disequality-false",
    "false",
    lambda: check(all(s != 1 for s in (Q(k, 8) for k in range(7))) and not (Q(3, 4) <= Q(1, 2))),
)
def _():
    # FALSE: τ = 3/4 stays in x != 1 and ends with x = 3/4 > 1/2.
    return T("ode-neq-f", x == 0, ode({x: 1}, x != 1), x <= Q(1, 2))


def w_or_true():
    # TRUE: x = s leaves x <= 1 ∨ x >= 2 on (1, 2): no run passes s = 3/2.
    g = rng("ode-or")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 4, den=128)
        if tau > 1:
            s = (1 + min(tau, Q(2))) / 2
            check(1 < s < 2 and s <= tau and not (s <= 1 or s >= 2))


@case("ode-domain-disjunction-gap-true", "true", w_or_true)
def _():
    # TRUE: a disjunctive domain with a gap (1, 2) that the flow cannot jump.
    return T("ode-or", x == 0, ode({x: 1}, (x <= 1) | (x >= 2)), x <= 1)


def w_vertex_strict_true():
    # TRUE: x = (s - 1)², v = 2(s - 1); the strict domain x > 0 fails at s = 1, so τ < 1, v < 0.
    crosscheck(lambda z: [z[1], 2.0], [1, -2], Q(3, 2), lambda s: [(s - 1) ** 2, 2 * (s - 1)])
    g = rng("ode-vertex")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 3, den=256)
        if tau >= 1:
            check((Q(1) - 1) ** 2 == 0)  # s = 1 in [0, τ] violates x > 0
        else:
            check(2 * (tau - 1) < 0)


@case("ode-domain-strict-touch-at-vertex-true", "true", w_vertex_strict_true)
def _():
    # TRUE: the parabola touches 0 at its vertex; a strict domain stops it there.
    return T("ode-vertex", And(x == 1, v == -2), ode({x: v, v: 2}, x > 0), v < 0)


def w_vertex_nonstrict_false():
    # FALSE: with x >= 0 the flow passes the vertex; τ = 2: x = 1 >= 0 all along, v = 2 >= 0.
    for s in [Q(k, 64) for k in range(129)]:
        check((s - 1) ** 2 >= 0)
    check(2 * (Q(2) - 1) == 2)


@case("ode-domain-nonstrict-touch-at-vertex-false", "false", w_vertex_nonstrict_false)
def _():
    # FALSE: a non-strict domain lets the flow touch 0 and come back up with v > 0.
    return T("ode-vertex-f", And(x == 1, v == -2), ode({x: v, v: 2}, x >= 0), v < 0)
