"""Dual-arm SCARA planner (the dual-arm paper): executing a plan, and the semantic inconsistency of §III.C.

The database's layer k was built from the principal's swept region over the joint box around
its planned pose θL(k) at time kΔt: the original box [θ - ωΔt, θ + ωΔt] per joint (step 3 of
Algorithm 1) or the modified one [θ, θ + σωΔt] (§IV.A; σ = +1 when θG > θS, else -1), and
the subordinate's box [h c - ωRΔt, h c + ωRΔt] per joint around its cell c (grid step h).
These models run the two arms in joint space, step k after step k, and observe the joint
angles at an arbitrary instant λΔt (λ in [0, 1]) of an arbitrary step; the guarantee is that
at that instant

    principal ∈ box of layer lay,  subordinate ∈ box of its cell c,  and ov[lay][c] is false,

where lay = min(k, N-1) is the layer the path's element k was checked against and ov[lay][c]
(an uninterpreted Bool array) says that the two swept regions of those boxes meet — by
Theorem 3's post P[lay][c] = 0 exactly when it is false. With the geometry lemmas
(`cfmpa.arc_in_triangle`, `cfmpa.sat_separates`: the kernel's enclosure of the swept region of
a box is sound) the arms are then disjoint at that instant; that last composition needs trig
and hull terms the DSL does not have, so it is stated here and tested numerically.

The principal: each joint a moves monotonically in direction σa at speed at most ωa (constant
within a step), never past its goal, and on schedule: at time kΔt it is at most
ωa·max(0, T_f - kΔt) from its goal, as both the synchronous PTP profile and per-joint full
speed are (T_f = max |θG - θS| / ω). N = ⌈T_f/Δt⌉ layers: (N-1)Δt < T_f <= NΔt. After N-1 the
database's last layer is reused (Property 4), with the principal parked at its goal.
The subordinate: follows a path of king moves cell to cell, one per step, in a straight joint
line, with grid step h <= ωRΔt (D4: m = ⌈2π/(ωRΔt)⌉); a path element k < len is checked
(P[min(k, N-1)][c] = 0), and after its last element it parks at the goal.

Mutants: the wrong direction σ, N rounded down, the grid rounded down (h > ωRΔt), a path
shorter than N (D6, early arrival), and boxes shrunk to the sampled poses. The segment
readings of §IV.A's undefined f (D11) are separate one-step models below.
"""

from __future__ import annotations

from fractions import Fraction

from certiloop.models.lang.conveniences import assign_min, if_
from certiloop.models.lang.programs import assign, branch, choice, havoc, loop, seq, skip, test
from certiloop.models.lang.terms import BOOL, INT, And, Array, Implies, Int, Ints, Not, Or, Real, Reals
from certiloop.models.lang.theorem import Theorem

JOINTS = (1, 2)
dt, Tf, wr, h, lam = Reals("dt Tf wr h lam")
k, N, ln, lay, ci, cj, ni, nj, co_i, co_j, lo = Ints("k N ln lay ci cj ni nj co_i co_j lo")
seen = Int("seen")
ov = Array("ov", (INT, INT, INT), BOOL)  # layer's swept principal region meets cell's swept region
S = {a: Real(f"S{a}") for a in JOINTS}  # principal start
G = {a: Real(f"G{a}") for a in JOINTS}  # principal goal
sg = {a: Real(f"sg{a}") for a in JOINTS}  # direction σa
w = {a: Real(f"w{a}") for a in JOINTS}  # speed limit ωLa
th = {a: Real(f"th{a}") for a in JOINTS}  # pose at the start of the current step
v = {a: Real(f"v{a}") for a in JOINTS}  # velocity during the step
bl = {a: Real(f"bl{a}") for a in JOINTS}  # planned pose of the layer in use (the box's base)
p = {a: Real(f"p{a}") for a in JOINTS}  # observed principal pose
bo = {a: Real(f"bo{a}") for a in JOINTS}  # observed box base
r = {a: Real(f"r{a}") for a in JOINTS}  # observed subordinate pose
CELL, NEXT, OBS = {1: ci, 2: cj}, {1: ni, 2: nj}, {1: co_i, 2: co_j}


def modified_box(a, x, base, direction=None):
    """x in [base, base + σωΔt] (ends ordered)."""
    s = sg[a] if direction is None else direction
    return And(s * (x - base) >= 0, s * (x - base) <= w[a] * dt)


def original_box(a, x, base):
    """x in [base - ωΔt, base + ωΔt]."""
    return And(x - base <= w[a] * dt, base - x <= w[a] * dt)


