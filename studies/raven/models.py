"""Raven-II deviation monitor (the Raven-II paper, Li, Alemzadeh et al., J. Healthcare Eng. 2017).

The paper runs a dynamical model of the robot beside the real arm; both get the same
command, and the deviation e = p_robot - p_model (eq 4's forward kinematics of both) raises
a spring-damper haptic force when ||e|| > tol = 3 mm (eqs 5-6). These models ask what that
monitor guarantees, as sampled-data loops at the control period eps (1 ms on Raven):

* the virtual fixture acts on the *model* (it keeps the model's distance d_m to a
  boundary >= m over every period: any command v it admits does), the robot follows the
  same command plus a fault push u with |u| <= U (constant over a period: the injected
  command and sensor streams are per-tick values);
* the monitor reads positions at each tick; on an alarm the stop fallback brakes both
  (v = u = 0 from then on, latched: pedal-up and motor brakes). The stop is immediate: a
  real brake's stopping distance adds to the margin, and the theorems assume the monitor
  reads the true robot position (encoder faults are the campaign's business).

Distances are along the boundary's unit normal, the safe side positive; the robot crosses
when d_r < 0. The margin the fixture must keep is m >= tol + U eps: the deviation is at most
tol when the last check passed and grows by at most U eps before the next one.
"""

from __future__ import annotations

from fractions import Fraction

from certiloop.models.lang.conveniences import assign_min, dot, if_
from certiloop.models.lang.programs import Program, assign, branch, choice, havoc, loop, ode, seq, skip, test
from certiloop.models.lang.terms import And, Family, ForAll, Implies, IndexSort, Or, Real, Reals, Var
from certiloop.models.lang.theorem import Theorem

dm, dr, v, u, U, tol, m, eps, t = Reals("dm dr v u U tol m eps t")
stopped = Real("stopped")  # 0 running, 1 stopped (latched E-STOP)


def _within(x, bound):
    """|x| <= bound, as two linear atoms."""
    return And(x <= bound, -x <= bound)


def _beyond(x, bound):
    """|x| > bound."""
    return Or(x > bound, -x > bound)


def _fault() -> Program:
    """u := any push with |u| <= U. The full push towards the boundary is listed apart (it
    adds no run: -U is within the bound) so that the falsifier tries it, not only random
    draws that rarely land on the bound."""
    return choice(branch("fault pushes in at U", assign(u, -U)),
                  branch("fault within U", havoc(u), test(_within(u, U))))


def _command() -> Program:
    """v := any command the fixture admits: the model stays >= m for the whole period (d_m
    is linear in time, so both ends suffice). Holding still is listed apart for the
    falsifier, as in `_fault`; the test is the same for both."""
    return seq(choice(branch("operator holds still", assign(v, 0)), branch("operator moves", havoc(v))),
               test(dm + v * eps >= m))


def _plant() -> Program:
    """The model follows the command, the robot the command plus the fault, for up to eps."""
    return seq(assign(t, 0), ode({dm: v, dr: v + u, t: 1}, t <= eps))


_BRAKE = seq(assign(stopped, 1), assign(v, 0), assign(u, 0))


def _stop_1d(name: str, margin_ok, expected: str, description: str) -> Theorem:
    alarm = Or(stopped == 1, _beyond(dr - dm, tol))
    react = if_(alarm, _BRAKE, seq(_fault(), _command()),
                labels=("deviation > tol: stop", "deviation <= tol: follow the fixture"))
    safe = And(dm >= m, dr >= 0)
    return Theorem(
        name=name,
        assumptions=And(tol > 0, U >= 0, eps > 0, margin_ok, dm >= m, dr >= 0, stopped == 0),
        program=loop(seq(react, _plant()), invariant=safe, label="control loop"),
        guarantee=dr >= 0,
        expected=expected,
        constants=(m, tol, U, eps),
        description=description,
    )


def deviation_stop(margin_factor=1) -> Theorem:
    """The stop fallback: with the model kept at m >= tol + U eps from the boundary, the
    robot never crosses it, whatever the fault does within |u| <= U. Invariant: d_m >= m and
    d_r >= 0; a period that starts with |e| <= tol ends with d_r >= m - tol - U eps.
    `margin_factor` scales the U eps term (1 is the theorem; tests show less is refuted)."""
    return _stop_1d("raven.deviation_stop", m >= tol + margin_factor * U * eps, "proved",
                    "1-D: deviation monitor + stop fallback, margin m >= tol + U eps: never crosses")


