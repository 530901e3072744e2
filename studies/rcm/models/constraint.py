"""Passive RCM admittance control with forbidden regions (the RCM paper, LWR4+, 250 Hz).

The paper's Theorem 1 claims, for the target dynamics (22)-(23): (1) constraint and free
motion are decoupled, (2) the RCM error x_c converges exponentially, (3) passivity, (4) the
tip never enters the forbidden region O_c. The models below check the algebra behind (1)
and (2) exactly, prove (4) in continuous time under its premises, and show that the
paper's 4 ms explicit Euler step breaks (4), together with a sampled-data guard that
restores it.

Symbols: r = p_t - p_c (tip relative to the RCM point), n = tool axis, a, o = the other two
columns of the tool frame (B_c = [a o]), x_c = B_c^T r (1). In the axial reduction of (27)
the gap s = rho - d_c is the distance from the tip to the nearest cloud ball, w the
approach speed (towards the cloud), F the human push along the axis.

Outside the decidable fragment (stated glue, see the README): the chain rule that makes
the model's L equal ln(1/(1 - psi)) along a flow, and the exponential functions in the
damping (43)-(45), which appear only through proved polynomial bounds.
"""

from __future__ import annotations

from fractions import Fraction

from certiloop.models.lang.programs import assign, branch, choice, havoc, loop, ode, seq, test
from certiloop.models.lang.terms import TRUE, And, Implies, Or, Reals
from certiloop.models.lang.theorem import Theorem

# --------------------------------------------------------------------------- Table 1

H = Fraction(1, 250)        # the paper's control period, 4 ms (250 Hz, explicit Euler)
ALPHA = 25                  # alpha = beta = 25
D0 = Fraction(23, 2000)     # d_0 = 0.0115 m, width of the barrier's band
K_BAR = Fraction(1, 100)    # k_i = 0.01
DC1, Q1, M1, G1, C1 = 10, 25, 22, 60, Fraction(1, 100)   # D_f element 1 (the tool axis)


def _vec(name: str):
    return Reals(f"{name}1 {name}2 {name}3")


def _cross(u, v):
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


# --------------------------------------------------------------------------- (2)-(4), (15): null space

a_, o_, n_, r_ = _vec("a"), _vec("o"), _vec("n"), _vec("r")
E3 = ([1, 0, 0], [0, 1, 0], [0, 0, 1])


def _ax_rows():
    """A_x = B_c^T [I  r^] (4): row b is [b^T, b^T r^], and b^T r^ w = (b x r) . w."""
    return [list(b) + _cross(b, r_) for b in (a_, o_)]


def _zx_rows(sign: int):
    """Z_x (15): [n^T 0] and the rows of [r^ I] (row j of r^ is e_j^T r^: e_j . (r x u)).
    sign = -1 builds the mutant with (p_c - p_t)^ in place of (p_t - p_c)^."""
    r1, r2, r3 = r_
    hat = [[0, -r3, r2], [r3, 0, -r1], [-r2, r1, 0]]
    rows = [list(n_) + [0, 0, 0]]
    for j, e in enumerate(E3):
        rows.append([sign * c if not isinstance(c, int) else 0 for c in hat[j]] + list(e))
    return rows


def _inner(u, v):
    """u . v without the terms that are literally zero (readable counterexamples)."""
    terms = []
    for x, y in zip(u, v):
        if isinstance(x, int) and isinstance(y, int):
            if x * y:
                terms.append(x * y)
        elif isinstance(x, int) or isinstance(y, int):
            c, t = (x, y) if isinstance(x, int) else (y, x)
            if c:
                terms.append(t if c == 1 else c * t)
        else:
            terms.append(x * y)
    out = terms[0] if terms else 0
    for t in terms[1:]:
        out = out + t
    return out


AZ = [Reals(f"AZ{i}1 AZ{i}2 AZ{i}3 AZ{i}4") for i in (1, 2)]   # the entries of A_x Z_x^T


