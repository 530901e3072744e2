"""Problem shaping before z3 (proofs/core/shaping.py) and the obligations it lets z3 prove.

Independent witnesses: a small Fraction evaluator written here (not proofs/core/exact.py) for
the equivalence of cleared comparisons at random rational points; hand proofs (below) and
exact sampling of the adaptive cruise control's step; explicit runs, computed here in exact
arithmetic from the closed-form flow, for the false variants, none of which may prove.
"""

from __future__ import annotations

import random
from fractions import Fraction

import pytest

from certiloop.models.lang.programs import assign, branch, choice, havoc, loop, ode, seq, test
from certiloop.models.lang.terms import And, Implies, Node, Or, Real, Reals
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.shaping import (
    clear_denominators,
    drop_stale,
    goal_parts,
    hypotheses_and_goal,
    shaped_parts,
)
from certiloop.proofs.core.vcgen import Obligation
from certiloop.proofs.engine import Prover
from certiloop.proofs.engine.discharge import discharge_one

# --------------------------------------------------------------------------- an evaluator


def value(n: Node, env: dict[str, Fraction]):
    """n at a state, exactly; None where a division is by zero."""
    op = n.op
    if op == "const":
        return Fraction(n.payload)
    if op == "var":
        return env[n.payload]
    if op in ("true", "false"):
        return op == "true"
    args = [value(a, env) for a in n.args]
    if any(a is None for a in args):
        return None
    if op == "+":
        return sum(args, Fraction(0))
    if op == "*":
        out = Fraction(1)
        for a in args:
            out *= a
        return out
    if op == "neg":
        return -args[0]
    if op == "^":
        return args[0] ** n.payload
    if op == "/":
        return None if args[1] == 0 else args[0] / args[1]
    if op == "cmp":
        a, b = args
        return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "==": a == b, "!=": a != b}[n.payload]
    if op == "and":
        return all(args)
    if op == "or":
        return any(args)
    if op == "not":
        return not args[0]
    if op == "implies":
        return (not args[0]) or args[1]
    raise TypeError(op)


def rational(rng: random.Random) -> Fraction:
    return Fraction(rng.randint(-40, 40), rng.randint(1, 6))


B, p, q, v, w, c = Reals("B p q v w c")


# --------------------------------------------------------------------------- clearing


@pytest.mark.parametrize("sign_fact, flips", [(B > 0, False), (B < 0, True), (B >= 1, False),
                                               (-2 * B > 3, True)])
@pytest.mark.parametrize("atom", [p + v**2 / (2 * B) < q + w**2 / (2 * B),
                                  p + v / B <= q * (c / (3 * B) + 1),
                                  v**2 / B**2 == w,
                                  (c / B + 1) * (v + w / 2) >= p])
def test_a_cleared_comparison_is_the_same_where_the_sign_fact_holds(sign_fact, flips, atom):
    f = Implies(And(sign_fact, p >= -100), atom)
    shaped = clear_denominators(f)
    assert not shaped.same(f)
    hyps, goal = hypotheses_and_goal(shaped)
    assert "/" not in str(goal).replace("/2", "").replace("/3", "")
    rng = random.Random(7)
    checked = 0
    while checked < 200:
        env = {n: rational(rng) for n in "pqvwc"}
        env["B"] = rational(rng)
        if not value(sign_fact, env):
            continue
        assert value(goal, env) == value(atom, env), env
        checked += 1


@pytest.mark.parametrize("fact", [B >= 0, B != 0, B > -1, Or(B > 0, B < 0), c > 0])
def test_a_divisor_whose_sign_is_not_fixed_is_left_alone(fact):
    """B >= 0 lets B be 0, B != 0 leaves its sign open (the direction would be unknown), a
    disjunction is not a top-level fact: nothing is multiplied out."""
    f = Implies(And(fact, p >= 0), p + v**2 / (2 * B) < q)
    assert clear_denominators(f).same(f)


def test_an_even_power_of_a_nonzero_divisor_is_cleared():
    f = Implies(B != 0, v / B**2 <= w)
    hyps, goal = hypotheses_and_goal(clear_denominators(f))
    assert "/" not in str(goal)


# --------------------------------------------------------------------------- stale facts