def deviation_small_margin() -> Theorem:
    """A margin of tol alone (tol <= m < tol + U eps) ignores that the deviation grows for a
    whole period before the next check: an undetected deviation of tol plus one period of
    push crosses in one tick."""
    return _stop_1d("raven.deviation_small_margin", And(tol <= m, m < tol + U * eps), "refuted",
                    "margin tol <= m < tol + U eps: crosses within one period, before the next check")


# --------------------------------------------------------------------------- the paper's haptic response

G, Kp, Kd, Fsat, F, w, ae, aw, dirn = Reals("G Kp Kd Fsat F w ae aw dirn")


def _abs(target, x) -> Program:
    return if_(x >= 0, assign(target, x), assign(target, -1 * x), labels=(f"{x} >= 0", f"{x} < 0"))


def deviation_haptic_only() -> Theorem:
    """The paper's response (eqs 5-6): an alarm only raises the spring-damper force
    F = min(Kp |e| + Kd |e'|, Fsat) towards the model; nothing stops the arm. The operator is
    modelled at their most helpful and fastest: hands off, the master moves with the cue at
    admittance G, so the command is v = G F d (d = sign(d_m - d_r), eq 6), which the fixture
    still filters. Both the model and the robot receive it, so it never shrinks the
    deviation (e' = u), and the robot's distance changes at G F d + u: a fault pushing at U
    above G Fsat wins (the paper keeps Fsat low so that the cue does not interfere with
    teleoperation). Starts with no deviation, with the stop theorem's margin m >= tol + U eps."""
    e = dr - dm
    haptic = if_(_beyond(e, tol),
                 seq(_abs(ae, e), _abs(aw, w), assign_min(F, Kp * ae + Kd * aw, Fsat),
                     if_(e < 0, assign(dirn, 1), assign(dirn, -1),
                         labels=("robot nearer: d = +1", "d = -1"))),
                 seq(assign(F, 0), assign(dirn, 0)),
                 labels=("deviation > tol: haptic force", "deviation <= tol: no force"))
    command = seq(assign(v, G * F * dirn),
                  if_(dm + v * eps >= m, skip(), assign(v, (m - dm) / eps),
                      labels=("fixture admits the command", "fixture attenuates it to keep the model at m")))
    step = seq(haptic, command, assign(w, u), _plant())
    return Theorem(
        name="raven.deviation_haptic_only",
        # refuted even in this narrow setting (it helps the falsifier): one constant push at
        # the full bound U, stronger than the cue's authority G Fsat
        assumptions=And(tol > 0, eps > 0, G > 0, Kp > 0, Kd >= 0, Fsat > 0, G * Fsat < U, u == -U,
                        m >= tol + U * eps, dm >= m, dr == dm, w == 0),
        program=loop(step, invariant=dm >= m, label="control loop"),
        guarantee=dr >= 0,
        expected="refuted",
        constants=(m, tol, U, eps, G, Kp, Kd, Fsat, u),
        unroll=3,
        description="the paper's haptic-only response (eq 5 force, no stop): a push above G Fsat crosses",
    )


# --------------------------------------------------------------------------- per-step residual vs drift

e0 = Real("e0")