def _nullspace(name: str, sign: int, expected: str, description: str) -> Theorem:
    entries = [assign(AZ[i][j], _inner(ra, rz))
               for i, ra in enumerate(_ax_rows()) for j, rz in enumerate(_zx_rows(sign))]
    frame = And(_dot(a_, n_) == 0, _dot(o_, n_) == 0)   # B_c ⟂ n: all that (15) needs
    return Theorem(
        name=name,
        assumptions=frame,
        program=seq(*(havoc(x) for x in r_), *entries),    # any tip position
        guarantee=And(*(e == 0 for row in AZ for e in row)),
        expected=expected,
        description=description,
    )


def nullspace() -> Theorem:
    """(15): A_x Z_x^T = 0, all 8 entries, for any tip position, any axis n and any
    B_c = [a o] orthogonal to it (3-D components, exact; unit lengths and a ⟂ o are not
    needed, so they are not assumed)."""
    return _nullspace("rcm.nullspace", 1, "proved",
                      "(15): A_x Z_x^T = 0 entry by entry, for any tip, RCM point and frame with B_c ⟂ n")


def nullspace_wrong_sign() -> Theorem:
    """Z_x built with (p_c - p_t)^: the torque rows leak into the constraint space."""
    return _nullspace("rcm.nullspace_wrong_sign", -1, "refuted",
                      "(15) with (p_c − p_t)^ instead of (p_t − p_c)^: A_x Z_x^T ≠ 0")


# --------------------------------------------------------------------------- (16)-(21): decoupling

# n = 2 joints, m = 1 constraint, so that every inverse in (18)-(20) is a scalar division
# (z3 does not decide the n = 3 identities with a 2x2 inverse within budget): A = [A1 A2],
# Z = [Z1 Z2] with A Z^T = 0 (16), W = diag(W1, W2) > 0 (the paper's W = 1.5 I is such a W).
A2v = Reals("A1 A2")
Z2v = Reals("Z1 Z2")
W2v = Reals("W1 W2")
Ad = Reals("Ad1 Ad2")          # A^dagger = W^-1 A^T (A W^-1 A^T)^-1   (18)
Zd = Reals("Zd1 Zd2")          # Z^dagger = W Z^T (Z W Z^T)^-1         (20)
q_aw, p_zw, which = Reals("q_aw p_zw which")


def _decoupling(name: str, zw_mapping: bool, expected: str, description: str) -> Theorem:
    A, Z, W = A2v, Z2v, W2v
    compute = [assign(q_aw, A[0] * A[0] / W[0] + A[1] * A[1] / W[1]),
               assign(p_zw, W[0] * Z[0] * Z[0] + W[1] * Z[1] * Z[1])]
    compute += [assign(Ad[i], A[i] / W[i] / q_aw) for i in range(2)]
    compute += [assign(Zd[i], W[i] * Z[i] / p_zw) for i in range(2)]
    # S = [A^dagger  Z^T] (19); the claimed inverse (20) is [A; Z^dagger^T] ([14]: [A; Z W])
    S = [[Ad[i], Z[i]] for i in range(2)]
    lower = [W[i] * Z[i] for i in range(2)] if zw_mapping else list(Zd)
    inverse = [list(A), lower]
    eye = [[1, 0], [0, 1]]
    claims = {"(i) A A† = 1": A[0] * Ad[0] + A[1] * Ad[1] == 1,
              "(iii) Z Z† = 1": Z[0] * Zd[0] + Z[1] * Zd[1] == 1}
    for i, what in enumerate(("A S = [1 0]", f"{'Z W' if zw_mapping else 'Z†ᵀ'} S = [0 1]")):
        claims[f"(20) {what}"] = And(*(inverse[i][0] * S[0][j] + inverse[i][1] * S[1][j] == eye[i][j]
                                       for j in range(2)))
    # one branch per identity, so each is its own obligation (and path in the proof tree)
    pick = choice(*(branch(label, assign(which, n)) for n, label in enumerate(claims)))
    return Theorem(
        name=name,
        assumptions=And(W[0] > 0, W[1] > 0, Or(A[0] != 0, A[1] != 0), Or(Z[0] != 0, Z[1] != 0),
                        A[0] * Z[0] + A[1] * Z[1] == 0),
        program=seq(*compute, pick),
        guarantee=And(*(Implies(which == n, c) for n, c in enumerate(claims.values()))),
        expected=expected,
        constants=(*A, *W, *Z),
        description=description,
    )


