"""Theme 10: vacuity (Theorem(check_nonblocking=True)): does the control step always have a
run from every state it can start in?

Every theorem here is safe (truth "true"), so the engine goes on to the vacuity check; the
`nonblocking` label says whether the step can block. A "blocks" witness exhibits a reachable
state (from an initial state satisfying the assumptions, by a concrete run) and shows the
step has no run from it; a "runs" witness builds a run of the step from sampled reachable
states. The control step is the body of the program's loop; for a program that is not a
loop it is the body of its top-level loop (cases are chosen so that reading the whole
program as the step gives the same label)."""

from __future__ import annotations

from certiloop.models import (
    BOOL,
    FALSE,
    TRUE,
    And,
    Family,
    ForAll,
    Implies,
    IndexSort,
    Int,
    Ints,
    Not,
    Reals,
    Theorem,
    Var,
    assign,
    choice,
    for_range,
    foreach,
    havoc,
    loop,
    ode,
    seq,
    test,
)

from .harness import SAMPLES, Case, Q, check, rat, rint, rng

CASES: list[Case] = []


def case(id, nonblocking, witness, truth="true", **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, nonblocking=nonblocking, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(
        name=name, assumptions=assumptions, program=program, guarantee=guarantee, check_nonblocking=True, **kw
    )


x, y, u, p, q, D, d, t = Reals("x y u p q D d t")
n, m, k, cnt = Ints("n m k cnt")
B = IndexSort("B")
i, j = Var("i", B), Var("j", B)
done = Family("done", B, BOOL)
F = Family("F", B)


def no_int(pred, lo=-2000, hi=2000):
    return not any(pred(v) for v in range(lo, hi + 1))


# --------------------------------------------------------------------------- tests that can fail
def w_countdown():
    # SAFE: x >= 0 is kept (the test x > 0 precedes x := x - 1 on integers).
    # BLOCKS: from x = 1 one step reaches x = 0, where ?x > 0 has no run.
    xx = 1
    check(xx > 0)
    xx -= 1
    check(not (xx > 0))


@case("vac-countdown-test-blocks", "blocks", w_countdown)
def _():
    # TRUE, BLOCKS: an Int countdown reaches 0, where its guard fails and nothing else runs.
    xi = Int("xi")
    return T("vac-cd", xi >= 1, loop(seq(test(xi > 0), assign(xi, xi - 1)), invariant=xi >= 0), xi >= 0)


def w_int_none():
    # SAFE: x is never written. BLOCKS: 2n = 1 has no integer solution (2n is even), from any state.
    check(no_int(lambda v: 2 * v == 1))


@case("vac-int-witness-missing-blocks", "blocks", w_int_none)
def _():
    # TRUE, BLOCKS: n := *; ?2n = 1 over the integers never runs.
    return T("vac-int", x == 0, loop(seq(havoc(n), test(2 * n == 1), assign(y, n)), invariant=x == 0), x == 0)


def w_int_real_target():
    # SAFE: x, y unchanged... BLOCKS: from x = 1/2 (allowed) no integer n equals x.
    check(no_int(lambda v: v == Q(1, 2)))


@case("vac-int-witness-real-target-blocks", "blocks", w_int_real_target)
def _():
    # TRUE, BLOCKS: n := *; ?n = x with x = 1/2 has no integer witness.
    return T("vac-int-x", y == 0, loop(seq(havoc(n), test(n == x)), invariant=y == 0), y == 0)


def w_int_exists():
    # RUNS: n := m + 1 is an integer witness for every integer m.
    g = rng("vac-int-ok")
    for _ in range(SAMPLES):
        mm = rint(g, -1000, 1000)
        nn = mm + 1
        check(nn == mm + 1)


@case("vac-int-witness-exists-runs", "runs", w_int_exists)
def _():
    # TRUE, RUNS: n := *; ?n = m + 1 always has the witness m + 1.
    return T("vac-int-ok", x == 0, loop(seq(havoc(n), test(n == m + 1)), invariant=x == 0), x == 0)


@case("vac-int-witness-even-runs", "runs", w_int_exists)
def _():
    # TRUE, RUNS: n := *; ?2n = 2m has the witness n = m.
    return T("vac-int-ok2", x == 0, loop(seq(havoc(n), test(2 * n == 2 * m)), invariant=x == 0), x == 0)


def w_lin_runs():
    # RUNS: u = d / D solves u·D = d when D > 0.
    g = rng("vac-lin")
    for _ in range(SAMPLES):
        DD, dd = rat(g, Q(1, 64), 10), rat(g, -10, 10)
        check((dd / DD) * DD == dd)


@case("vac-linear-witness-runs", "runs", w_lin_runs)
def _():
    # TRUE, RUNS: u := *; ?u·D = d with the constant D > 0.
    return T("vac-lin", And(D > 0, x == 0), loop(seq(havoc(u), test(u * D == d)), invariant=x == 0), x == 0)


def w_lin_blocks():
    # BLOCKS: D = 0, d = 1 satisfy the assumptions and u·0 = 1 has no solution.
    check(all(uu * 0 != 1 for uu in (Q(0), Q(1), Q(-7, 3))))


@case("vac-linear-witness-zero-slope-blocks", "blocks", w_lin_blocks)
def _():
    # TRUE, BLOCKS: D >= 0 allows D = 0 with d = 1.
    return T("vac-lin0", And(D >= 0, x == 0), loop(seq(havoc(u), test(u * D == d)), invariant=x == 0), x == 0)


def w_swap_blocks():
    # BLOCKS: p + q = 1 and p + q = 2 cannot both hold, for any p, q.
    check(Q(1) != Q(2))


@case("vac-two-havocs-inconsistent-blocks", "blocks", w_swap_blocks)
def _():
    # TRUE, BLOCKS: p := *; q := *; ?p + q = 1; ?p + q = 2 never runs.
    return T(
        "vac-pq",
        x == 0,
        loop(seq(havoc(p), havoc(q), test(p + q == 1), test(p + q == 2)), invariant=x == 0),
        x == 0,
    )


@case("vac-two-havocs-product-inconsistent-blocks", "blocks", w_swap_blocks)
def _():
    # TRUE, BLOCKS: p·q = 1 and p·q = 2 cannot both hold.
    return T(
        "vac-pq2",
        x == 0,
        loop(seq(havoc(p), havoc(q), test(p * q == 1), test(p * q == 2)), invariant=x == 0),
        x == 0,
    )


def w_two_eq_runs():
    # RUNS: p = q = 1/2 solves p + q = 1, p - q = 0.
    check(Q(1, 2) + Q(1, 2) == 1 and Q(1, 2) - Q(1, 2) == 0)


@case("vac-two-havocs-consistent-runs", "runs", w_two_eq_runs)
def _():
    # TRUE, RUNS: the linear system has the solution p = q = 1/2.
    return T(
        "vac-pq-ok",
        x == 0,
        loop(seq(havoc(p), havoc(q), test(p + q == 1), test(p - q == 0)), invariant=x == 0),
        x == 0,
    )


def w_sqrt_runs():
    # RUNS: u = √x solves u² = x for x >= 0 (checked in floats on samples).
    import math

    g = rng("vac-sqrt")
    for _ in range(SAMPLES):
        xx = float(rat(g, 0, 100))
        check(abs(math.sqrt(xx) ** 2 - xx) <= 1e-9 * max(1.0, xx))


@case("vac-sqrt-witness-runs", "runs", w_sqrt_runs)
def _():
    # TRUE, RUNS: u := *; ?u² = x with x >= 0 kept by the invariant.
    return T("vac-sqrt", x >= 0, loop(seq(havoc(u), test(u * u == x)), invariant=x >= 0), x >= 0)


@case("vac-sqrt-witness-blocks", "blocks", lambda: check(all(uu * uu != -1 for uu in (Q(0), Q(1), Q(-1)))))
def _():
    # TRUE, BLOCKS: from x = -1 (allowed), u² = -1 has no real solution (u² >= 0).
    return T("vac-sqrt0", y == 0, loop(seq(havoc(u), test(u * u == x)), invariant=y == 0), y == 0)


@case("vac-reciprocal-witness-runs", "runs", w_lin_runs)
def _():
    # TRUE, RUNS: u := *; ?u·x = 1 with x > 0 (u = 1/x).
    return T("vac-recip", x > 0, loop(seq(havoc(u), test(u * x == 1)), invariant=x > 0), x > 0)


@case("vac-reciprocal-witness-blocks", "blocks", w_lin_blocks)
def _():
    # TRUE, BLOCKS: x = 0 is allowed and u·0 = 1 has no solution.
    return T("vac-recip0", x >= 0, loop(seq(havoc(u), test(u * x == 1)), invariant=x >= 0), x >= 0)


def w_choice_runs():
    # RUNS: every x satisfies x > 0 or x <= 0.
    g = rng("vac-choice")
    for _ in range(SAMPLES):
        xx = rat(g, -5, 5)
        check(xx > 0 or xx <= 0)


@case("vac-choice-covers-runs", "runs", w_choice_runs)
def _():
    # TRUE, RUNS: the two guards cover every state.
    return T("vac-choice", x == x, loop(choice(test(x > 0), test(x <= 0)), invariant=TRUE), x == x)


@case("vac-test-false-blocks", "blocks", lambda: check(not False and Q(0) == 0))
def _():
    # TRUE, BLOCKS: ?false never runs.
    return T("vac-false", x == 0, loop(test(FALSE), invariant=x == 0), x == 0)


# --------------------------------------------------------------------------- ODEs
def w_ode_blocks():
    # SAFE: every completed step ends inside the domain x <= 5.
    # BLOCKS: x = 0 -> x := 1, flow 4 s -> x = 5 (domain holds on [0, 4]); next step x := 6 and
    # the domain x <= 5 is false at the flow's start: no run.
    xx = Q(0) + 1
    xx = xx + 4
    check(xx == 5)
    check(not (xx + 1 <= 5))


@case("vac-ode-domain-blocks", "blocks", w_ode_blocks)
def _():
    # TRUE, BLOCKS: the jump x := x + 1 can leave the evolution domain.
    return T("vac-ode", x == 0, loop(seq(assign(x, x + 1), ode({x: 1}, x <= 5)), invariant=x <= 5), x <= 5)


def w_ode_runs():
    # RUNS: the flow of duration 0 from t = 0 satisfies t <= 1.
    check(Q(0) <= 1)


@case("vac-ode-clock-runs", "runs", w_ode_runs)
def _():
    # TRUE, RUNS: t := 0 then a clocked flow always has its 0-length run.
    return T(
        "vac-ode-ok", x >= 0, loop(seq(assign(t, 0), ode({x: 1, t: 1}, t <= 1)), invariant=x >= 0), x >= 0
    )


# --------------------------------------------------------------------------- foreach
def w_unmark():
    # BLOCKS: a family with two elements: each iteration clears `done` and marks one element,
    # so after >= 1 iterations exactly one is done, after 0 none: ∀j done(j) never holds.
    for iters in range(0, 6):
        marked = {0: False, 1: False}
        for it in range(iters):
            marked = {0: False, 1: False}
            marked[it % 2] = True
        check(not all(marked.values()))


@case("vac-foreach-unmarks-blocks", "blocks", w_unmark)
def _():
    # TRUE, BLOCKS: a foreach body that resets `done` can never finish on two elements.
    body = seq(havoc(done), test(ForAll(j, Not(done(j)))))
    return T(
        "vac-unmark", x == 0, loop(seq(foreach(i, done, body, TRUE), assign(y, x)), invariant=x == 0), x == 0
    )


def w_foreach_runs():
    # RUNS: visiting each element once in any order finishes.
    g = rng("vac-fe")
    for _ in range(SAMPLES):
        size = rint(g, 1, 8)
        marked = set()
        for e in g.permutation(size):
            marked.add(int(e))
        check(len(marked) == size)


@case("vac-foreach-benign-runs", "runs", w_foreach_runs)
def _():
    # TRUE, RUNS: foreach that zeroes F always finishes.
    inv = ForAll(j, Implies(done(j), F(j) == 0))
    return T(
        "vac-fe",
        x == 0,
        loop(seq(foreach(i, done, assign(F(i), 0), inv), assign(y, x)), invariant=x == 0),
        x == 0,
    )


# --------------------------------------------------------------------------- loops not the whole program
def w_prefix_blocks():
    # BLOCKS: x = 1/2 passes ?x > 0 and reaches the loop, whose body needs x > 1.
    # (The program as a whole also blocks, from x = -1: ?x > 0 fails.)
    check(Q(1, 2) > 0 and not (Q(1, 2) > 1) and not (Q(-1) > 0))


@case("vac-loop-after-prefix-blocks", "blocks", w_prefix_blocks)
def _():
    # TRUE, BLOCKS: a program that is not a loop; its loop body can block.
    return T(
        "vac-prefix",
        x == x,
        seq(test(x > 0), loop(seq(test(x > 1), assign(x, x / 2)), invariant=x > 0)),
        x > 0,
    )


def w_prefix_runs():
    # RUNS: x := 1 always runs, and the loop body x := x + 1 always runs.
    check(True)


@case("vac-loop-after-prefix-runs", "runs", w_prefix_runs)
def _():
    # TRUE, RUNS: a program that is not a loop whose parts always run.
    return T("vac-prefix-ok", x == x, seq(assign(x, 1), loop(assign(x, x + 1), invariant=x >= 1)), x >= 1)


def w_for_blocks():
    # BLOCKS: n >= 1, so the body runs at least once, and 2m = 1 has no integer solution.
    check(no_int(lambda v: 2 * v == 1))


@case("vac-for-range-blocking-body-blocks", "blocks", w_for_blocks)
def _():
    # TRUE, BLOCKS: for_range whose body needs an odd 2m.
    return T(
        "vac-for",
        And(n >= 1, x == 0),
        for_range(k, 0, n, seq(havoc(m), test(2 * m == 1)), invariant=x == 0),
        x == 0,
    )


def w_inner_loop_blocks():
    # SAFE (vacuously after the test); BLOCKS: the inner loop keeps x >= 0, then ?x < 0 fails.
    g = rng("vac-inner")
    for _ in range(SAMPLES):
        xx = rat(g, 0, 5) + rint(g, 0, 5)
        check(not (xx < 0))


@case("vac-inner-plain-loop-blocks", "blocks", w_inner_loop_blocks)
def _():
    # TRUE, BLOCKS: the step contains a plain (non-foreach) loop and then a test that always fails.
    inner = loop(assign(x, x + 1), invariant=x >= 0, label="inner")
    return T("vac-inner", x >= 0, loop(seq(inner, test(x < 0)), invariant=x >= 0), x >= 0)


def w_inner_choice_runs():
    # RUNS: the branch x := x + 2 always runs.
    check(True)


@case("vac-inner-loop-in-choice-runs", "runs", w_inner_choice_runs)
def _():
    # TRUE, RUNS: a step whose choice contains a loop (the other branch always runs).
    inner = loop(assign(x, x + 1), invariant=x >= 0, label="inner")
    return T("vac-inner-ch", x >= 0, loop(choice(inner, assign(x, x + 2)), invariant=x >= 0), x >= 0)


def w_indep_runs():
    # RUNS: p := 1, q := 2.
    check(True)


@case("vac-two-havocs-independent-runs", "runs", w_indep_runs)
def _():
    # TRUE, RUNS: two independent equations.
    return T(
        "vac-indep",
        x == 0,
        loop(seq(havoc(p), havoc(q), test(p == 1), test(q == 2)), invariant=x == 0),
        x == 0,
    )


def w_counter_int_runs():
    # RUNS: cnt := cnt + 1 always runs; SAFE: cnt >= 0 grows.
    check(True)


@case("vac-int-counter-runs", "runs", w_counter_int_runs)
def _():
    # TRUE, RUNS: a plain integer counter.
    return T("vac-cnt", cnt >= 0, loop(assign(cnt, cnt + 1), invariant=cnt >= 0), cnt >= 0)


@case("vac-unsafe-counter-false", "runs", lambda: check(not (Q(2) <= 1)), truth="false")
def _():
    # FALSE (safety), RUNS: two increments from 0 give x = 2 > 1; the step x := x + 1 always runs.
    return T("vac-unsafe", x == 0, loop(assign(x, x + 1), invariant=x >= 0), x <= 1)


def w_unsafe_blocking():
    # FALSE (safety): x = 0, one step with u = 5 (5·1 = 5 = d... here d := 5 fixed): x := u = 5 > 1.
    # BLOCKS: D = 0 with d = 5 allowed: u·0 = 5 has no solution.
    check(Q(5) * 1 == 5 and not (Q(5) <= 1) and all(uu * 0 != 5 for uu in (Q(0), Q(3))))


@case("vac-unsafe-and-blocking-false", "blocks", w_unsafe_blocking, truth="false")
def _():
    # FALSE (safety): D = 1, d = 5 gives u = 5 and x := 5 > 1; BLOCKS for D = 0.
    return T(
        "vac-unsafe-b",
        And(x == 0, D >= 0, d == 5),
        loop(seq(havoc(u), test(u * D == d), assign(x, u))),
        x <= 1,
    )
