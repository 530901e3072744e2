"""Textbook hybrid systems, each with a correct design and a subtly wrong one.

Together they exercise every proof rule: loop invariants, differential invariants (dI),
differential cuts (dC), and reasoning from polynomial ODE solutions.
"""

from __future__ import annotations

from certiloop.models.lang.conveniences import if_
from certiloop.models.lang.programs import assign, branch, choice, havoc, loop, ode, seq, test
from certiloop.models.lang.roles import Roles
from certiloop.models.lang.terms import And, Or, Reals
from certiloop.models.lang.theorem import Theorem

h, v, g, c, H = Reals("h v g c H")


def _ball(name: str, c_max, expected: str, description: str) -> Theorem:
    energy = 2 * g * h + v**2 <= 2 * g * H
    flight = ode({h: v, v: -g}, h >= 0, invariants=[energy])
    bounce = if_(h == 0, assign(v, -c * v), labels=("on the ground: bounce", "in the air"))
    return Theorem(
        name=name,
        assumptions=And(0 <= h, h <= H, v == 0, g > 0, 0 <= c, c <= c_max),
        program=loop(seq(flight, bounce), invariant=And(0 <= h, energy), label="bounce loop"),
        guarantee=And(0 <= h, h <= H),
        expected=expected,
        constants=(g, c, H),
        description=description,
    )


def bouncing_ball() -> Theorem:
    """A ball dropped from rest at height <= H, losing energy at each bounce (0 <= c <= 1),
    never rises above H. Proof: loop invariant + dI on the energy 2gh + v^2."""
    return _ball("textbook.bouncing_ball", 1, "proved",
                 "ball with restitution c <= 1 stays below H (loop invariant, dI)")


def bouncing_ball_superelastic() -> Theorem:
    """Restitution up to 2: after one bounce the ball climbs above its drop height."""
    return _ball("textbook.bouncing_ball_superelastic", 2, "refuted",
                 "restitution may exceed 1: the ball rises above H")


# --------------------------------------------------------------------------- braking train

p, vt, a, A, b, m, eps, t = Reals("p vt a A b m eps t")


def _train(name: str, brake_zone, expected: str, description: str) -> Theorem:
    control = choice(
        branch("brake", test(brake_zone), assign(a, -b)),
        branch("accelerate", test(~brake_zone), assign(a, A)),
    )
    plant = seq(assign(t, 0), ode({p: vt, vt: a, t: 1}, And(vt >= 0, t <= eps)))
    stop_distance = vt**2 <= 2 * b * (m - p)
    return Theorem(
        name=name,
        assumptions=And(stop_distance, vt >= 0, A >= 0, b > 0, eps > 0),
        program=loop(seq(control, plant), invariant=stop_distance, label="control loop"),
        guarantee=p <= m,
        expected=expected,
        constants=(A, b, m, eps),
        description=description,
    )


def train() -> Theorem:
    """A train with braking b and acceleration A, controlled every eps seconds, brakes
    when accelerating for one more cycle could overrun its stopping distance to m.
    Proof: loop invariant vt^2 <= 2b(m - p), ODE by its solution."""
    lookahead = m - p <= vt**2 / (2 * b) + (A / b + 1) * (A / 2 * eps**2 + eps * vt)
    return _train("textbook.train", lookahead, "proved",
                  "time-triggered train braking before m (loop invariant, ODE solution)")


def train_no_lookahead() -> Theorem:
    """The brake zone forgets that the train keeps accelerating for up to eps seconds
    before the controller runs again."""
    return _train("textbook.train_no_lookahead", m - p <= vt**2 / (2 * b), "refuted",
                  "brake zone without the one-cycle look-ahead: overruns m")


# --------------------------------------------------------------------------- water tank

x, f, lo, hi, r = Reals("x f lo hi r")


def _tank(name: str, fill_guard, expected: str, description: str) -> Theorem:
    control = choice(
        branch("fill", test(fill_guard), assign(f, r)),
        branch("drain", test(x - r * eps >= lo), assign(f, -r)),
        branch("hold", assign(f, 0)),
    )
    plant = seq(assign(t, 0), ode({x: f, t: 1}, t <= eps))
    level_ok = And(lo <= x, x <= hi)
    return Theorem(
        name=name,
        assumptions=And(level_ok, r > 0, eps > 0),
        program=loop(seq(control, plant), invariant=level_ok, label="control loop"),
        guarantee=level_ok,
        expected=expected,
        constants=(r, eps, lo, hi),
        description=description,
    )