def test_stale_facts_are_dropped_and_only_they():
    x, x1, k = Real("x"), Real("x@1"), Real("K")
    f = Implies(And(x >= 0, x <= k, k > 0, x1 >= 0, x1 <= k), x1 / 2 <= k)
    g = drop_stale(f)
    hyps, goal = hypotheses_and_goal(g)
    assert [str(h) for h in hyps] == ["K > 0", "x@1 >= 0", "x@1 <= K"]
    assert goal.same(x1 / 2 <= k)


def test_a_stale_fact_linked_to_a_current_value_stays():
    """x@1 >= x ties the new value to the old one: the old one's facts are needed."""
    x, x1 = Real("x"), Real("x@1")
    f = Implies(And(x >= 1, x1 >= x), x1 > 0)
    assert drop_stale(f) is None


def test_goal_parts_are_the_conjuncts():
    parts = goal_parts(Implies(p > 0, And(p > -1, q > p, Implies(q > 0, v > 0))))
    assert [str(part.args[1]) for part in parts] == ["p > -1", "q > p", "q > 0 -> v > 0"]


def test_false_obligations_do_not_prove_shaped():
    """Mutants of a true shaped obligation: sign fact weakened, comparison flipped."""
    true = Implies(And(B > 0, p + v**2 / (2 * B) <= q, v >= 0, w >= v),
                   And(p <= q, p + w**2 / (2 * B) >= p + v**2 / (2 * B)))
    assert shaped_parts(true) is not None
    assert discharge_one(Obligation("o1", "t", true, "t", {})).verdict == "proved"
    weakened = Implies(And(B >= 0, p + v**2 / (2 * B) <= q, v >= 0, w >= v),
                       And(p <= q, p + w**2 / (2 * B) >= p + v**2 / (2 * B)))  # B = 0: z3's x/0
    flipped = Implies(And(B > 0, p + v**2 / (2 * B) <= q, v >= 0, w >= v),
                      And(p <= q, p + w**2 / (2 * B) <= p + v**2 / (2 * B)))
    for f in (weakened, flipped):
        assert discharge_one(Obligation("o1", "t", f, "t", {})).verdict != "proved"


# --------------------------------------------------------------------------- a user's ACC

xf, vf, af, xl, vl, al, A, T, t = Reals("xf vf af xl vl al A T t")


def acc(guard, safe, assumptions=None, inv_extra=(xf < xl,), leader_brake=-B) -> Theorem:
    """A follower behind a leader, both braking with B or accelerating with A, the follower's
    controller choosing every T seconds; the classic stopping-distance loop invariant."""
    leader = seq(havoc(al), test(And(leader_brake <= al, al <= A)))
    follower = choice(branch("accelerate", test(guard), assign(af, A)), branch("brake", assign(af, -B)))
    plant = seq(assign(t, 0), ode({xf: vf, vf: af, xl: vl, vl: al, t: 1}, And(vf >= 0, vl >= 0, t <= T)))
    inv = And(*inv_extra, vf >= 0, vl >= 0, safe)
    pre = assumptions if assumptions is not None else And(B > 0, A >= 0, T > 0)
    return Theorem(name="user.acc", assumptions=And(pre, inv),
                   program=loop(seq(leader, follower, plant), invariant=inv),
                   guarantee=xf < xl, expected="proved", constants=(A, B, T))


SAFE_DIV = xf + vf**2 / (2 * B) < xl + vl**2 / (2 * B)
GUARD_DIV = xf + vf**2 / (2 * B) + (A / B + 1) * (A / 2 * T**2 + T * vf) < xl + vl**2 / (2 * B)
SAFE_MUL = 2 * B * xf + vf**2 < 2 * B * xl + vl**2
GUARD_MUL = 2 * B * xf + vf**2 + (A + B) * (A * T**2 + 2 * T * vf) < 2 * B * xl + vl**2


def prove(theorem: Theorem) -> str:
    with Prover(jobs=1) as prover:
        return prover.prove(theorem, search=False).verdict


