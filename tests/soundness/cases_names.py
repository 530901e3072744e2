"""Theme 5: user names that look like the engine's own (SSA versions x@1, lowered array reads
F[i], a foreach's bound i_, z3/sympy/SMT-LIB specials, names that print like terms).

Labels follow the theorem read with every name as an opaque symbol. Refusing such a name
is an acceptable answer (may_reject); a wrong verdict is not."""

from __future__ import annotations

from certiloop.models import (
    BOOL,
    INT,
    And,
    Array,
    Exists,
    Family,
    ForAll,
    Implies,
    IndexSort,
    Int,
    Not,
    Real,
    Reals,
    Theorem,
    Var,
    assign,
    foreach,
    havoc,
    ode,
    seq,
    skip,
)

from .harness import SAMPLES, Case, Q, check, randomized, rat, rint, rng

CASES: list[Case] = []


def case(id, truth, witness, may_reject=True, **kw):
    def deco(build):
        CASES.append(Case(id, build, truth, witness, may_reject=may_reject, **kw))
        return build

    return deco


def T(name, assumptions, program, guarantee, **kw):
    return Theorem(name=name, assumptions=assumptions, program=program, guarantee=guarantee, **kw)


x, y = Reals("x y")
B = IndexSort("B")
i, j = Var("i", B), Var("j", B)
F = Family("F", B)


def arith(cond):
    def w():
        check(cond)

    return w


# --------------------------------------------------------------------------- SSA-looking names
@case(
    "name-ssa-like-x@1-true",
    "true",
    randomized("ssa-like", lambda g: (Q(2), rat(g, -9, 9)), lambda s: s[0] == 2),
)
def _():
    # TRUE: the user's `x@1` is untouched by x := * (whatever the engine calls its fresh x).
    x1 = Real("x@1")
    return T("ssa-like", x1 == 2, havoc(x), x1 == 2)


@case("name-ssa-like-x@1-false", "false", arith(Q(2) != 3))
def _():
    # FALSE: x@1 = 2 stays 2, not 3.
    x1 = Real("x@1")
    return T("ssa-like-f", x1 == 2, seq(havoc(x), assign(x, 3)), x1 == x)


def w_bound_at():
    # TRUE: for every z > 0, x + z > x (x is whatever was chosen).
    g = rng("bound-at")
    for _ in range(SAMPLES):
        xx, zz = rat(g, -10, 10), rat(g, Q(1, 64), 10)
        check(xx + zz > xx)


@case("name-bound-x@1-after-havoc-true", "true", w_bound_at)
def _():
    # TRUE: ∀ x@1 > 0. x + x@1 > x, where the program havocs x (bound name = an SSA-style name).
    x1 = Real("x@1")
    return T("bound-at", x == 0, havoc(x), ForAll(x1, Implies(x1 > 0, x + x1 > x)))


@case("name-bound-x@1-after-havoc-false", "false", arith(not (Q(-1) >= 0)))
def _():
    # FALSE: ∀ x@1. x@1 >= x fails at x@1 = x - 1.
    x1 = Real("x@1")
    return T("bound-at-f", x == 0, havoc(x), ForAll(x1, x1 >= x))


def w_sflow():
    # TRUE: ∃s (x < s < 3) is x < 3; from 0 at rate 1, x stays < 3 (x <= 3 claimed).
    g = rng("sflow")
    for _ in range(SAMPLES):
        tau = rat(g, 0, 3, den=512)
        if tau < 3:
            check(tau <= 3)


@case("name-bound-s@flow-in-domain-true", "true", w_sflow)
def _():
    # TRUE: domain ∃ s@flow (x < s@flow < 3), i.e. x < 3; the bound name mimics the flow time.
    s = Real("s@flow")
    return T("sflow", x == 0, ode({x: 1}, Exists(s, And(x < s, s < 3))), x <= 3)


@case("name-bound-s@flow-in-domain-false", "false", arith(Q(5, 2) < 3 and not (Q(5, 2) < 2)))
def _():
    # FALSE: x reaches 5/2 (domain x < 3 holds on [0, 5/2]), not < 2.
    s = Real("s@flow")
    return T("sflow-f", x == 0, ode({x: 1}, Exists(s, And(x < s, s < 3))), x < 2)


# --------------------------------------------------------------------------- lowered-read names
@case("name-F[i]-collides-with-read-false", "false", arith(Q(2) != 1))
def _():
    # FALSE: the real symbol named `F[i]` is 2 while the family read F(i) is 1.
    Fi = Real("F[i]")
    return T("Fi", And(F(i) == 1, Fi == 2), skip(), Fi == 1)


