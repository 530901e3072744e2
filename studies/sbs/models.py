"""Skull-base-surgery virtual fixtures (the virtual-fixture paper, Kouskoulas et al., HSCC'13).

Symbols follow the seed: p = tool tip, f = surgeon force, fxp/fyp = force derivatives
(the inputs), G = admittance gain, D = slow-zone thickness. In Table 1 the boundary is the
x-axis and the safe side is py >= 0.
"""

from __future__ import annotations

from fractions import Fraction

from certiloop.models.lang.programs import Program, assign, branch, choice, havoc, loop, ode, seq, test
from certiloop.models.lang.terms import And, Iff, Or, Real, Reals
from certiloop.models.lang.theorem import Theorem

px, py, fx, fy, fxp, fyp, G, D = Reals("px py fx fy fxp fyp G D")


def _mode(vx, vy, domain):
    return ode({px: vx, py: vy, fx: fxp, fy: fyp}, domain)


def _ctrl1(past_boundary_inward):
    step = seq(
        havoc(fxp),
        havoc(fyp),
        choice(
            branch("free zone", _mode(G * fx, G * fy, py >= D)),
            branch("slow zone, towards", _mode(G * fx, G * py / D * fy, And(0 <= py, py <= D, fy <= 0))),
            branch("slow zone, away", _mode(G * fx, G * fy, And(0 <= py, py <= D, fy >= 0))),
            branch("past boundary, towards", past_boundary_inward),
            branch("past boundary, away", _mode(0, G * fy, And(py <= 0, fy >= 0))),
        ),
    )
    return loop(step, invariant=py >= 0, label="ctrl1 loop")


def ctrl1() -> Theorem:
    """Table 1 and Theorem 1: safe1 ∧ sane -> [ctrl1] safe1, with safe1 = py >= 0."""
    return Theorem(
        name="sbs.ctrl1",
        assumptions=And(py >= 0, G > 0, D > 0),
        program=_ctrl1(_mode(0, 0, And(py <= 0, fy <= 0))),
        guarantee=py >= 0,
        expected="proved",
        check_nonblocking=True,
        constants=(G, D),
        description="Table 1: event-driven continuous control, one boundary, 2D (Theorem 1)",
    )


def ctrl1_broken() -> Theorem:
    """ctrl1 where the past-boundary mode for an inward force keeps the admittance law
    (py' = G fy) instead of stopping the tool: a tool that reaches the boundary while the
    surgeon pushes inward slides through it."""
    return Theorem(
        name="sbs.ctrl1_broken",
        assumptions=And(py >= 0, G > 0, D > 0),
        program=_ctrl1(_mode(G * fx, G * fy, And(py <= 0, fy <= 0))),
        guarantee=py >= 0,
        expected="refuted",
        constants=(G, D),
        description="ctrl1 with a past-boundary mode that lets the tool keep moving inward",
    )


# =========================================================================== Table 2: ctrl2
#
# Transcription notes (the published table has typesetting errors; checked against the
# authors' KeYmaeraD file medrobot_nfix3d.dl):
#  * `?u(i)1 = 1` reads u(i)*1 = 1, i.e. u(i) = 1; `?u(i)d = d0(i)` reads u(i)*D = d0(i),
#    i.e. u(i) = d0(i)/D; `?u(i)1 = 0` reads u(i) = 0. Lower-case `d` in the first guard
#    is the slow-zone thickness D.
#  * `(3 ≥ 3)` is just true.
#  * `tmp := *; ?tmp*G*X = 1; kt := -d0*tmp` is the paper's division kt = -d0/(G X); we keep
#    it, so a division by zero simply blocks that branch, exactly as in the paper.
#  * The paper's list traversal `i := first; (?i ≠ end; ...; i := next(i))*; ?i = end` over
#    an injective `next` visits every boundary once; `foreach` does the same with a `done`
#    family, which makes the per-boundary induction a quantified invariant over the family.
#  * `xtr` appears without its index in two guards of the KeYmaeraD file; Table 2 writes
#    xtr(i) everywhere, which we follow.

from certiloop.models.lang.conveniences import dot, foreach  # noqa: E402
from certiloop.models.lang.terms import BOOL, Family, ForAll, Implies, IndexSort, Var  # noqa: E402

