"""Skull-base-surgery virtual fixtures (seed 000, Kouskoulas et al., HSCC'13).

Symbols follow the seed: p = tool tip, f = surgeon force, fxp/fyp = force derivatives
(the inputs), G = admittance gain, D = slow-zone thickness. In Table 1 the boundary is the
x-axis and the safe side is py >= 0.
"""

from __future__ import annotations

from .programs import branch, choice, havoc, loop, ode, seq
from .terms import And, Reals
from .theorem import Theorem

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