def water_tank() -> Theorem:
    """A sampled pump controller keeps the level in [lo, hi]: it fills or drains at rate r
    only if a whole control period of that keeps the level in range."""
    return _tank("textbook.water_tank", x + r * eps <= hi, "proved",
                 "sampled fill/drain/hold keeps the level in range (loop invariant, ODE solution)")


def water_tank_late_check() -> Theorem:
    """The fill guard checks the level now, not at the end of the period: it overflows."""
    return _tank("textbook.water_tank_late_check", x <= hi, "refuted",
                 "fill guard ignores the period eps: the tank overflows")


# --------------------------------------------------------------------------- dC chain

y, w, acc, y0 = Reals("y w acc y0")


def _cart(name: str, acc_ok, expected: str, description: str) -> Theorem:
    drive = ode({y: w, w: acc}, invariants=[w >= 0, y >= y0])
    return Theorem(
        name=name,
        assumptions=And(y == y0, w >= 0),
        program=loop(seq(havoc(acc), test(acc_ok), drive),
                     invariant=And(w >= 0, y >= y0), label="drive loop"),
        guarantee=y >= y0,
        expected=expected,
        constants=(y0,),
        description=description,
    )


def cart_forward() -> Theorem:
    """A cart that never brakes never moves back: the differential cut w >= 0 (dI) makes
    y >= y0 provable by dI, which alone it is not."""
    return _cart("textbook.cart_forward", acc >= 0, "proved",
                 "non-negative acceleration never moves the cart back (dC chain of two dI)")


def cart_may_brake() -> Theorem:
    """Braking is allowed and nothing stops the cart at zero speed: it reverses."""
    return _cart("textbook.cart_may_brake", Or(acc >= 0, acc >= -1), "refuted",
                 "braking allowed: the cart rolls back past its start")


# --------------------------------------------------------------------------- adaptive cruise control

v, pl, vl, al, B = Reals("v pl vl al B")


def _cruise(name: str, accelerate_zone, expected: str, description: str) -> Theorem:
    leader = seq(havoc(al), test(And(-B <= al, al <= A)))  # the environment: any acceleration in [-B, A]
    control = choice(
        branch("accelerate", test(accelerate_zone), assign(a, A)),
        branch("stopped", test(v == 0), assign(a, 0)),
        branch("brake", assign(a, -B)),
    )
    plant = seq(assign(t, 0), ode({p: v, v: a, pl: vl, vl: al, t: 1}, And(v >= 0, vl >= 0, t <= eps)))
    # both brake at B at most: the follower stays behind if it can stop before the leader can
    safe_distance = And(p < pl, p + v**2 / (2 * B) < pl + vl**2 / (2 * B), v >= 0, vl >= 0)
    return Theorem(
        name=name,
        assumptions=And(B > 0, A >= 0, eps > 0, safe_distance),
        program=loop(seq(leader, control, plant), invariant=safe_distance, label="control loop"),
        guarantee=p < pl,
        expected=expected,
        constants=(A, B, eps),
        description=description,
        roles=Roles(environment=(al,), controls=(a,)),
    )


def adaptive_cruise() -> Theorem:
    """A follower at p, v behind a leader at pl, vl, both accelerating in [-B, A]; the leader's
    acceleration al is the environment's choice, the follower's a the controller's (declared
    `roles`: `extract` gives a controller of the follower's state and the leader's position and
    speed, and an environment monitor of -B <= al <= A). The follower accelerates only if a whole
    period of that keeps its stopping point behind the leader's. Proof: loop invariant, ODE by
    its solution."""
    # p + v^2/(2B) + (A/B + 1)(A/2 eps^2 + eps v) < pl + vl^2/(2B), times 2B > 0: no division in the
    # guard, so the controller has a run wherever the model has (even at B = 0, outside the assumptions)
    lookahead = 2 * B * p + v**2 + (A + B) * (A * eps**2 + 2 * eps * v) < 2 * B * pl + vl**2
    return _cruise("textbook.adaptive_cruise", lookahead, "proved",
                   "follower keeps behind a leader that may brake at any time (loop invariant, ODE solution)")


def adaptive_cruise_no_lookahead() -> Theorem:
    """The accelerate zone compares stopping points now, forgetting the period of acceleration
    before the controller runs again: the follower hits the leader."""
    zone = 2 * B * p + v**2 < 2 * B * pl + vl**2
    return _cruise("textbook.adaptive_cruise_no_lookahead", zone, "refuted",
                   "accelerate zone without the one-period look-ahead: hits the leader")
