"""The RCM paper, the energy side of Theorem 1: passivity (28)-(33), the whole-tool capsule (34)-(37),
and the premises the paper's theorem leaves unstated, each shown necessary by a refuted variant.

Symbols: w = x_f' (the free-motion velocity of (27), four coordinates: the tool axis and three
rotations about the RCM point), u = Z J^T F_th (the human's push mapped into them, (22)),
fr = Z J^T F_r (the barrier's), D = diag(D_f) (43)-(45), Phi = sum V_i, e = int u.w (the energy
the human has supplied), q = d_min int |w|^2 (the energy the damping has at least removed).

Stated glue (outside the decidable fragment, as in rcm.py): Phi' = -fr.w is the chain rule for a
conservative barrier (fr = -grad sum V_i mapped by (36)); the human force, the barrier force
and the damping are held over each flow (any values, re-chosen at every step), which is how
their time variation enters a loop of flows.
"""

from __future__ import annotations

from certiloop.models.lang.programs import assign, branch, choice, havoc, loop, ode, seq, skip, test
from certiloop.models.lang.terms import TRUE, And, Reals
from certiloop.models.lang.theorem import Theorem
from certiloop.studies.rcm.models.constraint import D0, K_BAR, H

# --------------------------------------------------------------------------- (28)-(33): passivity on S

W4, U4, R4, D4 = (Reals(f"{p}1 {p}2 {p}3 {p}4") for p in ("w", "u", "fr", "D"))
phi, sup, dis, dmin, E0, Eb = Reals("Phi e q dmin E0 Ebar")


def _sum(terms):
    out = terms[0]
    for t in terms[1:]:
        out = out + t
    return out


def passivity() -> Theorem:
    """Claim 3, (28)-(33), strict output passivity of the free motion (27) on S: the storage
    H = |w|^2/2 + sum V_i obeys H(t) + d_min int |w|^2 <= H(0) + int u.w for any human push,
    any conservative barrier and any damping D_f >= d_min >= 0 (diagonal, as Table 1's).
    dI on H - e + q: its derivative is sum (d_min - D_j) w_j^2 <= 0."""
    return _passivity("rcm.passivity", dmin, "proved",
                      "claim 3, (28)–(33): H + d_min∫|w|² <= H(0) + ∫u·w on S (strict output passivity, dI)")


def _passivity(name: str, floor, expected: str, description: str) -> Theorem:
    """The continuous passivity model with the damping bounded below by `floor` (d_min in the
    theorem; the mutation tests lower it)."""
    kinetic = _sum([w * w for w in W4]) / 2
    flow = ode({**{w: u + r - d * w for w, u, r, d in zip(W4, U4, R4, D4)},
                phi: -_sum([r * w for r, w in zip(R4, W4)]),
                sup: _sum([u * w for u, w in zip(U4, W4)]),
                dis: dmin * _sum([w * w for w in W4])},
               invariants=[kinetic + phi - sup + dis <= E0])
    step = seq(*(havoc(x) for x in (*U4, *R4, *D4)), test(And(*(d >= floor for d in D4))), flow)
    return Theorem(
        name=name,
        assumptions=And(dmin >= 0, E0 == kinetic + phi - sup + dis),
        program=loop(step, invariant=kinetic + phi - sup + dis <= E0, label="admittance loop"),
        guarantee=kinetic + phi + dis <= E0 + sup,
        expected=expected,
        constants=(dmin, E0),
        description=description,
    )


# One axial period of (27) at h = 4 ms with the kinematics frozen: the human's u, the barrier's
# fr and the damping D held over the period. The storage is w^2/2 + Phi, the supply u times the
# distance moved. A discrete-gradient barrier is charged for the distance it acts over
# (Phi := Phi - fr ds), i.e. it is conservative over the step.
wa, wn, ua, fa, da = Reals("w wn u fr D")


def _midpoint(name: str, damping, charged: bool, expected: str, description: str) -> Theorem:
    """Implicit midpoint: (1 + hD/2) wn = w + h (u + fr) - hD w/2, ds = h (w + wn)/2; then
    dH = u ds - hD ((w + wn)/2)^2, so the step is passive iff D >= 0 and the barrier conservative."""
    ds = H * (wa + wn) / 2
    step = seq(havoc(ua), havoc(fa), havoc(da), test(damping),
               assign(wn, (wa + H * (ua + fa) - H * da * wa / 2) / (1 + H * da / 2)),
               assign(phi, phi - fa * ds) if charged else skip(),
               assign(sup, sup + ua * ds), assign(wa, wn))
    storage = wa * wa / 2 + phi
    return Theorem(
        name=name,
        assumptions=E0 == storage - sup,
        program=loop(step, invariant=storage - sup <= E0, label="250 Hz loop"),
        guarantee=storage <= E0 + sup,
        expected=expected,
        constants=(E0,),
        unroll=2,
        check_nonblocking=expected == "proved",
        description=description,
    )