def residual_drift() -> Theorem:
    """The per-step residual monitor (certiloop's `kernel/monitor.check_motion`, or any
    detector re-anchored to the measured robot each period) compares only the last period's
    motion with the model's: the residual is the change of the deviation, |e - e0|, where e0
    is the deviation at the previous check. A constant drift u with U eps < tol never trips
    it, and the deviation accumulates past the margin that makes the deviation monitor safe
    (m >= tol + U eps). The operator holds still and the fault is one constant drift: a run
    of the general design too, and (with tol/2 < U eps < tol) short enough for the
    falsifier's three periods. Narrower assumptions only make a refutation stronger."""
    alarm = Or(stopped == 1, _beyond(dr - dm - e0, tol))
    react = if_(alarm, seq(assign(stopped, 1), assign(v, 0)), seq(assign(v, 0), assign(e0, dr - dm)),
                labels=("residual > tol: stop", "residual <= tol: carry on, re-anchor"))
    drift = seq(assign(t, 0), ode({dm: v, dr: v + u * (1 - stopped), t: 1}, t <= eps))
    return Theorem(
        name="raven.residual_drift",
        # refuted even in this narrow setting: the drift is the full U towards the boundary,
        # between tol/2 and tol per period, and the margin exactly the stop theorem's
        assumptions=And(tol > 0, eps > 0, U * eps < tol, 2 * U * eps > tol, u == -U, m == tol + U * eps,
                        dm == m, dr == dm, e0 == 0, stopped == 0),
        program=loop(seq(react, drift), invariant=dr >= 0, label="control loop"),
        guarantee=dr >= 0,
        expected="refuted",
        constants=(m, tol, U, eps, u),
        unroll=3,
        description="per-step residual monitor vs a drift below tol per period: crosses, never alarms",
    )


# --------------------------------------------------------------------------- jumps

jumped, seen, jmp = Reals("jumped seen jmp")


def _jump(name: str, jump_size: Program, assumed, expected: str, description: str) -> Theorem:
    """A sudden jump (Table 1, H3; an add-once on the command or encoder stream) moves the
    robot by jmp at any instant of a period; the next check must alarm. `seen` records that
    a check ran after the jump; the guarantee: seen = 1 -> stopped = 1 (as seen <= stopped)."""
    alarm = Or(stopped == 1, _beyond(dr - dm, tol))
    check = seq(if_(alarm, _BRAKE, seq(_fault(), havoc(v)),
                    labels=("deviation > tol: stop", "deviation <= tol: carry on")),
                assign(seen, jumped))
    maybe_jump = choice(branch("jump", test(jumped == 0), jump_size, assign(dr, dr + jmp), assign(jumped, 1)),
                        branch("no jump", skip()))
    flow = ode({dm: v, dr: v + u, t: 1}, t <= eps)  # one period, split by the jump instant
    step = seq(check, assign(t, 0), flow, maybe_jump, flow)
    flags = And(*(Or(f == 0, f == 1) for f in (stopped, jumped, seen)))
    invariant = And(seen <= stopped, flags, Implies(And(jumped == 1, stopped == 0), _beyond(dr - dm, tol)))
    return Theorem(
        name=name,
        assumptions=And(tol > 0, U >= 0, eps > 0, assumed, stopped == 0, jumped == 0, seen == 0),
        program=loop(step, invariant=invariant, label="control loop"),
        guarantee=seen <= stopped,  # the 0/1 flags: seen = 1 -> stopped = 1, with a numeric margin
        expected=expected,
        constants=(tol, U, eps),
        unroll=2,
        description=description,
    )


def jump_detected() -> Theorem:
    """A jump of more than 2 tol + U eps, either way, is seen at the first check after it:
    the deviation was at most tol at the last check, and the rest of the period moves it by
    at most U eps. Starts from any deviation the monitor accepts."""
    # Premises in the paper's scale (tol = 3 mm, a workspace of metres): tol >= 1 mm and the
    # tips within 10 m at the start. Not needed by the proof; they keep the falsifier's float
    # runs in a range where a jump cannot vanish in rounding (a 1e-156 jump beside a 1e-18
    # position once produced a float-only "violation"; see the falsifier's known limits).
    return _jump("raven.jump_detected", seq(havoc(jmp), test(_beyond(jmp, 2 * tol + U * eps))),
                 And(_within(dr - dm, tol), tol >= Fraction(1, 1000), dr <= 10, dr >= -10,
                     dm <= 10, dm >= -10), "proved",
                 "a jump > 2 tol + U eps raises the alarm at the first check after it "
                 "(tol >= 1 mm, tips within 10 m)")


def jump_above_tol() -> Theorem:
    """"Larger than the threshold" is not enough: an add-once jump J with tol < J <= 2 tol
    against an accepted deviation of -tol leaves |e| <= tol, unseen. Refuted even with no
    other fault (U = 0)."""
    return _jump("raven.jump_above_tol", assign(jmp, Real("J")),
                 And(tol < Real("J"), Real("J") <= 2 * tol, U == 0, dr == dm - tol), "refuted",
                 "a jump J with tol < J <= 2 tol hides against an accepted deviation: no alarm")