def decoupling() -> Theorem:
    """(16)-(21) for n = 2, m = 1 over explicit components: with A Z^T = 0, A and Z
    non-zero and W diagonal positive, A A† = 1 (i), Z Z† = 1 (iii) and [A; Z†^T] S = I (20),
    whose rows are A S = [1 0] (used for (24) -> (25)) and Z†^T S = [0 1] (used for (27));
    its off-diagonal entry Z†^T A† = 0 is (ii)."""
    return _decoupling("rcm.decoupling", False, "proved",
                       "(16)–(21) in components, n = 2, m = 1: A A† = 1, Z Z† = 1, [A; Z†ᵀ] S = I")


def decoupling_zw_mapping() -> Theorem:
    """Remark 2: the mapping of [14], [A; Z W], is not the inverse of S."""
    return _decoupling("rcm.decoupling_zw_mapping", True, "refuted",
                       "Remark 2: [14]'s mapping [A; Z W] is not S⁻¹ (Z W Zᵀ ≠ I)")


# --------------------------------------------------------------------------- (25), (26): the RCM error

xc, vc, al, be, gh, W0 = Reals("xc vc al be gh W0")


def constraint_set_invariant() -> Theorem:
    """(25)-(26): the set S (x_c = 0, x_c' = 0) is positively invariant for any alpha >= 0
    and beta > 0: dI on the energy beta^2 x_c^2 + x_c'^2 <= 0 (its derivative is -4 alpha x_c'^2)."""
    energy = be**2 * xc**2 + vc**2
    return Theorem(
        name="rcm.constraint_set_invariant",
        assumptions=And(xc == 0, vc == 0, al >= 0, be > 0),
        program=ode({xc: vc, vc: -2 * al * vc - be**2 * xc}, invariants=[energy <= 0]),
        guarantee=And(xc == 0, vc == 0),
        expected="proved",
        constants=(al, be),
        description="(26): S = {x_c = 0, x_c' = 0} is invariant under (25) (dI on the energy)",
    )


def constraint_exponential() -> Theorem:
    """Claim 2 with an explicit rate, alpha = beta = a > 0 (the paper's critically damped
    choice): |x_c(t)| <= sqrt(W0)/a * e^(-a t/2) and |x_c' + a x_c| <= sqrt(W0) e^(-a t/2),
    W0 = a^2 x_c^2 + (x_c' + a x_c)^2 at the start. The ghost gh' = (a/2) gh, gh(0) = 1, is
    e^(a t/2); the invariant gh^2 W <= W0 is a plain dI: its derivative is -a gh^2 x_c'^2.
    (Squaring the ghost avoids the Darboux step gh > 0, which the engine has no rule for.)"""
    a = al
    w = a**2 * xc**2 + (vc + a * xc) ** 2
    return Theorem(
        name="rcm.constraint_exponential",
        assumptions=And(a > 0, gh == 1, W0 == w),
        program=ode({xc: vc, vc: -2 * a * vc - a**2 * xc, gh: a / 2 * gh}, invariants=[gh**2 * w <= W0]),
        guarantee=And(gh**2 * a**2 * xc**2 <= W0, gh**2 * (vc + a * xc) ** 2 <= W0),
        expected="proved",
        constants=(a, W0),
        description="claim 2 with a rate: α = β = a gives a²x_c²·e^(at) <= W0 (ghost e^(at/2), dI)",
    )


# The paper integrates (22) with explicit Euler at h = 4 ms. For (25) with alpha = beta = a
# that is x+ = x + h v, v+ = v + h(-2a v - a^2 x); in y = v + a x it is exactly
# x+ = (1 - a h) x + h y, y+ = (1 - a h) y: a Jordan block with eigenvalue 1 - a h (0.9 for
# Table 1), stable iff 0 < a h < 2. The certificate V = x^2 + y^2/400 decreases by the
# factor rho^2 = (19/20)^2 per step (z3 checks it; rho = 0.95 is e^(-12.8 t) at 250 Hz).
gs, x_old = Reals("gs x_old")