@case("name-F[i]-shifted-false", "false", arith(not (Q(0) > 100)))
def _():
    # FALSE: F(i) = F[i] + 1 is satisfiable (F[i] = 0, F(i) = 1) and F[i] > 100 fails.
    Fi = Real("F[i]")
    return T("Fi2", F(i) == Fi + 1, skip(), Fi > 100)


@case("name-F[i]-read-true", "true", arith(Q(1) == 1))
def _():
    # TRUE: F(i) = 1 stays 1 (the real `F[i]` is just another symbol).
    Fi = Real("F[i]")
    return T("Fi3", And(F(i) == 1, Fi == 2), skip(), And(F(i) == 1, Fi == 2))


@case("name-prints-like-index-term-false", "false", arith(Q(2) != 1))
def _():
    # FALSE: A[k + 1] (cell 1) and A[K] with an Int named "k + 1" = 5 (cell 5) are different cells.
    k, K = Int("k"), Int("k + 1")
    A = Array("A", INT)
    return T("kplus1", And(k == 0, K == 5, A[k + 1] == 1, A[K] == 2), skip(), A[K] == 1)


@case("name-universe-like-symbol-false", "false", arith(Q(1, 2) > 0 and not (Q(1, 2) > 1)))
def _():
    # FALSE: F(j) = 1/2 for all j satisfies the assumptions; F(i) > 1 fails. A real symbol
    # is named like the model's universe key.
    U = Real("#universe:B")
    return T("universe", And(i == i, ForAll(j, F(j) > 0), U == 1), skip(), F(i) > 1)


# --------------------------------------------------------------------------- foreach's bound name
done = Family("done", B, BOOL)
mark = Family("mark", B)
i_ = Var("i_", B)


def w_foreach_capture():
    # TRUE: simulate foreach over random finite sets in random orders, visiting exactly the
    # elements e != i_ (the documented meaning of `where`), each marked 1.
    g = rng("foreach-capture")
    for _ in range(SAMPLES):
        size = rint(g, 1, 6)
        elems = list(range(size))
        user_i_ = rint(g, 0, size - 1)
        mk = {e: rat(g, -3, 3) for e in elems}
        for e in g.permutation([e for e in elems if e != user_i_]):
            mk[int(e)] = 1
        check(all(mk[e] == 1 for e in elems if e != user_i_))


@case("name-foreach-where-mentions-i_-true", "true", w_foreach_capture)
def _():
    # TRUE: foreach over the elements other than the user's i_ marks them all.
    return T(
        "capture",
        i_ == i_,
        foreach(
            i,
            done,
            assign(mark(i), 1),
            ForAll(j, Implies(done(j), mark(j) == 1)),
            where=lambda e: Not(e == i_),
        ),
        ForAll(j, Implies(Not(j == i_), mark(j) == 1)),
    )


def w_foreach_capture_false():
    # FALSE: a one-element family {e} with i_ = e: nothing is visited, mark(e) keeps 0 != 1.
    check(Q(0) != 1)


@case("name-foreach-where-mentions-i_-false", "false", w_foreach_capture_false)
def _():
    # FALSE: the user's i_ itself is never visited, so mark(i_) may keep its old value.
    return T(
        "capture-f",
        And(i_ == i_, mark(i_) == 0),
        foreach(
            i,
            done,
            assign(mark(i), 1),
            ForAll(j, Implies(done(j), mark(j) == 1)),
            where=lambda e: Not(e == i_),
        ),
        mark(i_) == 1,
    )


# --------------------------------------------------------------------------- specials
@case("name-smt-keywords-true", "true", arith(Q(1) + 2 == 3))
def _():
    # TRUE: symbols named `and`, `or`, `true`, `=>`: and + or = 3, true = 0.
    a, o, tr, imp = Real("and"), Real("or"), Real("true"), Real("=>")
    return T("smt-kw", And(a == 1, o == 2, tr == 0, imp == tr), skip(), And(a + o == 3, imp <= 0))


@case("name-smt-keywords-false", "false", arith(Q(0) != 1))
def _():
    # FALSE: the real symbol `true` is 0, not 1.
    tr, nt = Real("true"), Real("not")
    return T("smt-kw-f", And(tr == 0, nt == 1), skip(), tr == nt)


def w_sympy_specials():
    # TRUE: E' = I = 2 from 0 gives E = 2s >= 0; pi' = 0 keeps pi = 3.
    g = rng("sympy-specials")
    for _ in range(SAMPLES):
        s = rat(g, 0, 10)
        check(2 * s >= 0)