# =========================================================================== 3-D, a family of planes

B = IndexSort("B")
nx, ny, nz, rx, ry, rz = (Family(name, B) for name in ("nx", "ny", "nz", "rx", "ry", "rz"))
j = Var("j", B)
pm = Reals("pmx pmy pmz")  # the model's tool tip
pr = Reals("prx pry prz")  # the robot's tool tip (encoders, eq 4)
vel = Reals("vx vy vz")  # the command both receive
push = Reals("ux uy uz")  # the fault's push on the robot


def _normal(b):
    return (nx(b), ny(b), nz(b))


def _dist(p, b):
    """Signed distance of p to plane b (unit normal n(b) through r(b)), safe side positive."""
    return dot([pc - rc for pc, rc in zip(p, (rx(b), ry(b), rz(b)))], _normal(b))


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _lagrange(a, b, ab):
    """Lagrange's identity (a·b)² + |a × b|² = |a|² |b|², with `ab` a term equal to a·b:
    Cauchy-Schwarz with its slack made explicit, a polynomial identity."""
    return ab**2 + dot(_cross(a, b), _cross(a, b)) == dot(a, a) * dot(b, b)


def _lemma(fact, label: str) -> Program:
    """A cut: `skip*` with invariant `fact`. skip* is skip, so no run changes; the loop rule
    proves `fact` where it stands (init) from what is known there and keeps it (a trivial
    step), and everything after it may use it. This lets a nonlinear fact be proved in a
    small obligation of its own instead of inside a large one."""
    return loop(skip(), invariant=fact, label=f"lemma: {label}")


def deviation_stop_3d() -> Theorem:
    """The stop fallback in 3-D against any finite family of arbitrarily placed planes,
    with the paper's Euclidean detector ||p_r - p_m|| > tol (as e·e > tol²) and a push
    |u| <= U (u·u <= U²). The proof needs |e·n| <= ||e|| ||n|| (Cauchy-Schwarz) for unit n,
    which z3 finds for itself."""
    e = [a - b for a, b in zip(pr, pm)]
    margin = tol + U * eps  # the least margin m that works (a fixture keeping more keeps this)
    alarm = Or(stopped == 1, dot(e, e) > tol**2)
    fault = seq(*(havoc(c) for c in push), test(dot(push, push) <= U**2))
    command = seq(*(havoc(c) for c in vel),
                  test(ForAll(j, _dist(pm, j) + eps * dot(vel, _normal(j)) >= margin)))
    # Cauchy-Schwarz for every plane, as a cut (see `_lemma`): nlsat does not find it
    # inside the step obligation, but proves it alone (Lagrange's identity)
    cs = ForAll(j, And(_lagrange(e, _normal(j), _dist(pr, j) - _dist(pm, j)),
                       _lagrange(push, _normal(j), dot(push, _normal(j)))))
    run = seq(fault, command, _lemma(cs, "|e·n| <= |e|, |u·n| <= |u| for unit n"))
    brake = seq(assign(stopped, 1), *(assign(c, 0) for c in (*vel, *push)))
    react = if_(alarm, brake, run, labels=("deviation > tol: stop", "deviation <= tol: follow the fixture"))
    plant = ode({**{c: vc for c, vc in zip(pm, vel)}, **{c: vc + uc for c, vc, uc in zip(pr, vel, push)},
                 t: 1}, t <= eps)
    safe = ForAll(j, And(_dist(pm, j) >= margin, _dist(pr, j) >= 0))
    return Theorem(
        name="raven.deviation_stop_3d",
        # `pr = pm ∨ ...` adds no start state (pr = pm puts the robot at the model, >= tol > 0
        # from every plane) but lets the falsifier's repair meet the assumptions more often
        assumptions=And(tol > 0, U >= 0, eps > 0,
                        ForAll(j, dot(_normal(j), _normal(j)) == 1), ForAll(j, _dist(pm, j) >= margin),
                        Or(And(*(a == b for a, b in zip(pr, pm))), ForAll(j, _dist(pr, j) >= 0)),
                        stopped == 0),
        program=loop(seq(react, assign(t, 0), plant), invariant=safe, label="control loop"),
        guarantee=ForAll(j, _dist(pr, j) >= 0),
        expected="proved",
        constants=(tol, U, eps),
        abbreviations=_abbreviations_3d(),
        description="3-D: Euclidean deviation monitor + stop, any finite family of planes, m >= tol + U eps",
    )