def _schedule():
    """The plan's parameters: directions, T_f, and N = ⌈T_f/Δt⌉ (or ⌊ ⌋ for the mutant)."""
    out = [dt > 0, wr > 0, h > 0, N >= 1, Tf >= 0]
    for a in JOINTS:
        out += [w[a] > 0, Or(sg[a] == 1, sg[a] == -1), sg[a] * (G[a] - S[a]) >= 0,
                sg[a] * (G[a] - S[a]) <= w[a] * Tf]
    return out


def _speed(a, hints: bool, allowed):
    """v_a := the principal's speed for this step. With hints (the refuted mutants) only full
    speed, standing still and reaching the goal within the step: a sub-program of the design,
    so a violating run of it is a run of the design, and one the falsifier finds (random draws
    rarely pass the test); it also keeps the refuter's case split small."""
    if not hints:
        return seq(havoc(v[a]), test(allowed))
    return choice(branch(f"joint {a} at full speed", assign(v[a], sg[a] * w[a]), test(allowed)),
                  branch(f"joint {a} reaches its goal", assign(v[a], (G[a] - th[a]) / dt), test(allowed)),
                  branch(f"joint {a} still", assign(v[a], 0), test(allowed)))


def _one_joint_moves(distance):
    """A narrow setting for the mutants: Δt = ω = 1, joint 1 turns by `distance` from 0, joint 2
    stays put (σ2 = -1 as the paper's rule gives for θG = θS), so T_f = distance."""
    return And(dt == 1, Tf == distance, w[1] == 1, w[2] == 1, sg[1] == 1, S[1] == 0, G[1] == distance,
               sg[2] == -1, S[2] == 0, G[2] == 0)


def _execution(name: str, expected: str, description: str, *, region: str = "modified",
               wrong_direction: bool = False, floor_layers: bool = False, floor_grid: bool = False,
               early: bool = False, narrow=None) -> Theorem:
    """The plan executed step by step; see the module docstring. region: which box the
    guarantee checks ("modified", "original", "backward" for the inconsistency, "pose")."""
    layer_count = And(N * dt >= Tf, (N - 1) * dt < Tf)
    if floor_layers:
        layer_count = And(N * dt <= Tf, Tf < (N + 1) * dt)
    grid = h <= wr * dt if not floor_grid else And(wr * dt < h, h <= 2 * wr * dt)
    length = ln >= N if not early else And(ln >= 1, ln < N)
    start = seq(assign(k, 0), assign(seen, 0), *(assign(th[a], S[a]) for a in JOINTS),
                *(assign(bl[a], S[a]) for a in JOINTS))
    # narrow: a mutant is refuted already in this smaller set of starts (a stronger refutation;
    # it keeps the falsifier's search small)
    extra = [narrow] if narrow is not None else []
    assumptions = And(*_schedule(), layer_count, grid, length, *extra)

    remaining = {a: sg[a] * (G[a] - th[a] - v[a] * dt) for a in JOINTS}
    on_schedule = {a: Or(remaining[a] <= 0, remaining[a] <= w[a] * (Tf - (k + 1) * dt)) for a in JOINTS}
    hints = expected == "refuted"  # a sub-program of the design: see _speed
    principal = seq(*(_speed(a, hints, And(sg[a] * v[a] >= 0, sg[a] * v[a] <= w[a], remaining[a] >= 0,
                                           on_schedule[a]))
                      for a in JOINTS))
    park = Implies(k + 1 >= ln, And(ni == ci, nj == cj))
    king = test(And(ni - ci <= 1, ci - ni <= 1, nj - cj <= 1, cj - nj <= 1, park))
    subordinate = seq(havoc(ni), havoc(nj), king)
    if hints:
        subordinate = choice(branch("subordinate waits", assign(ni, ci), assign(nj, cj), king),
                             branch("subordinate steps in i", assign(ni, ci + 1), assign(nj, cj), king))
    instant = seq(havoc(lam), test(And(0 <= lam, lam <= 1)))
    if hints:
        instant = assign(lam, 1)  # the end of the step, where every mutant's excursion is largest
    observe = seq(instant,
                  *(assign(p[a], th[a] + v[a] * lam * dt) for a in JOINTS),
                  *(assign(r[a], h * CELL[a] + h * (NEXT[a] - CELL[a]) * lam) for a in JOINTS),
                  *(assign(bo[a], bl[a]) for a in JOINTS),
                  assign(co_i, ci), assign(co_j, cj), assign(lo, lay), assign(seen, 1))
    advance = seq(*(assign(th[a], th[a] + v[a] * dt) for a in JOINTS), assign(ci, ni), assign(cj, nj),
                  assign(k, k + 1))
    step = seq(
        assign_min(lay, k, N - 1),
        test(Implies(k < ln, Not(ov[lay][ci][cj]))),  # the path's element k passed the check
        if_(k < N, seq(*(assign(bl[a], th[a]) for a in JOINTS)), skip(),
            labels=("moving: layer k's box is around the pose at kΔt", "stopped: last layer reused")),
        principal, subordinate, observe, advance)

    def box(a, x, base):
        if region == "original":
            return original_box(a, x, base)
        if region == "backward":  # the inconsistency: never behind the base
            return sg[a] * (x - base) >= 0
        if region == "pose":
            return x == base
        return modified_box(a, x, base, -sg[a] if wrong_direction else None)

    sub_box = (lambda a: r[a] == h * OBS[a]) if region == "pose" else (
        lambda a: And(r[a] - h * OBS[a] <= wr * dt, h * OBS[a] - r[a] <= wr * dt))
    safe_instant = And(*(box(a, p[a], bo[a]) for a in JOINTS), *(sub_box(a) for a in JOINTS),
                       Not(ov[lo][co_i][co_j]))
    guarantee = Implies(seen == 1, safe_instant)
    stopped = And(*(th[a] == G[a] for a in JOINTS),
                  *(And(sg[a] * (G[a] - bl[a]) >= 0, sg[a] * (G[a] - bl[a]) <= w[a] * dt) for a in JOINTS))
    invariant = And(k >= 0, Or(seen == 0, seen == 1), guarantee,
                    *(sg[a] * (G[a] - th[a]) >= 0 for a in JOINTS),
                    Implies(k >= N, stopped),
                    Implies(And(k >= 1, k < N + 1), And(*(Or(sg[a] * (G[a] - th[a]) <= 0,
                                                             sg[a] * (G[a] - th[a]) <= w[a] * (Tf - k * dt))
                                                          for a in JOINTS))),
                    Implies(k >= ln, And(Not(ov[N - 1][ci][cj]), ln >= 1)))
    return Theorem(
        name=name,
        assumptions=assumptions,
        program=seq(start, loop(step, invariant=invariant, label="plan step")),
        guarantee=guarantee,
        expected=expected,
        constants=(dt, Tf, wr, h, N, ln, *S.values(), *G.values(), *sg.values(), *w.values()),
        description=description,
        scenarios=(And(dt == 1, wr == 1, h == 1, N == 2, *(w[a] == 1 for a in JOINTS)),),
    )