def _euler_constraint(name: str, a: int, expected: str, description: str) -> Theorem:
    y = vc + a * xc
    lyap = xc**2 + y**2 / 400
    # explicit: both updates read the old state (x_old keeps x for the velocity update)
    step = seq(assign(x_old, xc), assign(xc, xc + H * vc), assign(vc, vc + H * (-2 * a * vc - a**2 * x_old)),
               assign(gs, Fraction(361, 400) * gs))
    return Theorem(
        name=name,
        assumptions=And(W0 == lyap, gs == 1),
        program=loop(step, invariant=And(lyap <= gs * W0, gs >= 0), label="Euler loop"),
        guarantee=And(xc**2 <= gs * W0, (vc + a * xc) ** 2 <= 400 * gs * W0),
        expected=expected,
        constants=(W0,),
        unroll=2,
        description=description,
    )


def constraint_euler_4ms() -> Theorem:
    """(25) integrated by the paper's explicit Euler at 4 ms with alpha = beta = 25:
    x_c^2 <= 0.95^(2k) V0 after k steps (V = x^2 + (v + 25 x)^2/400, loop invariant)."""
    return _euler_constraint("rcm.constraint_euler_4ms", ALPHA, "proved",
                             "(25) by Euler at 4 ms, α = β = 25: x_c² <= 0.95^(2k)·V0 after k steps")


def constraint_euler_stiff() -> Theorem:
    """The same Euler loop with alpha = beta = 600 (a h = 2.4 > 2): x_c grows."""
    return _euler_constraint("rcm.constraint_euler_stiff", 600, "refuted",
                             "(25) by Euler at 4 ms with α = β = 600 (αh = 2.4 > 2): x_c diverges")


# --------------------------------------------------------------------------- (9)-(13), (27)-(33): the barrier

s_, w_, F_, f_, dmp, L_, e_, E0, Eb, Yb, t_, eps, mrg, wc = Reals("gap w F f dmp L e E0 Ebar Y t eps m wcmd")


def _one_minus_psi(s):
    """1 - psi (10) as a polynomial in the gap s = rho - d_c: s (2 d_0 - s) / d_0^2."""
    return s * (2 * D0 - s) / D0**2


def barrier_continuous() -> Theorem:
    """Claim 4 in continuous time, axial reduction of (27) inside the barrier's band
    0 < s <= d_0: s' = -w, w' = F - D w - f with the paper's force f = k_v (d_0 - s) (11)-(13)
    written with L = ln(1/(1 - psi)) as a state (L' is its chain-rule derivative, the one
    piece of glue: L stays ln(1/(1 - psi(s)))). Premises made explicit: human force F
    piecewise constant, any D >= 0 (4.4), and finite human energy e = int F w <= Ebar (in
    the domain). The storage w^2/2 + k L^2/2 - e never grows (dI, (31)), so
    k L^2/2 <= E0 + Ebar: V_i stays bounded, and rcm.barrier_clearance turns that into a
    positive clearance. (The domain's s > 0 is the band; a flow cannot leave through s = 0
    while L is bounded, by continuity.)"""
    y = _one_minus_psi(s_)
    force = 2 * K_BAR * L_ * (D0 - s_) / (D0**2 * y)
    flow = ode({s_: -w_, w_: F_ - dmp * w_ - force, L_: 2 * (D0 - s_) * w_ / (D0**2 * y), e_: F_ * w_},
               And(0 < s_, s_ <= D0, e_ <= Eb),
               invariants=[w_**2 / 2 + K_BAR / 2 * L_**2 - e_ <= E0])
    step = seq(havoc(F_), havoc(dmp), test(dmp >= 0), flow)
    return Theorem(
        name="rcm.barrier_continuous",
        assumptions=And(E0 == w_**2 / 2 + K_BAR / 2 * L_**2 - e_, e_ <= Eb, 0 < s_, s_ <= D0),
        program=loop(step, invariant=And(w_**2 / 2 + K_BAR / 2 * L_**2 - e_ <= E0, e_ <= Eb),
                     label="admittance loop"),
        guarantee=K_BAR / 2 * L_**2 <= E0 + Eb,
        expected="proved",
        constants=(E0, Eb),
        description="claim 4, continuous time, finite human energy: kL²/2 <= E0 + Ē (dI on the storage)",
    )