def _abbreviations_3d():
    """Per-plane projections, squared norms and the cross products of the Lagrange lemma:
    the step obligation becomes arithmetic in a dozen reals per plane."""
    b = Var("b_", B)
    e = [a - c for a, c in zip(pr, pm)]
    n = _normal(b)
    cross = {f"{name}{axis}_": c for name, a in (("ce", e), ("cu", push))
             for axis, c in zip("xyz", _cross(a, n))}
    return {"dm_": _dist(pm, b), "dr_": _dist(pr, b), "vn_": dot(vel, n), "un_": dot(push, n),
            "ee_": dot(e, e), "uu_": dot(push, push), "nn_": dot(n, n), **cross}


# =========================================================================== eqs 5-6: the force law

dp = Reals("dpx dpy dpz")  # p_model - p_robot (eq 4 on both)
dv = Reals("dvx dvy dvz")  # v_model - v_robot (eq 3 on both)
dirv = Reals("dx dy dz")  # the force direction, eq 6
cn = Reals("cx cy cz")  # a boundary's unit normal, the safe side positive
nrm, nv, n2 = Reals("nrm nv n2")


def haptic_force() -> Theorem:
    """Eqs 5-6 as a Hoare triple, with the reading of eq 5's garbled second branch that the
    text supports (a force only above tol, and a saturation): F = min(Kp ||dp|| + Kd ||dv||,
    Fsat) if ||dp|| > tol, else 0; d = dp / ||dp||, eq 6, only when the force is on (eq 6
    alone divides by zero at dp = 0, which certiloop rejects as ill-defined). Norms are
    square roots as `nrm := *; ?nrm >= 0 ∧ nrm² = ...`; the vacuity check proves such a
    value always exists, so the triple is not vacuous. Claims: F is exactly 0 at or below
    tol; 0 <= F <= Fsat; with Kp > 0 the force is on above tol; d is a unit vector along
    dp (moving along it shrinks the deviation); and for any boundary the model is farther
    inside than the robot (dp·c > 0), d points to the safe side (d·c > 0)."""
    above = n2 > tol**2
    on = seq(havoc(nrm), test(And(nrm >= 0, nrm * nrm == n2)),
             *(assign(dc, pc / nrm) for dc, pc in zip(dirv, dp)),
             havoc(nv), test(And(nv >= 0, nv * nv == dot(dv, dv))),
             assign_min(F, Kp * nrm + Kd * nv, Fsat))
    off = seq(assign(F, 0), *(assign(dc, 0) for dc in dirv))
    parts = {"F = 0 at or below tol": Implies(n2 <= tol**2, F == 0),
             "0 <= F <= Fsat": And(0 <= F, F <= Fsat),
             "F > 0 above tol when Kp > 0": Implies(And(above, Kp > 0), F > 0),
             "|d| = 1": Implies(above, dot(dirv, dirv) == 1),
             "d·dp > 0": Implies(above, dot(dirv, dp) > 0),
             "d·c > 0 when the robot is nearer the boundary": Implies(And(above, dot(dp, cn) > 0),
                                                                      dot(dirv, cn) > 0)}
    # each claim in an obligation of its own (`_lemma`): nlsat proves every one at once,
    # but not their conjunction in the saturated branch within the budget
    program = seq(assign(n2, dot(dp, dp)),
                  if_(above, on, off, labels=("||dp|| > tol: spring-damper force", "||dp|| <= tol: off")),
                  *(_lemma(part, label) for label, part in parts.items()))
    guarantee = And(*parts.values())
    return Theorem(
        name="raven.haptic_force",
        assumptions=And(tol > 0, Kp >= 0, Kd >= 0, Fsat > 0, dot(cn, cn) == 1),
        program=program,
        guarantee=guarantee,
        expected="proved",
        check_nonblocking=True,
        description="eqs 5-6: F = 0 below tol, 0 <= F <= Fsat, unit direction to the model and the safe side",
    )