B = IndexSort("B")


class Ctrl2Symbols:
    """The symbols of Table 2 for a given dimension (2 or 3)."""

    def __init__(self, dim: int) -> None:
        axes = "xyz"[:dim]
        self.dim = dim
        self.p = Reals(" ".join(f"p{a}" for a in axes))
        self.f = Reals(" ".join(f"f{a}" for a in axes))
        self.fp = Reals(" ".join(f"f{a}p" for a in axes))
        self.n = [Family(f"n{a}", B) for a in axes]
        self.r = [Family(f"r{a}", B) for a in axes]
        self.G, self.e, self.D, self.k, self.kt, self.tmp, self.t = Reals("G e D k kt tmp t")
        self.i, self.j = Var("i", B), Var("j", B)
        self.done = Family("done", B, BOOL)
        self.active = Family("active", B, BOOL)
        for name in ("xtr", "u", "d0", "fn", "fnp", "dist", "disc"):
            setattr(self, name, Family(name, B))

    # projected quantities of boundary j, from the state (the paper's d0, fn, fnp)
    def dist0(self, j):
        return dot([pc - rc(j) for pc, rc in zip(self.p, self.r)], [nc(j) for nc in self.n])

    def fnormal(self, j):
        return dot(self.f, [nc(j) for nc in self.n])

    def fpnormal(self, j):
        return dot(self.fp, [nc(j) for nc in self.n])

    def safe(self, j):
        return self.dist0(j) >= 0

    def safe_for_step(self, j, k):
        """Boundary j stays safe for a whole step of at most e under gain k:
        ∀t∈[0,e]. d0 + G k (fn t + fnp t²/2) >= 0  (Eqn 9 with multiplicative k)."""
        t = Real("t_")
        d = self.dist0(j) + self.G * k * (self.fnormal(j) * t + self.fpnormal(j) * t**2 / 2)
        return ForAll(t, Implies(And(0 <= t, t <= self.e), d >= 0))

    def unit_normals(self):
        return ForAll(self.j, dot([nc(self.j) for nc in self.n], [nc(self.j) for nc in self.n]) == 1)

    def axis_aligned(self):
        """Refutation scenario: every boundary passes through the origin with a normal along
        +x or +y, so projected quantities are plain coordinates."""
        j = self.j
        n, r = self.n, self.r
        along = lambda a: And(*(nc(j) == (1 if c == a else 0) for c, nc in enumerate(n)))  # noqa: E731
        return ForAll(j, And(Or(along(0), along(1)), *(rc(j) == 0 for rc in r)))

    def abbreviations(self):
        j = Var("b_", B)
        return {"d0": self.dist0(j), "fn": self.fnormal(j), "fnp": self.fpnormal(j)}


def force_feedback(s: Ctrl2Symbols, i) -> Program:
    """Table 2's force-feedback section: ten cases computing the attenuation u(i)."""
    d0, fn, fnp, xtr, u, D, e = s.d0(i), s.fn(i), s.fnp(i), s.xtr(i), s.u(i), s.D, s.e
    one = lambda: seq(havoc(u), test(u * 1 == 1))  # noqa: E731
    slow = lambda: seq(havoc(u), test(u * D == d0))  # noqa: E731
    turn = xtr * fnp == -1 * fn
    return choice(
        branch("ff1 free (d0 >= D)", test(d0 >= D), one()),
        branch("ff2 slow, fnp>=0 fn>=0", test(And(0 <= d0, d0 <= D, fnp >= 0, fn >= 0)), one()),
        branch("ff3 slow, turns early", test(And(0 <= d0, d0 <= D, fnp > 0, fn <= 0, turn, xtr <= e / 2)),
               one()),
        branch("ff4 slow, turns late", test(And(0 <= d0, d0 <= D, fnp > 0, fn <= 0, turn, xtr >= e / 2)),
               slow()),
        branch("ff5 slow, fnp=0 fn<=0", test(And(0 <= d0, d0 <= D, fnp == 0, fn <= 0)), slow()),
        branch("ff6 slow, reverses early", test(And(0 <= d0, d0 <= D, fnp < 0, fn >= 0, turn,
                                                    xtr <= e / 2)), slow()),
        branch("ff7 slow, reverses late", test(And(0 <= d0, d0 <= D, fnp < 0, fn >= 0, turn,
                                                   xtr >= e / 2)), one()),
        branch("ff8 slow, fnp=0 fn>=0", test(And(0 <= d0, d0 <= D, fnp == 0, fn >= 0)), one()),
        branch("ff9 slow, fnp<=0 fn<=0", test(And(0 <= d0, d0 <= D, fnp <= 0, fn <= 0)), slow()),
        branch("ff10 stuck (d0 <= 0)", test(d0 <= 0), seq(havoc(u), test(u * 1 == 0))),
    )