def execution() -> Theorem:
    """The modified algorithm executed: the principal never leaves the modified box of the layer
    the subordinate's cell was checked against, the subordinate never leaves its cell's box,
    and that cell is free in that layer — at every instant of every step, including after the
    principal has stopped (layer N-1 reused)."""
    return _execution("cfmpa.execution", "proved",
                      "executing a plan, modified region: both arms stay in the boxes of a free cell")


def execution_original() -> Theorem:
    """The original algorithm executed: its symmetric boxes contain the modified ones, so it is
    safe too (conservative, not unsafe: the paper's 'security could be threatened' does not
    hold under the box reading of the swept region, D11)."""
    return _execution("cfmpa.execution_original", "proved",
                      "executing a plan, original region: safe too (the original is only conservative)",
                      region="original")


def original_backward_half_unreachable() -> Theorem:
    """The semantic inconsistency of §III.C, formalised: the principal never enters the backward
    half [θ - ωΔt, θ) of the original box, which the original algorithm reserves anyway."""
    return _execution("cfmpa.original_backward_half_unreachable", "proved",
                      "the inconsistency: the principal never enters the original box's backward half",
                      region="backward")


def execution_wrong_direction() -> Theorem:
    """The modified box built with the wrong direction (-σ): the principal leaves it at once."""
    return _execution("cfmpa.execution_wrong_direction", "refuted",
                      "modified box with the wrong direction: the principal leaves it", wrong_direction=True)


def execution_layers_floor() -> Theorem:
    """N = ⌊T_f/Δt⌋ (D4): the last layer is reused from step N on while the principal is still
    moving, and it leaves that layer's box."""
    return _execution("cfmpa.execution_layers_floor", "refuted",
                      "N rounded down: the last layer is reused while the principal still moves",
                      floor_layers=True, narrow=And(N == 1, _one_joint_moves(Fraction(3, 2))))