def accelerate_step_holds(b, a, tt, xf0, vf0, xl0, vl0, al0, s) -> bool | None:
    """The accelerate branch's step at one sample, exactly: None if the sample is not a run of
    it (guard, leader's choice, domain), else whether the invariant holds after s seconds.
    Hand proof that it always does: with E(x, v) = 2*B*x + v^2, along the leader's flow
    E grows by s*(B + al)*(vl0 + vl(s)) >= 0 (al >= -B, both speeds >= 0); along the
    follower's it grows by s*(A + B)*(2*vf0 + A*s) <= T*(A + B)*(2*vf0 + A*T), which the guard
    leaves room for. The gap xl - xf stays positive: at its minimum over [0, s] it is either
    the start, or a time where vf = vl (or s with vf >= vl), and there E's order gives it."""
    guard = 2 * b * xf0 + vf0**2 + (a + b) * (a * tt**2 + 2 * tt * vf0) < 2 * b * xl0 + vl0**2
    inv0 = xf0 < xl0 and vf0 >= 0 and vl0 >= 0 and 2 * b * xf0 + vf0**2 < 2 * b * xl0 + vl0**2
    if not (guard and inv0 and -b <= al0 <= a and 0 <= s <= tt and vl0 + al0 * s >= 0):
        return None
    xf1, vf1 = xf0 + vf0 * s + a * s**2 / 2, vf0 + a * s
    xl1, vl1 = xl0 + vl0 * s + al0 * s**2 / 2, vl0 + al0 * s
    return xf1 < xl1 and vf1 >= 0 and vl1 >= 0 and 2 * b * xf1 + vf1**2 < 2 * b * xl1 + vl1**2


def test_the_acc_step_holds_at_exact_samples():
    rng = random.Random(3)
    seen = 0
    for _ in range(20000):
        b, a, tt = (Fraction(rng.randint(1, 8), rng.randint(1, 4)) for _ in range(3))
        xf0 = Fraction(rng.randint(-20, 20), 2)
        xl0 = xf0 + Fraction(rng.randint(1, 60), 3)
        vf0, vl0 = Fraction(rng.randint(0, 20), 2), Fraction(rng.randint(0, 20), 2)
        al0 = Fraction(rng.randint(-8, 8), 4)
        s = tt * Fraction(rng.randint(0, 8), 8)
        holds = accelerate_step_holds(b, a, tt, xf0, vf0, xl0, vl0, al0, s)
        if holds is not None:
            seen += 1
            assert holds
    assert seen > 200


@pytest.mark.parametrize("guard, safe", [(GUARD_DIV, SAFE_DIV), (GUARD_MUL, SAFE_MUL)],
                         ids=["dividing by B", "multiplied out"])
def test_a_users_acc_proves_from_the_loop_invariant_alone(guard, safe):
    assert prove(acc(guard, safe)) == "proved"


def test_acc_mutants_do_not_prove():
    """Each is false; the run that shows it is computed here exactly."""
    # 1. no look-ahead: xf=0 vf=0, xl=1 vl=0, B=A=T=1: the guard 0 < 2 holds, the follower
    #    accelerates for 1 s to xf=1/2, vf=1: E_f = 2*1/2 + 1 = 2 = E_l, the invariant fails.
    assert not (2 * Fraction(1, 2) + 1 < 2 * 1 + 0)
    assert prove(acc(SAFE_MUL, SAFE_MUL)) != "proved"
    # 2. the leader may brake harder than B (-2B): B=1, T=1, xf=0 vf=2 (E_f = 4), xl=1 vl=2
    #    (E_l = 6). The leader brakes with -2 and stops after 1 s at xl=2 (E_l = 4); the
    #    follower brakes with -1 for 1 s: xf = 3/2, vf = 1, E_f = 3 + 1 = 4, not < 4.
    assert 0 < 1 and 4 < 6
    assert (1 + 2 - Fraction(2, 2), 2 - 2) == (2, 0) and (2 - Fraction(1, 2), 2 - 1) == (Fraction(3, 2), 1)
    assert not (2 * Fraction(3, 2) + 1 < 2 * 2 + 0)
    assert prove(acc(GUARD_MUL, SAFE_MUL, leader_brake=-2 * B)) != "proved"
    # 3. B >= 0 instead of B > 0, dividing: B = 0 divides by zero (ill-defined, not proved)
    assert prove(acc(GUARD_DIV, SAFE_DIV, assumptions=And(B >= 0, A >= 0, T > 0))) != "proved"
    # 4. the invariant forgets xf < xl: the guarantee does not follow from it (xf=2, xl=1,
    #    vl=2, vf=0, B=1: E_f = 4 < E_l = 2 + 4 = 6 and xf > xl)
    assert 2 * 2 + 0 < 2 * 1 + 4 and not (2 < 1)
    assert prove(acc(GUARD_MUL, SAFE_MUL, inv_extra=())) != "proved"