def safety(s: Ctrl2Symbols, i, kt_formula=None) -> Program:
    """Table 2's safety section: seven cases (Fig. 5) computing the safe gain kt."""
    d0, fn, fnp, u, G, e = s.d0(i), s.fn(i), s.fnp(i), s.u(i), s.G, s.e
    dist, disc, tmp, kt = s.dist(i), s.disc(i), s.tmp, s.kt
    reach = fn * e + fnp * e**2 / 2 if kt_formula is None else kt_formula(s, i)
    keep_u = lambda: seq(havoc(tmp), test(tmp * G == 1), assign(kt, u))  # noqa: E731
    hit_at_end = lambda: seq(havoc(tmp), test(tmp * G * reach == 1), assign(kt, -1 * d0 * tmp))  # noqa: E731
    return choice(
        branch("sa fnp<=0, clear", test(And(fnp <= 0, dist >= 0)), keep_u()),
        branch("se fnp<=0, would cross", test(And(fnp <= 0, dist <= 0)), hit_at_end()),
        branch("sb turns back, disc<=0", test(And(fnp >= 0, fn <= 0, disc <= 0)), keep_u()),
        branch("sf turns within step", test(And(fnp >= 0, fn <= 0, disc >= 0, fn + fnp * e >= 0)),
               seq(havoc(tmp), test(tmp * G * fn**2 == 1), assign(kt, 2 * fnp * d0 * tmp))),
        branch("sg still inward, would cross", test(And(fnp >= 0, fn <= 0, disc >= 0, fn + fnp * e <= 0,
                                                         dist <= 0)), hit_at_end()),
        branch("sc still inward, clear", test(And(fnp >= 0, fn <= 0, disc >= 0, fn + fnp * e <= 0,
                                                  dist >= 0)), keep_u()),
        branch("sd away", test(And(fnp >= 0, fn >= 0)), keep_u()),
    )


def boundary_step(s: Ctrl2Symbols, i, kt_formula=None, combine=None) -> Program:
    """One inner-loop iteration of Table 2 for boundary i."""
    G, e = s.G, s.e
    return seq(
        havoc(s.xtr(i)),
        assign(s.u(i), 1),
        assign(s.d0(i), s.dist0(i)),
        assign(s.fnp(i), s.fpnormal(i)),
        assign(s.fn(i), s.fnormal(i)),
        force_feedback(s, i),
        assign(s.dist(i), s.d0(i) + G * s.u(i) * (s.fn(i) * e + s.fnp(i) * e**2 * Fraction(1, 2))),
        assign(s.disc(i), (G * s.u(i) * s.fn(i))**2 - 2 * G * s.u(i) * s.fnp(i) * s.d0(i)),
        safety(s, i, kt_formula),
        combine(s) if combine is not None else choice(
            branch("kt >= k: keep k", test(s.kt >= s.k), assign(s.k, s.k)),
            branch("kt < k: k := kt", test(s.kt < s.k), assign(s.k, s.kt)),
        ),
    )


