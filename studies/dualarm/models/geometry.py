"""Dual-arm SCARA planner (the dual-arm paper), the convex-polygon domain of §III.A.

The paper's collision test rests on Definitions 1-3 (segment, is_convex, convex hull) and
Lemmas 1-2 (the hull is monotone and contains the union of hulls). certiloop states them as
the facts the planner's geometry uses, in plain real arithmetic:

* Definition 1 as printed, `segment x y = {t x + (t - 1) y | 0 <= t <= 1}`, is the segment
  from -y to x, not from y to x; under it a half-plane is not "convex" (`segment_printed`,
  refuted). With `(1 - t)` it is (`halfspace_convex`).
* A hull point is reached from the vertices by repeated convex combinations
  `x := t x + (1 - t) a` (Definition 3 read constructively); a half-plane containing the
  vertices contains every such point (`hull_in_halfplane`: Lemmas 1-2 as the planner uses
  them). An axis that separates two vertex sets therefore separates their hulls
  (`sat_separates`: the separating-axis test the kernel runs per cell is sound).
* A link vertex rotating about its joint by an angle in [0, α] (α < π) leaves the hull of its
  two end positions: the arc bulges by r (1 - cos(α/2)) beyond the chord
  (`arc_in_chord_hull`, refuted), but stays in the triangle of its end positions and the
  apex where the end tangents meet, at r / cos(α/2) on the bisector (`arc_in_triangle`).
  So a swept region must be enclosed with the apex points, not with the end poses alone.
  Radii scale out: the vertex is on the unit circle, its start at angle 0; rotating the
  whole picture (R conv S = conv R S) gives any start angle.
* `joint_box_monotone`: the modified joint interval [θ, θ + σ ω Δt] of §IV.A lies in the
  original [θ - ω Δt, θ + ω Δt], for both directions σ — the S' ⊆ S behind Property 8.
"""

from __future__ import annotations

from certiloop.models.lang.programs import assign, branch, choice, havoc, loop, seq, test
from certiloop.models.lang.terms import And, Not, Or, Reals
from certiloop.models.lang.theorem import Theorem

x1, x2, y1, y2, z1, z2, t = Reals("x1 x2 y1 y2 z1 z2 t")
a1, a2, c = Reals("a1 a2 c")


def _in_half(p1, p2):
    """p lies in the closed half-plane a . p >= c."""
    return a1 * p1 + a2 * p2 >= c


def _segment_point(printed: bool):
    """z := a point of `segment x y`, Definition 1 as printed (t x + (t - 1) y) or repaired."""
    w = (t - 1) if printed else (1 - t)
    return seq(havoc(t), test(And(0 <= t, t <= 1)),
               assign(z1, t * x1 + w * y1), assign(z2, t * x2 + w * y2))


def segment_printed() -> Theorem:
    """Definition 1 as printed makes the segment run from -y to x: with x and y in the upper
    half-plane, t = 0 gives z = -y below it, so half-planes would not be convex (Def 2)."""
    return Theorem(
        name="cfmpa.segment_printed",
        assumptions=And(x2 >= 0, y2 >= 0),
        program=_segment_point(printed=True),
        guarantee=z2 >= 0,
        expected="refuted",
        description="Def 1 as printed (t x + (t-1) y): a half-plane is not convex under it",
    )


def halfspace_convex() -> Theorem:
    """Definition 1 with (1 - t): every half-plane is convex (Definition 2), the base case of
    all the hull reasoning below."""
    return Theorem(
        name="cfmpa.halfspace_convex",
        assumptions=And(_in_half(x1, x2), _in_half(y1, y2)),
        program=_segment_point(printed=False),
        guarantee=_in_half(z1, z2),
        description="Def 1 repaired (t x + (1-t) y): every half-plane is convex (Def 2)",
    )


def hull_in_halfplane() -> Theorem:
    """Lemmas 1-2 as the planner uses them: a point of the hull of a vertex set A, built by
    any number of steps x := t x + (1 - t) a (a in A, t in [0, 1]), stays in every half-plane
    that contains A. So conv A ⊆ H for every half-plane H ⊇ A (Lemma 1 with Y = H convex)."""
    step = seq(havoc(y1), havoc(y2), test(_in_half(y1, y2)), havoc(t), test(And(0 <= t, t <= 1)),
               assign(x1, t * x1 + (1 - t) * y1), assign(x2, t * x2 + (1 - t) * y2))
    return Theorem(
        name="cfmpa.hull_in_halfplane",
        assumptions=_in_half(x1, x2),
        program=loop(step, invariant=_in_half(x1, x2), label="convex combinations"),
        guarantee=_in_half(x1, x2),
        description="Lemmas 1-2 as used: the hull of vertices in a half-plane stays in it",
    )