def passivity_step_midpoint() -> Theorem:
    """The discrete fix for claim 3: an implicit-midpoint period with a discrete-gradient
    barrier is passive for any D >= 0 (dH = u ds - hD w_mid^2)."""
    return _midpoint("rcm.passivity_step_midpoint", da >= 0, True, "proved",
                     "claim 3 at 4 ms: implicit midpoint + discrete-gradient barrier is passive (D >= 0)")


def passivity_negative_damping() -> Theorem:
    """Premise D_f >= 0 dropped (damping allowed down to -1 N s/m): a moving tool gains
    energy with no human supply."""
    return _midpoint("rcm.passivity_negative_damping", da >= -1, True, "refuted",
                     "premise D_f >= 0 dropped: negative damping raises the storage with zero supply")


def passivity_nonconservative() -> Theorem:
    """Premise 'the barrier is a potential force' dropped: its work is not stored in Phi
    (a force that is not -grad V, e.g. summed with the wrong sign or velocity dependent), so
    it can push the tool's energy up with zero human supply."""
    return _midpoint("rcm.passivity_nonconservative", da >= 0, False, "refuted",
                     "premise 'barrier conservative' dropped: the barrier's work raises the storage")


def passivity_step_explicit() -> Theorem:
    """The paper's explicit Euler period (ds = h w with the old w, w := w + h (u + fr - D w)),
    barrier charged exactly for ds: dH - supply = h^2 (u + fr - D w)^2/2 - hD w^2, positive
    from rest. The paper's implementation is not passive, whatever the damping."""
    step = seq(havoc(ua), havoc(fa), havoc(da), test(da >= 0),
               assign(phi, phi - fa * H * wa), assign(sup, sup + ua * H * wa),
               assign(wa, wa + H * (ua + fa - da * wa)))
    storage = wa * wa / 2 + phi
    return Theorem(
        name="rcm.passivity_step_explicit",
        assumptions=E0 == storage - sup,
        program=loop(step, invariant=storage - sup <= E0, label="250 Hz loop"),
        guarantee=storage <= E0 + sup,
        expected="refuted",
        constants=(E0,),
        unroll=2,
        description="the paper's 4 ms explicit Euler is not passive: a push from rest adds h²u²/2 unsupplied",
    )


# --------------------------------------------------------------------------- (34)-(37): the capsule

A3, B3, C3 = (Reals(f"{p}1 {p}2 {p}3") for p in ("pa", "pb", "pc"))
sig, tau, num, den = Reals("sigma tau num den")


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


def _capsule_nearest(name: str, clamp: bool, expected: str, description: str) -> Theorem:
    """The tool is the segment a + sigma (b - a), sigma in [0, 1] (tip a, shaft towards b). The
    nearest tool point to a cloud point c is sigma* = clamp(((c - a).(b - a))/|b - a|^2, 0, 1) (34):
    it is on the tool and no tool point is closer. In the distance |a + s(b - a) - c|^2 =
    s^2 den - 2 s num + |c - a|^2 only den = |b - a|^2 and num = (c - a).(b - a) depend on s."""
    u = [b - a for a, b in zip(A3, B3)]
    d = [c - a for a, c in zip(A3, C3)]
    project = assign(sig, num / den)
    pick = choice(branch("behind the tip", test(num <= 0), assign(sig, 0)),
                  branch("beyond the shaft end", test(num >= den), assign(sig, 1)),
                  branch("along the shaft", test(And(0 < num, num < den)), project)) if clamp else project
    return Theorem(
        name=name,
        assumptions=_dot(u, u) > 0,
        program=seq(assign(num, _dot(d, u)), assign(den, _dot(u, u)), pick,
                    havoc(tau), test(And(0 <= tau, tau <= 1))),
        guarantee=And(0 <= sig, sig <= 1, sig * sig * den - 2 * sig * num <= tau * tau * den - 2 * tau * num),
        expected=expected,
        description=description,
    )


def capsule_nearest_point() -> Theorem:
    """(34): the clamped projection is the tool point nearest to a cloud point."""
    return _capsule_nearest("rcm.capsule_nearest_point", True, "proved",
                            "(34): σ* = clamp((c−a)·(b−a)/|b−a|², 0, 1) is the nearest tool point")


def capsule_unclamped() -> Theorem:
    """(34) without the clamp: the projection of a point beside the tip is off the tool."""
    return _capsule_nearest("rcm.capsule_unclamped", False, "refuted",
                            "(34) without the clamp: σ* leaves [0, 1], a point that is not on the tool")


g_, w1, v2, L_, e_, c1, c2, u1, u2, Dc1, Dc2 = Reals("gap w1 w2 L e c1 c2 u1 u2 D1 D2")