def _ctrl2(name: str, dim: int, expected: str, description: str, kt_formula=None, combine=None,
           dynamic: bool = False, join_only_when_safe: bool = True) -> Theorem:
    s = Ctrl2Symbols(dim)
    j = s.j
    member = (lambda b: s.active(b)) if dynamic else None
    guarded = (lambda b, f: Implies(s.active(b), f)) if dynamic else (lambda b, f: f)
    inner_inv = And(0 <= s.k, s.k <= 1,
                    ForAll(j, Implies(s.done(j), s.safe_for_step(j, s.k))))
    if dynamic:
        # only active boundaries are processed, and the ones joined this step are safe too:
        # the key lemma (lowering k keeps a processed boundary safe) needs d0 >= 0 for them
        inner_inv = And(inner_inv, ForAll(j, Implies(s.done(j), s.active(j))),
                        ForAll(j, guarded(j, s.safe(j))))
    inner = foreach(s.i, s.done, boundary_step(s, s.i, kt_formula, combine), inner_inv,
                    where=member, label="boundary loop")
    plant = ode({**{pc: s.G * fc * s.k for pc, fc in zip(s.p, s.f)},
                 **{fc: fpc for fc, fpc in zip(s.f, s.fp)}, s.t: 1}, s.t <= s.e)
    safe_all = ForAll(j, guarded(j, s.safe(j)))
    step = [*(havoc(c) for c in s.fp)]
    if dynamic:
        # section 7: any boundary may be removed; a new one joins only on its safe side
        new_active = Family("active_next", B, BOOL)
        joins = ForAll(j, Implies(new_active(j), Or(s.active(j), s.safe(j))))
        step += [havoc(new_active), *([test(joins)] if join_only_when_safe else []),
                 _copy_family(s.active, new_active, j)]
    step += [assign(s.k, 1), inner, assign(s.t, 0), plant]
    return Theorem(
        name=name,
        assumptions=And(s.G > 0, s.e > 0, s.D > 0, s.unit_normals(), safe_all),
        program=loop(seq(*step), invariant=safe_all, label="control loop"),
        guarantee=safe_all,
        expected=expected,
        check_nonblocking=True,
        abbreviations=s.abbreviations(),
        constants=(s.G, s.e, s.D),
        description=description,
        unroll=2,
        scenarios=(And(s.G == 1, s.e == 1, s.D == 1, s.axis_aligned()), s.axis_aligned()),
    )


def _copy_family(target, source, j):
    """target := source for a whole Bool family, as havoc + pointwise test."""
    return seq(havoc(target), test(ForAll(j, Iff(target(j), source(j)))))


def ctrl2() -> Theorem:
    """Table 2 and Theorem 2: any finite number of arbitrarily placed and oriented
    boundaries in three dimensions stay safe."""
    return _ctrl2("sbs.ctrl2", 3, "proved",
                  "Table 2 / Theorem 2: ctrl2, 3D, any finite family of boundaries")


def ctrl2_2d() -> Theorem:
    """Table 2 in two dimensions (the paper's medrobot_nfix2d)."""
    return _ctrl2("sbs.ctrl2_2d", 2, "proved", "Table 2 in 2D, any finite family of boundaries")


def ctrl2_dynamic() -> Theorem:
    """Section 7's future work: boundaries may be removed at any step and added at the start
    of a step when the tool is on their safe side."""
    return _ctrl2("sbs.ctrl2_dynamic", 3, "proved",
                  "section 7: boundaries removed any time, added when the tool is on their safe side",
                  dynamic=True)


def ctrl2_dynamic_join_anywhere() -> Theorem:
    """Mutant of ctrl2_dynamic: a boundary may join wherever the tool is, so the tool can
    start a step already on the wrong side of a new boundary."""
    return _ctrl2("sbs.ctrl2_dynamic_join_anywhere", 3, "refuted",
                  "ctrl2_dynamic mutant: boundaries join without the safe-side check",
                  dynamic=True, join_only_when_safe=False)


def ctrl2_wrong_k() -> Theorem:
    """Mutant: safety cases e/g divide by fn e + fnp e²/4 instead of fn e + fnp e²/2, so the
    damping computed for an inward-accelerating tool is too weak."""
    return _ctrl2("sbs.ctrl2_wrong_k", 3, "refuted", "ctrl2 mutant: wrong k formula in safety cases e/g",
                  kt_formula=lambda s, i: s.fn(i) * s.e + s.fnp(i) * s.e**2 / 4)


def ctrl2_last_wins() -> Theorem:
    """Mutant: k := kt for every boundary instead of the minimum, so the last boundary
    processed decides the gain for all of them."""
    return _ctrl2("sbs.ctrl2_last_wins", 3, "refuted", "ctrl2 mutant: min replaced by the last boundary's kt",
                  combine=lambda s: assign(s.k, s.kt))