def sat_separates() -> Theorem:
    """The separating-axis test is sound: if every vertex of polygon A has u . v <= s and every
    vertex of B has u . w > s, no point of conv A equals a point of conv B. Hull points are
    built as in `hull_in_halfplane`, for both polygons at once (in any interleaving)."""
    u1, u2, s, p1, p2, q1, q2 = Reals("u1 u2 s p1 p2 q1 q2")
    side_a = u1 * p1 + u2 * p2 <= s
    side_b = u1 * q1 + u2 * q2 > s
    grow_a = seq(havoc(y1), havoc(y2), test(u1 * y1 + u2 * y2 <= s), havoc(t), test(And(0 <= t, t <= 1)),
                 assign(p1, t * p1 + (1 - t) * y1), assign(p2, t * p2 + (1 - t) * y2))
    grow_b = seq(havoc(y1), havoc(y2), test(u1 * y1 + u2 * y2 > s), havoc(t), test(And(0 <= t, t <= 1)),
                 assign(q1, t * q1 + (1 - t) * y1), assign(q2, t * q2 + (1 - t) * y2))
    step = choice(branch("a hull point of A", grow_a), branch("a hull point of B", grow_b))
    return Theorem(
        name="cfmpa.sat_separates",
        assumptions=And(side_a, side_b),
        program=loop(step, invariant=And(side_a, side_b), label="convex combinations"),
        guarantee=Not(And(p1 == q1, p2 == q2)),
        constants=(u1, u2, s),
        description="separating axis: vertices split by u . x = s give disjoint hulls",
    )


# --------------------------------------------------------------------------- the arc bulge

ca, sa, cs, sn = Reals("ca sa cs sn")  # cos/sin of the sweep angle α; of the current angle φ
ua, u = Reals("ua u")  # tan(α/2), tan(φ/2)


def _on_arc():
    """(cs, sn) = (cos φ, sin φ) for some φ in [0, α], by the half-angle tangent u = tan(φ/2)
    in [0, tan(α/2)]: a rational parametrisation of the whole arc (φ < π), so counterexamples
    are exact rationals."""
    return seq(havoc(u), test(And(0 <= u, u <= ua)),
               assign(cs, (1 - u * u) / (1 + u * u)), assign(sn, 2 * u / (1 + u * u)))


def _sweep_angle():
    """(ca, sa) = (cos α, sin α) with 0 < α < π, from ua = tan(α/2) > 0."""
    return And(ua > 0, ca * (1 + ua * ua) == 1 - ua * ua, sa * (1 + ua * ua) == 2 * ua)


def _beyond_chord():
    """On the outer side of the chord from (1, 0) to (ca, sa) (the side away from the joint)."""
    return (1 + ca) * cs + sa * sn >= 1 + ca


def arc_in_chord_hull() -> Theorem:
    """The hull of a link's two end poses misses the arc bulge: a vertex half-way through the
    rotation lies beyond the chord of its end positions by r (1 - cos(α/2)) (9 mm at
    r = 1.8 m, α = 0.2 rad). The claim refuted: the swept vertex stays on the joint's side of
    the chord, i.e. inside the hull of the end poses."""
    return Theorem(
        name="cfmpa.arc_in_chord_hull",
        assumptions=_sweep_angle(),
        program=_on_arc(),
        guarantee=(1 + ca) * cs + sa * sn <= 1 + ca,
        expected="refuted",
        constants=(ca, sa, ua),
        description="hull of the end poses: the swept arc bulges out beyond the chord",
    )


def arc_in_triangle() -> Theorem:
    """The sound enclosure: the arc lies in the triangle of its end positions (1, 0), (ca, sa)
    and the apex (1, tan(α/2)) = (1, ua) where the end tangents meet — the three half-planes: behind
    the start tangent (x <= 1), behind the end tangent (ca x + sa y <= 1), beyond the chord.
    The kernel encloses each link vertex's sweep by these three points."""
    return Theorem(
        name="cfmpa.arc_in_triangle",
        assumptions=_sweep_angle(),
        program=_on_arc(),
        guarantee=And(cs <= 1, ca * cs + sa * sn <= 1, _beyond_chord()),
        constants=(ca, sa, ua),
        description="the swept arc lies in the triangle of its end points and the tangent apex",
    )


def joint_box_monotone() -> Theorem:
    """§IV.A's modified joint interval [θ, θ + σ ω Δt] (ends ordered) is inside the original
    [θ - ω Δt, θ + ω Δt] for σ = ±1: so S' ⊆ S, and P' <= P cell by cell (Property 8b).

    A point of the modified interval is written θ + σ u ω Δt for a fraction u in [0, 1] (every
    point, as ω Δt >= 0): the same set as `x := *; ?0 <= σ(x - θ) <= ω Δt`, but the falsifier
    meets the assumption on u by repair and the equation pins x, where the test after an open
    x blocked most runs."""
    th, w, dt, sg, x, u = Reals("th w dt sg x u")
    return Theorem(
        name="cfmpa.joint_box_monotone",
        assumptions=And(w >= 0, dt > 0, Or(sg == 1, sg == -1), 0 <= u, u <= 1),
        program=seq(havoc(x), test(x == th + sg * u * w * dt)),
        guarantee=And(th - w * dt <= x, x <= th + w * dt),
        constants=(th, w, dt, sg, u),
        description="the modified joint interval lies in the original one, both directions",
    )