@case("name-sympy-specials-ode-true", "true", w_sympy_specials)
def _():
    # TRUE: symbols named I, E, pi, oo (sympy constants) in an ODE are plain reals here.
    imag, E, pi, oo = Real("I"), Real("E"), Real("pi"), Real("oo")
    return T(
        "sympy-sp", And(imag == 2, E == 0, pi == 3, oo == 1), ode({E: imag * oo, pi: 0}), And(E >= 0, pi == 3)
    )


@case("name-sympy-specials-ode-false", "false", arith(2 * Q(3) > 5))
def _():
    # FALSE: E = 2t exceeds 5 at t = 3.
    imag, E = Real("I"), Real("E")
    return T("sympy-sp-f", And(imag == 2, E == 0), ode({E: imag}), E <= 5)


@case("name-digits-as-symbols-true", "true", arith(Q(2) + 1 == 3))
def _():
    # TRUE: a real symbol named "1" equal to 2: "1" + 1 = 3.
    one = Real("1")
    return T("digits", one == 2, skip(), one + 1 == 3)


@case("name-digits-as-symbols-false", "false", arith(Q(2) != 1))
def _():
    # FALSE: the symbol named "1" is 2, so it is not equal to the number 1.
    one = Real("1")
    return T("digits-f", one == 2, skip(), one == 1)


@case("name-prime-and-pipe-true", "true", randomized("prime", lambda g: 3 * rat(g, 0, 2), lambda xx: xx <= 6))
def _():
    # TRUE: symbols named x' and a|b: x grows at rate x' = 3 for t <= 2.
    xp, ab, t = Real("x'"), Real("a|b"), Real("t")
    return T("prime", And(xp == 3, ab == 0, x == 0, t == 0), ode({x: xp, t: 1}, t <= 2), x <= 6 + ab)


@case("name-prime-and-pipe-false", "false", arith(Q(3) * 2 > 5))
def _():
    # FALSE: x reaches 6 > 5.
    xp, ab, t = Real("x'"), Real("a|b"), Real("t")
    return T("prime-f", And(xp == 3, ab == 0, x == 0, t == 0), ode({x: xp, t: 1}, t <= 2), x <= 5 + ab)


@case("name-family-and-real-same-name-ill", "ill-formed", None)
def _():
    # ILL-FORMED: `G` is both a family and a real.
    G, Gr = Family("G", B), Real("G")
    return T("fam-real", And(G(i) == 1, Gr == 2), skip(), G(i) == 1)


@case("name-empty-ill", "ill-formed", None)
def _():
    # ILL-FORMED: a symbol needs a name.
    e = Real("")
    return T("empty", e == 0, skip(), e == 0)


@case(
    "name-like-tau-and-skolem-true",
    "true",
    randomized("tau-like", lambda g: 1 * rat(g, 0, 20), lambda xx: xx >= 0),
)
def _():
    # TRUE: symbols named like an integration variable and a skolem constant stay themselves.
    tau, sk = Real("tau_int"), Real("j_sk1")
    return T("tau-like", And(tau == 1, sk == tau, x == 0), ode({x: tau}), And(x >= 0, sk == 1))


@case(
    "name-index-sort-named-Array-true",
    "true",
    randomized(
        "sort-array",
        lambda g: (lambda n_: ({e: 1 for e in range(n_)}, rint(g, 0, n_ - 1)))(rint(g, 1, 6)),
        lambda s: s[0][s[1]] == 1,
    ),
)
def _():
    # TRUE: an index sort called "Array" is just a sort: H(e) = 1 for all e -> H(e0) = 1.
    S = IndexSort("Array")
    e0, e1 = Var("e0", S), Var("e1", S)
    H = Family("H", S)
    return T("sort-array", And(e0 == e0, ForAll(e1, H(e1) == 1)), skip(), H(e0) == 1)


@case("name-z3-element-like-false", "false", arith(Q(1, 2) > 0 and not (Q(1, 2) > 1)))
def _():
    # FALSE: F(j) = 1/2 everywhere satisfies ∀j F(j) > 0; F(i) > 1 fails. Real symbols are named
    # like z3's names for elements of B (B!val!0) and its fresh constants (B!1).
    v0, b1 = Real("B!val!0"), Real("B!1")
    return T("z3-like", And(i == i, ForAll(j, F(j) > 0), v0 == 5, b1 == 6), skip(), F(i) > 1)