# =========================================================================== 6.2.1 and Eqn 12

k_imm, t_imm, e_imm = Reals("k t e")


def immediate() -> Theorem:
    """6.2.1: delayed control with the slow-zone feedback of Eqn 2 rewritten as Eqn 6,
    p' = G (f - k n), with k chosen at the start of each step from the current state and
    no prediction. Boundary: the x-axis, n = (0, 1), safe side py >= 0. Within one delay e a
    fast inward push starting just outside the slow zone crosses the whole buffer D."""
    towards = fy < 0
    control = choice(
        branch("free zone: no feedback", test(py > D), assign(k_imm, 0)),
        branch("slow zone, towards: k = (1 - d/D) f·n", test(And(0 <= py, py <= D, towards)),
               assign(k_imm, (1 - py / D) * fy)),
        branch("slow zone, away: no feedback", test(And(0 <= py, py <= D, fy >= 0)), assign(k_imm, 0)),
    )
    plant = ode({px: G * fx, py: G * (fy - k_imm), fx: fxp, fy: fyp, t_imm: 1}, t_imm <= e_imm)
    step = seq(havoc(fxp), havoc(fyp), control, assign(t_imm, 0), plant)
    return Theorem(
        name="sbs.immediate",
        assumptions=And(py >= 0, G > 0, D > 0, e_imm > 0),
        program=loop(step, invariant=py >= 0, label="control loop"),
        guarantee=py >= 0,
        expected="refuted",
        constants=(G, D, e_imm),
        description="6.2.1: immediate (non-predictive) delayed control crosses D within one delay",
    )


wx, wy, vx, vy, xx, xy, nix, niy, njx, njy, di, dj = Reals("wx wy vx vy xx xy nix niy njx njy di dj")


def _q(ax, ay, nx_, ny_, d):
    """Eqn 10: Q(a, v) for the boundary with normal n and distance d."""
    a_n, v_n = ax * nx_ + ay * ny_, vx * nx_ + vy * ny_
    return Or(-a_n <= -v_n * d / D, a_n >= 0)


def eqn12() -> Theorem:
    """Eqns 10-13: the sequential velocity-projection algorithm as a Hoare triple
    {Q_i(w,v)} x := Eqn12(w) {Q_i(x,v) ∧ Q_j(x,v)}, for two boundaries in 2D (C_s = {i}).
    The paper reports a counterexample in the fourth case with n_i·n_j <= 0; the first case
    (which also adds a multiple of n_j) fails for acute angles as well."""
    w_nj, v_nj = wx * njx + wy * njy, vx * njx + vy * njy
    attenuated = -w_nj >= -v_nj * dj / D
    corr = (vx * dj / D - wx) * njx + (vy * dj / D - wy) * njy
    cases = choice(
        branch("case 1: subtract the excess normal speed",
               test(And(w_nj <= 0, v_nj <= 0, attenuated)),
               assign(xx, wx + corr * njx), assign(xy, wy + corr * njy)),
        branch("case 2: already attenuated", test(And(w_nj <= 0, v_nj <= 0, -w_nj <= -v_nj * dj / D)),
               assign(xx, wx), assign(xy, wy)),
        branch("case 3: moving away", test(w_nj >= 0), assign(xx, wx), assign(xy, wy)),
        branch("case 4: remove the normal component",
               test(And(w_nj <= 0, v_nj >= 0)),
               assign(xx, wx - w_nj * njx), assign(xy, wy - w_nj * njy)),
    )
    return Theorem(
        name="sbs.eqn12",
        assumptions=And(D > 0, nix**2 + niy**2 == 1, njx**2 + njy**2 == 1, 0 <= di, di <= D,
                        0 <= dj, dj <= D, _q(wx, wy, nix, niy, di)),
        program=cases,
        guarantee=And(_q(xx, xy, nix, niy, di), _q(xx, xy, njx, njy, dj)),
        expected="refuted",
        constants=(D,),
        description="Eqn 12: sequential projection breaks an earlier boundary at acute angles (Eqn 13)",
    )