def execution_grid_floor() -> Theorem:
    """m = ⌊2π/(ωRΔt)⌋ (D4): the grid step exceeds ωRΔt and a move to the next cell leaves the
    subordinate's box around its cell."""
    return _execution("cfmpa.execution_grid_floor", "refuted",
                      "grid rounded down (h > ωRΔt): a king move leaves the cell's box", floor_grid=True,
                      narrow=And(dt == 1, wr == 1, h == Fraction(3, 2)))


def execution_early_arrival() -> Theorem:
    """D6: a path shorter than N reaches the goal while the principal still moves; the parked
    subordinate is never checked against layers len .. N-1."""
    return _execution("cfmpa.execution_early_arrival", "refuted",
                      "path shorter than N: the parked goal cell is unchecked in later layers", early=True,
                      narrow=And(N == 2, ln == 1, _one_joint_moves(2)))


def execution_pose_only() -> Theorem:
    """Boxes shrunk to the sampled poses (a database of static poses): between samples both arms
    are elsewhere, so a collision-free database of poses says nothing about the motion."""
    return _execution("cfmpa.execution_pose_only", "refuted",
                      "static poses only: the arms move between the sampled poses", region="pose")


# --------------------------------------------------------------------------- the segment reading of f (D11)

b1, b2 = Reals("b1 b2")


def _one_step(name: str, full_speed: bool, on_region, expected: str, description: str) -> Theorem:
    """One step of the principal from its planned pose (b1, b2), observed at λΔt. §IV.A's
    S'_LArm = f((θ1, θ2), (θ1 + σ1ω1Δt, θ2 + σ2ω2Δt)) with f read as the straight joint-space
    segment between the two poses (the *segment reading*) rather than the box they span."""
    speed = [v[a] == sg[a] * w[a] for a in JOINTS] if full_speed else \
        [And(sg[a] * v[a] >= 0, sg[a] * v[a] <= w[a]) for a in JOINTS]
    move = seq(*(havoc(v[a]) for a in JOINTS), test(And(*speed)), havoc(lam), test(And(0 <= lam, lam <= 1)),
               assign(p[1], b1 + v[1] * lam * dt), assign(p[2], b2 + v[2] * lam * dt))
    return Theorem(
        name=name,
        assumptions=And(dt > 0, *(And(w[a] > 0, Or(sg[a] == 1, sg[a] == -1)) for a in JOINTS)),
        program=move,
        guarantee=on_region(),
        expected=expected,
        constants=(dt, b1, b2, *sg.values(), *w.values()),
        description=description,
    )


def _on_original_segment():
    """On the segment from (θ1 - ω1Δt, θ2 - ω2Δt) to (θ1 + ω1Δt, θ2 + ω2Δt):
    p - b = μ (ω1Δt, ω2Δt) with |μ| <= 1."""
    return And((p[1] - b1) * w[2] == (p[2] - b2) * w[1], p[1] - b1 <= w[1] * dt, b1 - p[1] <= w[1] * dt)


def _on_modified_segment():
    """On the segment from (θ1, θ2) to (θ1 + σ1ω1Δt, θ2 + σ2ω2Δt): p - b = μ (σ1ω1Δt, σ2ω2Δt), 0 <= μ <= 1."""
    return And(sg[1] * (p[1] - b1) * w[2] == sg[2] * (p[2] - b2) * w[1],
               sg[1] * (p[1] - b1) >= 0, sg[1] * (p[1] - b1) <= w[1] * dt)


def execution_segment_original() -> Theorem:
    """Under the segment reading the original region (Algorithm 1's step 3 segment from
    θ - ωΔt to θ + ωΔt) misses the principal whenever its joints turn in opposite directions,
    even at full speed on both: the one reading under which 'security could be threatened'."""
    return _one_step("cfmpa.execution_segment_original", True, _on_original_segment, "refuted",
                     "segment reading of the original region: joints turning opposite ways leave it")


def execution_segment_modified() -> Theorem:
    """Under the segment reading the modified region is unsafe too unless |v1|/|v2| = ω1/ω2:
    a PTP move with one joint slower than its limit leaves the segment (and then S' ⊄ S)."""
    return _one_step("cfmpa.execution_segment_modified", False, _on_modified_segment, "refuted",
                     "segment reading of the modified region: unequal speed ratios leave it")


def segment_modified_full_speed() -> Theorem:
    """The segment reading of the modified region is exact when both joints run at their limits
    (|v1|/|v2| = ω1/ω2), whatever the directions: the only case where the paper's f is safe as
    a segment."""
    return _one_step("cfmpa.segment_modified_full_speed", True, _on_modified_segment, "proved",
                     "segment reading of the modified region holds when both joints run at full speed")