def barrier_clearance() -> Theorem:
    """(33) -> claim 4: V_i <= E means ln(1/(1 - psi)) <= sqrt(2E/k), i.e. 1 - psi >= Y with
    Y = exp(-sqrt(2E/k)) in (0, 1] (the exponential abstracted as that interval). Then the
    gap is at least d_1 = d_0 (1 - sqrt(1 - Y)) > 0, the clearance the paper leaves implicit
    (0.26 um at E = 0.5 J with k = 0.01)."""
    return Theorem(
        name="rcm.barrier_clearance",
        assumptions=And(0 < Yb, Yb <= 1, s_ * (2 * D0 - s_) >= D0**2 * Yb),
        program=test(TRUE),
        guarantee=And(s_ > 0, (D0 - s_) ** 2 <= D0**2 * (1 - Yb)),
        expected="proved",
        description="(33) → claim 4: 1 − ψ >= Y > 0 gives the gap s >= d0(1 − √(1 − Y)) > 0",
    )


def damping_bounds() -> Theorem:
    """(43)-(45) with Table 1, element 1 and elements 2-4: exp(-M s) and exp(-C z^2) lie in
    (0, 1] (abstracted as such), so D_c <= D_f <= D_c + Q + G: [10, 95] and [4, 54]."""
    e1, e2, e3, e4, d1, d2 = Reals("ev1 er1 ev2 er2 Df1 Df2")
    prog = seq(*(seq(havoc(x), test(And(0 < x, x <= 1))) for x in (e1, e2, e3, e4)),
               assign(d1, DC1 + Q1 * e1 + G1 * (1 - e2)), assign(d2, 4 + 20 * e3 + 30 * (1 - e4)))
    return Theorem(
        name="rcm.damping_bounds",
        assumptions=And(),
        program=prog,
        guarantee=And(10 <= d1, d1 <= 95, 4 <= d2, d2 <= 54),
        expected="proved",
        description="§4.4, Table 1: D_f1 ∈ [10, 95], D_f2..4 ∈ [4, 54] (exp abstracted as (0, 1])",
    )


# --------------------------------------------------------------------------- the paper's 4 ms Euler step

lam, xo, yv = Reals("lam xo y")


def _barrier_force():
    """The paper's force (11)-(13) on the axis, f = 2 k lam (d_0 - s) / (d_0^2 y) with y = 1 - psi,
    lam = ln(1/y), here replaced by its upper bound (1/y - y)/2 >= ln(1/y) for y in (0, 1]:
    a barrier at least as repulsive as the paper's. Outside the band (s >= d_0) no force."""
    y = _one_minus_psi(s_)
    return choice(
        # (constants through tests: the refuter's encoder gives a choice's merged variable
        # the sort of the first branch's value, and a literal 0 would make it an Int)
        branch("outside the band", test(s_ >= D0), havoc(yv), test(yv == 1), havoc(lam), test(lam == 0),
               havoc(f_), test(f_ == 0)),
        branch("in the band", test(And(0 < s_, s_ < D0)), assign(yv, y),
               havoc(lam), test(2 * yv * lam == 1 - yv * yv),
               havoc(f_), test(D0**2 * yv * f_ == 2 * K_BAR * lam * (D0 - s_))),
    )


def _table1_damping():
    """D_f1 = 10 + 25 exp(-22 |w|) + 60 (1 - exp(-0.01 f^2)) (43)-(45), Table 1, with the
    exponentials replaced by upper bounds, exp(-x) <= 1/(1 + x) and 1 - exp(-z) <= z: at
    least the paper's damping."""
    z = C1 * f_**2
    return choice(
        branch("approaching", test(w_ >= 0),
               havoc(dmp), test((dmp - DC1 - G1 * z) * (1 + M1 * w_) == Q1)),
        branch("receding", test(w_ < 0), assign(dmp, DC1 + Q1 + G1 * z)),
    )