# =========================================================================== 6.2.2: predictive control
#
# Eqn 9 with subtractive feedback: p' = G (f - k n), so the distance to a plane moves as
# d(t) = d0 + G (fn - k) t + G fnp t²/2. Cases a-g of Fig. 5 choose k; checked against the
# authors' medrobot_1fix_lin.dl. Transcription notes:
#  * k > 0 pushes towards the plane ("g positive means towards the barrier" in the file); every
#    correcting k the cases compute is <= 0, i.e. a push along n, away from the plane.
#  * Cases f and g write k = fn0 - sqrt(2 fnp d0 / G) as `root := *; ?root² G = 2 d0 fnp ∧ root
#    >= 0; k := fn - root`. With this sign the tool starts the step moving away (d'(0) = G root
#    >= 0), which is safe but stronger than the touching path the text describes (fn + root);
#    we keep the published sign.
#  * Case g's "if t_m < ε use the sqrt damping, otherwise the case-e damping" is the file's
#    three sub-branches: t_m from `fnp t_m = -(fn - kt)` when fnp > 0, and fnp = 0 (no
#    minimum) falls back to case e.

tm, root, kt_p, tmp_p = Reals("tm root kt tmp")


class _Plane:
    """One plane of 6.2.2: a point r on it, its unit normal n (towards the safe side) and
    the per-plane quantities of Eqn 9; `suffix` names them apart when there are several."""

    def __init__(self, suffix: str = "") -> None:
        names = "rx ry nx ny d0 fn fnp dist disc k"
        (self.rx, self.ry, self.nx, self.ny, self.d0, self.fn, self.fnp, self.dist, self.disc,
         self.k) = Reals(" ".join(n + suffix for n in names.split()))

    def distance(self):
        return (px - self.rx) * self.nx + (py - self.ry) * self.ny

    def unit(self):
        return self.nx**2 + self.ny**2 == 1

    def abbreviations(self, suffix: str = ""):
        """The projection onto the plane's frame: distance, normal force and its rate."""
        n = (self.nx, self.ny)
        return {f"d0{suffix}_": self.distance(), f"fn{suffix}_": dot((fx, fy), n),
                f"fnp{suffix}_": dot((fxp, fyp), n), f"nn{suffix}_": dot(n, n)}


def _predictive_control(plane: _Plane, force_x, force_y) -> Program:
    """Measure the plane's Eqn-9 quantities for the force (force_x, force_y) and choose its
    subtractive damping k by cases a-g of Fig. 5."""
    d0, fn, fnp, dist, disc, k = plane.d0, plane.fn, plane.fnp, plane.dist, plane.disc, plane.k
    e = e_imm
    reach_end = lambda: seq(havoc(tmp_p), test(tmp_p * G * e == 1),  # noqa: E731
                            assign(k, fn + (d0 + Fraction(1, 2) * G * fnp * e**2) * tmp_p))
    touch_min = lambda: seq(havoc(root), test(And(root * root * G == 2 * d0 * fnp, root >= 0)),  # noqa: E731
                            assign(k, fn - root))
    inward, slowing = fn <= 0, fnp >= 0
    case_g = seq(
        havoc(tmp_p), test(tmp_p * G * e == 1),
        assign(kt_p, fn + (d0 + Fraction(1, 2) * G * fnp * e**2) * tmp_p),
        choice(
            branch("g1 damped minimum within the step", havoc(tm),
                   test(And(fnp > 0, fnp * tm == -1 * (fn - kt_p), tm <= e)), touch_min()),
            branch("g2 damped minimum after the step", havoc(tm),
                   test(And(fnp > 0, fnp * tm == -1 * (fn - kt_p), tm >= e)), assign(k, kt_p)),
            branch("g3 no minimum (fnp = 0)", test(fnp == 0), assign(k, kt_p)),
        ),
    )
    return seq(
        assign(d0, plane.distance()),
        assign(fn, force_x * plane.nx + force_y * plane.ny),
        assign(fnp, fxp * plane.nx + fyp * plane.ny),
        assign(dist, d0 + G * (fn * e + fnp * e**2 * Fraction(1, 2))),
        assign(disc, (G * fn)**2 - 2 * G * fnp * d0),
        choice(
            branch("a away, accelerating away", test(And(slowing, fn >= 0)), assign(k, 0)),
            branch("b turns before the plane (disc <= 0)", test(And(slowing, inward, disc <= 0)),
                   assign(k, 0)),
            branch("c would cross, but after the step",
                   test(And(slowing, inward, disc >= 0, fn + fnp * e <= 0, dist >= 0)), assign(k, 0)),
            branch("d accelerating in, clear at the end", test(And(fnp <= 0, dist >= 0)), assign(k, 0)),
            branch("e accelerating in, would cross: d(e) = 0", test(And(fnp <= 0, dist <= 0)), reach_end()),
            branch("f turns within the step: minimum touches",
                   test(And(slowing, inward, disc >= 0, fn + fnp * e >= 0)), touch_min()),
            branch("g still inward at the end, would cross",
                   test(And(slowing, inward, disc >= 0, fn + fnp * e <= 0, dist <= 0)), case_g),
        ),
    )