def _capsule(name: str, energy_cap: bool, expected: str, description: str, lever2=None) -> Theorem:
    """The whole tool (34)-(37) in continuous time. gap = rho* - d_c - r is the distance from
    the capsule (radius r) to the nearest cloud ball; the nearest point p* moves towards it at
    c.w, where w = (w1, w2) are free velocities (along the axis and about the RCM point) and c
    the lever of p* (its Jacobian row along the normal, held over a flow). The barrier force
    f = k_v (d_0 - gap) acts at p*; (36) maps it to the generalised force -c f, whose power is
    -f (c.w): exactly what the barrier's potential k L^2/2 stores. So the storage
    |w|^2/2 + k L^2/2 - e never grows, and with finite human energy e <= Ebar the capsule's
    potential stays below E0 + Ebar: rcm.barrier_clearance turns that into a capsule
    clearance d_0 (1 - sqrt(1 - Y)) > 0 for the whole tool."""
    y = g_ * (2 * D0 - g_) / D0**2
    vel = c1 * w1 + c2 * v2
    force = 2 * K_BAR * L_ * (D0 - g_) / (D0**2 * y)
    domain = And(0 < g_, g_ <= D0, e_ <= Eb) if energy_cap else And(0 < g_, g_ <= D0)
    storage = (w1 * w1 + v2 * v2) / 2 + K_BAR / 2 * L_**2 - e_
    # (36): the force at p* maps to the generalised force -c f (a mutant passes another lever)
    lever = c2 if lever2 is None else lever2
    flow = ode({g_: -vel, w1: u1 - Dc1 * w1 - c1 * force, v2: u2 - Dc2 * v2 - lever * force,
                L_: 2 * (D0 - g_) * vel / (D0**2 * y), e_: u1 * w1 + u2 * v2},
               domain, invariants=[storage <= E0])
    step = seq(*(havoc(x) for x in (u1, u2, c1, c2, Dc1, Dc2)), test(And(Dc1 >= 0, Dc2 >= 0)), flow)
    start = And(E0 == storage, 0 < g_, g_ <= D0, *((e_ <= Eb,) if energy_cap else ()))
    return Theorem(
        name=name,
        assumptions=start,
        program=loop(step, invariant=And(storage <= E0, *((e_ <= Eb,) if energy_cap else ())),
                     label="admittance loop"),
        guarantee=K_BAR / 2 * L_**2 <= E0 + Eb,
        expected=expected,
        constants=(E0, Eb),
        description=description,
    )


def capsule_continuous() -> Theorem:
    """The capsule extension of claim 4 in continuous time, finite human energy."""
    return _capsule("rcm.capsule_continuous", True, "proved",
                    "(34)–(37), continuous time: the whole-tool capsule's potential stays <= E0 + Ē (dI)")


# --------------------------------------------------------------------------- omitted premises

Yb, s_ = Reals("Y gap")


def _clearance(name: str, premise, expected: str, description: str) -> Theorem:
    """rcm.barrier_clearance with its premise on Y = exp(-sqrt(2E/k)) varied: the energy bound
    V_i <= E gives 1 - psi >= Y; the clearance needs Y > 0, i.e. a finite E."""
    return Theorem(
        name=name,
        assumptions=And(premise, Yb <= 1, s_ * (2 * D0 - s_) >= D0**2 * Yb),
        program=test(TRUE),
        guarantee=s_ > 0,
        expected=expected,
        description=description,
    )


def clearance_unbounded_energy() -> Theorem:
    """Premise 'finite human energy' dropped: E -> infinity makes Y = exp(-sqrt(2E/k)) -> 0, and
    1 - psi >= 0 admits gap 0, the tip on the forbidden region's surface. Theorem 1 states no
    bound on the human's energy; without one no clearance follows."""
    return _clearance("rcm.clearance_unbounded_energy", Yb >= 0, "refuted",
                      "premise 'finite human energy' dropped: Y = e^(−√(2E/k)) → 0 admits gap 0")


sv = Reals("spacing")[0]
U3 = Reals("u1 u2 u3")


def _cloud_cover(name: str, dc_squared, expected: str, description: str) -> Theorem:
    """(8): O_c is the union of balls of radius d_c around the cloud's points, one per voxel of
    side s (density rho = 1/s^3). It covers the true region only if every point of a voxel is
    within d_c of the voxel's cloud point (its centre): u in [-s/2, s/2]^3 gives |u|^2 <= d_c^2
    (d_c enters only squared, so it is written as d_c^2 in s)."""
    return Theorem(
        name=name,
        assumptions=sv > 0,
        program=seq(*(seq(havoc(u), test(And(-sv / 2 <= u, u <= sv / 2))) for u in U3)),
        guarantee=_dot(U3, U3) <= dc_squared,
        expected=expected,
        constants=(sv,),
        description=description,
    )


def cloud_cover() -> Theorem:
    """(8) with the paper's d_c = sqrt(3)/(2 rho^(1/3)) = sqrt(3) s/2: every voxel point is covered."""
    return _cloud_cover("rcm.cloud_cover", 3 * sv * sv / 4, "proved",
                        "(8): balls of radius d_c = √3·s/2 around the voxel points cover every voxel")


def cloud_cover_half_spacing() -> Theorem:
    """Premise of (8): with d_c = s/2 (the ball inscribed in the voxel) the corners are outside
    O_c, so 'never in O_c' would not keep the tool out of the true region."""
    return _cloud_cover("rcm.cloud_cover_half_spacing", sv * sv / 4, "refuted",
                        "(8) with d_c = s/2: a voxel's corner is outside O_c though inside the region")
