"""Theme 4: sorts — Int, Real and Bool mixed; Int symbols in ODEs; one name with two sorts;
integer facts a real-arithmetic reading would get wrong."""

from __future__ import annotations

from certiloop.models import (
    And,
    Bool,
    Exists,
    ForAll,
    Implies,
    Int,
    Ints,
    Not,
    Or,
    Real,
    Reals,
    Theorem,
    assign,
    havoc,
    loop,
    ode,
    seq,
    skip,
    test,
)

from .harness import SAMPLES, Case, Q, check, rat, rint, rng

CASES: list[Case] = []


def case(id, truth, witness, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


x, y, z = Reals("x y z")
n, k, j = Ints("n k j")
flag = Bool("flag")


def no_int_strictly_between(lo, hi):
    """Witness helper: no integer lies strictly between lo and hi (checked on a wide range)."""

    def w():
        check(not any(lo < i < hi for i in range(-1000, 1001)))

    return w


# --------------------------------------------------------------------------- integer facts
@case("sort-int-strictly-between-0-1-true", "true", no_int_strictly_between(0, 1))
def _():
    # TRUE (vacuous): no integer n has 0 < n < 1, so the assumptions are unsatisfiable.
    return T("int-01", And(0 < n, n < 1, x == 0), skip(), x == 1)


def w_odd():
    # TRUE: 2n = 1 has no integer solution (2n is even).
    check(all(2 * i != 1 for i in range(-1000, 1001)))


@case("sort-int-2n-eq-1-true", "true", w_odd)
def _():
    # TRUE (vacuous): 2n = 1 is impossible over the integers.
    return T("int-2n1", And(2 * n == 1, x == 0), skip(), x == 1)


def w_sqrt2_int():
    # TRUE: n² = 2 has no integer solution (1² = 1, 2² = 4), so the test never passes.
    check(all(i * i != 2 for i in range(-1000, 1001)))


@case("sort-int-havoc-square-2-true", "true", w_sqrt2_int)
def _():
    # TRUE: n := *; ?n*n = 2 has no run.
    return T("int-sq2", x == 0, seq(havoc(n), test(n * n == 2)), n == 5)


def w_int_ge1():
    # TRUE: an integer n > 0 is >= 1.
    check(all(i >= 1 for i in range(-1000, 1001) if i > 0))


@case("sort-int-positive-is-ge-1-true", "true", w_int_ge1)
def _():
    # TRUE: n > 0 -> n >= 1 over the integers.
    return T("int-ge1", n > 0, skip(), n >= 1)


def w_real_ge1_false():
    # FALSE: x = 1/2 > 0 but not >= 1 (x is real).
    check(Q(1, 2) > 0 and not (Q(1, 2) >= 1))


@case("sort-real-positive-is-ge-1-false", "false", w_real_ge1_false)
def _():
    # FALSE: the same claim for a real x.
    return T("real-ge1", x > 0, skip(), x >= 1)


def w_half():
    # TRUE: y = n + 1/2 is never 0 for integer n.
    check(all(i + Q(1, 2) != 0 for i in range(-1000, 1001)))


@case("sort-int-plus-half-nonzero-true", "true", w_half)
def _():
    # TRUE: y = n + 1/2 != 0 since n is an integer.
    return T("int-half", y == n + Q(1, 2), skip(), y != 0)


def w_half_false():
    # FALSE: n = 0 gives y = 1/2.
    check(0 + Q(1, 2) == Q(1, 2))


@case("sort-int-plus-half-false", "false", w_half_false)
def _():
    # FALSE: n = 0 makes y = 1/2.
    return T("int-half-f", y == n + Q(1, 2), skip(), y != Q(1, 2))


def w_mixed_eq():
    # TRUE: an integer never equals 1/2.
    check(all(Q(i) != Q(1, 2) for i in range(-1000, 1001)))


@case("sort-int-equals-real-half-true", "true", w_mixed_eq)
def _():
    # TRUE (vacuous): n = y with y = 1/2 is impossible.
    return T("int-eq-real", And(y == Q(1, 2), n == y, x == 0), skip(), x == x + 1)


def w_havoc_int_gt_half():
    # TRUE: an integer > 1/2 is >= 1.
    check(all(i >= 1 for i in range(-1000, 1001) if i > Q(1, 2)))


@case("sort-havoc-int-test-gt-half-true", "true", w_havoc_int_gt_half)
def _():
    # TRUE: n := *; ?n > 1/2 leaves n >= 1.
    return T("int-havoc", x == 0, seq(havoc(n), test(n > Q(1, 2))), n >= 1)


def w_even_step():
    # TRUE: from n = 0, adding 2 keeps n even, and 3 is odd.
    g = rng("int-even")
    for _ in range(SAMPLES):
        nn = 2 * rint(g, 0, 500)
        check(nn != 3 and nn % 2 == 0)


@case("sort-int-loop-parity-true", "true", w_even_step)
def _():
    # TRUE: n only takes even values, never 3 (invariant: ∃j. n = 2j over the integers).
    return T("int-parity", n == 0, loop(assign(n, n + 2), invariant=Exists(j, n == 2 * j)), n != 3)


def w_odd_step_false():
    # FALSE: from n = 1, two iterations give n = 5.
    check(1 + 2 + 2 == 5)


@case("sort-int-loop-parity-false", "false", w_odd_step_false)
def _():
    # FALSE: n = 1, 3, 5, ...: two iterations reach 5.
    return T("int-parity-f", n == 1, loop(assign(n, n + 2)), n != 5)


def w_int_rhs():
    # TRUE: x' = n (Int constant) from 0: x = n s; with n >= 1, x >= s = t.
    g = rng("int-rhs")
    for _ in range(SAMPLES):
        nn, s = rint(g, 1, 20), rat(g, 0, 10)
        check(nn * s >= s)


@case("sort-int-constant-in-ode-rhs-true", "true", w_int_rhs)
def _():
    # TRUE: an Int constant in a right-hand side is fine.
    return T("int-rhs", And(n >= 1, x == 0, y == 0), ode({x: n, y: 1}), x >= y)


# --------------------------------------------------------------------------- ill-formed
def w_int_ode_ill():
    # ILL-FORMED: x' = 1 would make the Int x take the value 1/2 at t = 1/2.
    check(0 + Q(1, 2) != int(0 + Q(1, 2)))


@case("sort-int-ode-state-poly-ill", "ill-formed", w_int_ode_ill)
def _():
    # ILL-FORMED: an Int symbol as an ODE state.
    xi = Int("xi")
    return T("int-ode", xi == 0, ode({xi: 1}), 2 * xi != 1)


@case("sort-int-ode-state-nonpoly-ill", "ill-formed", w_int_ode_ill)
def _():
    # ILL-FORMED: an Int symbol as the state of x' = x (no polynomial solution).
    xi = Int("xi")
    return T("int-ode2", xi == 1, ode({xi: xi}), 2 * xi != 3)


@case("sort-int-ode-state-dI-ill", "ill-formed", w_int_ode_ill)
def _():
    # ILL-FORMED: an Int ODE state with a dI annotation.
    xi = Int("xi")
    return T("int-ode3", xi == 0, ode({xi: 1}, invariants=[xi >= 0]), 2 * xi != 1)


@case("sort-bool-ode-state-ill", "ill-formed", None)
def _():
    # ILL-FORMED: a Bool symbol cannot evolve continuously.
    return T("bool-ode", x == 0, ode({flag: 1, x: 1}), x >= 0)


@case("sort-name-two-sorts-across-parts-ill", "ill-formed", None)
def _():
    # ILL-FORMED: `x` is Real in the assumptions and Int in the guarantee.
    return T("two-sorts", Real("x") > 0, skip(), Int("x") >= 0)


@case("sort-name-two-sorts-in-assumptions-ill", "ill-formed", None)
def _():
    # ILL-FORMED: `x` is Real and Int inside the assumptions alone (0 < x < 1 both ways).
    return T("two-sorts-asm", And(Real("x") > 0, Int("x") < 1, y == 0), skip(), Real("x") > Q(1, 2))


@case("sort-name-two-sorts-in-program-ill", "ill-formed", None)
def _():
    # ILL-FORMED: the program writes Real `q` and tests Int `q`.
    return T("two-sorts-prog", y == 0, seq(assign(Real("q"), Q(1, 2)), test(Int("q") >= 0)), y == 0)


@case("sort-name-real-and-bool-ill", "ill-formed", None)
def _():
    # ILL-FORMED: `p` is a Real and a Bool.
    return T("real-bool", And(Real("p") > 0, y == 0), test(Bool("p")), y == 0)


@case("sort-name-int-and-bool-in-guarantee-ill", "ill-formed", None)
def _():
    # ILL-FORMED: `u` is an Int (program, guarantee) and a Bool (guarantee).
    return T("int-bool", y == 0, test(Int("u") >= 0), Or(Int("u") > 0, Bool("u"), y == 0))


@case("sort-assign-real-to-int-ill", "ill-formed", None)
def _():
    # ILL-FORMED: an Int symbol cannot take a real value.
    return T("int-assign", x == 1, assign(n, x / 2), n >= 0)


@case("sort-int-index-into-family-ill", "ill-formed", None)
def _():
    # ILL-FORMED: a family over an index sort read at an Int.
    from certiloop.models import Family, IndexSort

    B = IndexSort("B")
    F = Family("F", B)
    return T("int-index", n == 0, skip(), F(n) >= 0)


# --------------------------------------------------------------------------- Bool symbols
def w_bool_flag():
    # TRUE: flag := (x > 0); ?flag leaves x > 0.
    g = rng("bool-flag")
    for _ in range(SAMPLES):
        xx = rat(g, -5, 5)
        if xx > 0:
            check(xx > 0)


@case("sort-bool-assigned-formula-true", "true", w_bool_flag)
def _():
    # TRUE: a Bool set from a comparison and then tested.
    return T("bool-flag", x == x, seq(assign(flag, x > 0), test(flag)), x > 0)


def w_bool_flag_false():
    # FALSE: x = 0: flag := false, the else branch runs, x = 0 is not > 0.
    check(not (Q(0) > 0))


@case("sort-bool-negated-flag-false", "false", w_bool_flag_false)
def _():
    # FALSE: testing ¬flag leaves x <= 0.
    return T("bool-flag-f", x == x, seq(assign(flag, x > 0), test(Not(flag))), x > 0)


def w_bound_int_shadow():
    # TRUE: every integer u satisfies u <= 0 or u >= 1 (the free real x = 1/2 is another symbol).
    check(all(i <= 0 or i >= 1 for i in range(-1000, 1001)))


@case("sort-bound-int-shadows-free-real-true", "true", w_bound_int_shadow, may_reject=True)
def _():
    # TRUE: ∀ Int x (x <= 0 ∨ x >= 1), while the free Real x is 1/2.
    xi = Int("x")
    return T("int-shadow", x == Q(1, 2), skip(), And(x == Q(1, 2), ForAll(xi, Or(xi <= 0, xi >= 1))))


def w_bound_real_false():
    # FALSE: the bound real u = 1/2 is neither <= 0 nor >= 1.
    check(not (Q(1, 2) <= 0 or Q(1, 2) >= 1))


@case("sort-bound-real-shadows-free-int-false", "false", w_bound_real_false, may_reject=True)
def _():
    # FALSE: ∀ Real n (n <= 0 ∨ n >= 1) fails at 1/2, even though the free n is an Int.
    nr = Real("n")
    return T("real-shadow", n == 0, skip(), ForAll(nr, Or(nr <= 0, nr >= 1)))


def w_int_square_ge():
    # TRUE: for integers, n² >= n (n <= 0 or n >= 1).
    check(all(i * i >= i for i in range(-1000, 1001)))


@case("sort-int-square-ge-self-true", "true", w_int_square_ge)
def _():
    # TRUE over the integers (false over the reals at 1/2).
    return T("int-sq", n == n, skip(), n * n >= n)


def w_real_square_false():
    # FALSE: x = 1/2: 1/4 < 1/2.
    check(Q(1, 4) < Q(1, 2))


@case("sort-real-square-ge-self-false", "false", w_real_square_false)
def _():
    # FALSE for a real x = 1/2.
    return T("real-sq", x == x, skip(), x * x >= x)


def w_implies_int():
    # TRUE: k > n and k < n + 1 cannot both hold for integers.
    check(all(not (n_ < kk < n_ + 1) for n_ in range(-30, 31) for kk in range(-40, 41)))


@case("sort-int-no-gap-between-consecutive-true", "true", w_implies_int)
def _():
    # TRUE: no integer lies strictly between n and n + 1.
    return T("int-gap", n == n, skip(), ForAll(k, Implies(k > n, k >= n + 1)))