def _predictive_plant(*planes: _Plane) -> Program:
    vx_ = G * fx - G * sum((pl.k * pl.nx for pl in planes[1:]), planes[0].k * planes[0].nx)
    vy_ = G * fy - G * sum((pl.k * pl.ny for pl in planes[1:]), planes[0].k * planes[0].ny)
    return ode({px: vx_, py: vy_, fx: fxp, fy: fyp, t_imm: 1}, t_imm <= e_imm)


def predictive() -> Theorem:
    """6.2.2: predictive subtractive damping p' = G (f - k n), cases a-g, for one arbitrarily
    placed and oriented plane in 2D (the paper's medrobot_1fix_lin)."""
    plane = _Plane()
    step = seq(havoc(fxp), havoc(fyp), _predictive_control(plane, fx, fy), assign(t_imm, 0),
               _predictive_plant(plane))
    safe = plane.distance() >= 0
    return Theorem(
        name="sbs.predictive",
        assumptions=And(G > 0, e_imm > 0, plane.unit(), safe),
        program=loop(step, invariant=safe, label="control loop"),
        guarantee=safe,
        expected="proved",
        check_nonblocking=True,
        constants=(G, e_imm),
        abbreviations=plane.abbreviations(),
        # the refuter tries the x-axis with the safe side up first
        scenarios=(And(G == 1, e_imm == 1, plane.nx == 0, plane.ny == 1, plane.rx == 0, plane.ry == 0),),
        unroll=1,
        description="6.2.2: predictive subtractive damping, cases a-g, one plane",
    )


def predictive_multi() -> Theorem:
    """6.2.2 applied plane after plane, Eqn-2 style: plane 1's damping k1 is chosen for the
    surgeon's force, plane 2's k2 for the force already corrected by k1, and the tool moves
    with p' = G (f - k1 n1 - k2 n2). Each k is safe for its own plane, but k2's push along
    n2 has component k2 (n1·n2) along n1: when n1·n2 < 0 it drives the tool through plane 1."""
    one, two = _Plane("1"), _Plane("2")
    corrected_x, corrected_y = fx - one.k * one.nx, fy - one.k * one.ny
    step = seq(havoc(fxp), havoc(fyp),
               _predictive_control(one, fx, fy),
               _predictive_control(two, corrected_x, corrected_y),
               assign(t_imm, 0), _predictive_plant(one, two))
    safe = And(one.distance() >= 0, two.distance() >= 0)
    # The refuter first tries plane 1 facing +y and plane 2 along any axis: it must pick
    # n2 = -n1 itself, since n1·n2 >= 0 is safe (a push along n2 then helps plane 1).
    axes = [(1, 0), (-1, 0), (0, 1), (0, -1)]
    scenario = And(G == 1, e_imm == 1, one.nx == 0, one.ny == 1,
                   Or(*(And(two.nx == a, two.ny == b) for a, b in axes)))
    return Theorem(
        name="sbs.predictive_multi",
        assumptions=And(G > 0, e_imm > 0, one.unit(), two.unit(), safe),
        program=loop(step, invariant=safe, label="control loop"),
        guarantee=safe,
        expected="refuted",
        constants=(G, e_imm),
        abbreviations={**one.abbreviations("1"), **two.abbreviations("2"),
                       "n1n2_": dot((one.nx, one.ny), (two.nx, two.ny))},
        scenarios=(scenario,),
        unroll=1,
        description="6.2.2 applied plane after plane: one plane's correction pushes through another",
    )
