"""A climbing drone under an altitude ceiling H: the limiter lets it climb at full thrust A only
when braking at b after one more control period still stops it below H.

`certiloop prove drone_models.py:altitude_limiter` proves it; `no_reaction_time` forgets the
period the drone keeps climbing before the next decision, and is refuted with a concrete run.
"""

from certiloop.models import And, Reals, Theorem, assign, branch, choice, loop, ode, seq, test

h, v, a, A, b, H, eps, t = Reals("h v a A b H eps t")

# the drone may start anywhere it can still brake below the ceiling, climbing or hovering
START = And(v**2 <= 2 * b * (H - h), v >= 0, A >= 0, b > 0, eps > 0)
CAN_BRAKE = v**2 <= 2 * b * (H - h)  # the loop invariant: braking now stops below H


def limiter(climb_ok):
    """One control period: decide (climb or brake), then fly for at most eps seconds."""
    return seq(
        choice(branch("climb", test(climb_ok), assign(a, A)),
               branch("brake", test(~climb_ok), assign(a, -b))),
        assign(t, 0),
        ode({h: v, v: a, t: 1}, And(v >= 0, t <= eps)),
    )


def altitude_limiter():
    """Climb only if the room left covers braking from the speed reached after one more period."""
    climb_ok = H - h >= v**2 / (2 * b) + (A / b + 1) * (A / 2 * eps**2 + eps * v)
    return Theorem(
        name="drone.altitude_limiter",
        description="climbs at full thrust only when braking later still stops below the ceiling",
        assumptions=START,
        program=loop(limiter(climb_ok), invariant=CAN_BRAKE),
        guarantee=h <= H,
        constants=(A, b, H, eps),
    )


def no_reaction_time():
    """The same limiter checking only the braking distance at today's speed: it overshoots."""
    climb_ok = H - h >= v**2 / (2 * b)
    return Theorem(
        name="drone.no_reaction_time",
        description="forgets the climb during one control period: it overshoots the ceiling",
        expected="refuted",
        assumptions=START,
        program=loop(limiter(climb_ok), invariant=CAN_BRAKE),
        guarantee=h <= H,
        constants=(A, b, H, eps),
    )