def axial_euler_4ms() -> Theorem:
    """Claim 4 for the paper's implementation: (27) on the tool axis integrated by explicit
    Euler every 4 ms (s := s - h w with the old w, then w := w + h (F - f - D w)), Table 1
    gains, a steady 5 N push. The run starts where the push has brought the tip from rest
    30 mm away: 3.3 mm from the ball, approaching at 0.355 m/s (the kernel's simulation with
    the exact ln and exp passes there, tested). The barrier's force grows only like
    ln(1/(1 - psi)), too slowly to stop a tip that covers 1.4 mm per period: at the third
    period the position step jumps 0.6 mm past the wall. Here ln and exp are replaced by
    upper bounds (more repulsion, more damping than the paper's) and the tip still enters;
    the kernel test runs the push with the exact functions (entry at step 35, 0.76 mm deep)."""
    step = seq(_barrier_force(), _table1_damping(),
               assign(s_, s_ - H * w_), assign(w_, w_ + H * (F_ - f_ - dmp * w_)))
    return Theorem(
        name="rcm.axial_euler_4ms",
        assumptions=And(F_ == 5, s_ == Fraction(33, 10000), w_ == Fraction(71, 200)),
        program=loop(step, invariant=s_ > 0, label="250 Hz loop"),
        guarantee=s_ > 0,
        expected="refuted",
        constants=(F_,),
        unroll=3,
        scenarios=(And(s_ == Fraction(33, 10000), w_ == Fraction(71, 200)),),
        description="the paper's 4 ms explicit Euler, Table 1, steady 5 N push: the tip jumps into O_c",
    )


def barrier_off_s() -> Theorem:
    """Theorem 1 assumes only p_t(t0) outside O_c, but claims 3-4 are shown on S. Off S the
    RCM correction (25) moves the tip (here its gap changes with x_c, unit leverage), and
    the barrier cannot resist it: its force lives in the free coordinates (27), decoupled
    from x_c. Euler at 4 ms, Table 1."""
    step = seq(assign(xo, xc), assign(xc, xc + H * vc),
               assign(vc, vc + H * (-2 * ALPHA * vc - ALPHA**2 * xc)), assign(s_, s_ + (xc - xo)))
    return Theorem(
        name="rcm.barrier_off_s",
        assumptions=And(s_ > 0, s_ <= D0),
        program=loop(step, invariant=s_ > 0, label="250 Hz loop"),
        guarantee=s_ > 0,
        expected="refuted",
        unroll=2,
        description="premise: off S (x_c ≠ 0) the RCM correction carries the tip into O_c unopposed",
    )


# --------------------------------------------------------------------------- the sampled-data guard (the fix)


def _axial_guard(name: str, margin, expected: str, description: str) -> Theorem:
    """Whatever speed the admittance step asks for (wcmd := *, any sign, Euler or not), the
    guard lets it through only if one period at that speed keeps the gap >= margin, and
    otherwise commands the speed that ends the period exactly there; between samples the tip
    moves at the commanded speed for up to eps seconds (t' = 1, t <= eps). In the kernel s is
    the smallest gap to any cloud ball and wcmd the tip's speed, an upper bound on how fast
    any gap closes (|d/dt |p - c|| <= |p'|)."""
    control = choice(
        branch("command keeps the margin", test(eps * wc <= s_ - margin)),
        branch("command would cross: limit it", test(eps * wc > s_ - margin),
               assign(wc, (s_ - margin) / eps)),
    )
    plant = seq(assign(t_, 0), ode({s_: -wc, t_: 1}, t_ <= eps))
    return Theorem(
        name=name,
        assumptions=And(s_ >= mrg, mrg > 0, eps > 0),
        program=loop(seq(havoc(wc), control, plant), invariant=s_ >= mrg, label="guarded loop"),
        guarantee=And(s_ >= mrg, s_ > 0),
        expected=expected,
        constants=(mrg, eps),
        check_nonblocking=True,
        description=description,
    )


def axial_guard() -> Theorem:
    """The fix: the sampled-data guard keeps the tip at least m outside O_c for any command."""
    return _axial_guard("rcm.axial_guard", mrg, "proved",
                        "the fix: sampled-data guard, any command, any period ε: the gap stays >= m > 0")


def axial_guard_half_margin() -> Theorem:
    """The guard with its margin halved: the gap can end a period at m/2 < m."""
    return _axial_guard("rcm.axial_guard_half_margin", mrg / 2, "refuted",
                        "mutant: the guard checks against m/2: the tip enters the inflated region")
