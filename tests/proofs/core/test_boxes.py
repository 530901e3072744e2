"""boxes.proves (exact interval arithmetic over a box, no solver) against independent witnesses.

A wrong True from `boxes.proves` makes certiloop report `proved` for a false claim, so every
test here checks the one direction that matters, against witnesses that do not share its code:

* z3 (`check_valid`): whenever boxes proves a claim, z3 must not find a counterexample;
* exact evaluation (`exact.evaluate`, Fractions) at rational points built inside the
  hypotheses' region *by construction*, boundary points included (inverse stereographic
  projection gives rational points exactly on a sphere): a proved claim holds at each;
* claims false by construction (the goal fails at a chosen point of the region): never proved.

The near-miss cases (min exactly on the boundary, strict against non-strict, a single bad
point, unbounded or non-ellipsoid hypotheses, opaque terms) each come with an exact
counterexample that the test evaluates first, so the expected `False` is checked, not assumed.
A few valid claims the method should decide are asserted too (with z3 confirming validity),
so that a module that always says False does not pass unnoticed.
"""

from __future__ import annotations

import random
from fractions import Fraction as F
from itertools import product

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models.lang.terms import (
    FALSE,
    INT,
    And,
    Array,
    Bool,
    ForAll,
    Iff,
    Implies,
    Ints,
    Node,
    Not,
    Or,
    Real,
    Reals,
    const,
)
from certiloop.proofs.core import boxes
from certiloop.proofs.core.exact import evaluate
from certiloop.proofs.core.solver import check_valid

RLIMIT = 5_000_000  # generous: z3 decides these small claims in far less
Z3_WALL_S = 1.0  # the random claims' z3 witness only: see check_proved_claim_is_valid
x, y, z, w = Reals("x y z w")
i, j = Ints("i j")
NAMES = ("x0", "x1", "x2", "x3")


def z3_status(f: Node) -> str:
    return check_valid(f, RLIMIT).status


def truth(f: Node, point: dict) -> bool:
    """The formula's exact truth value at a point (all values Fractions, or ints for Int symbols)."""
    v = evaluate(f, point)
    assert isinstance(v, bool), f"exact evaluation of `{f}` at {point} gave {v!r}"
    return v


def assert_not_proved_false_claim(f: Node, counterexample: dict) -> None:
    """The claim is false (checked exactly at the counterexample), so boxes must not prove it."""
    assert truth(f, counterexample) is False, "the test's counterexample is wrong"
    assert boxes.proves(f) is False, f"boxes.proves returned True for the false claim `{f}`"


# --------------------------------------------------------------------------- random regions


class Draw:
    """One interface over hypothesis' `data.draw` and a seeded `random.Random`."""

    def __init__(self, data=None, rnd: random.Random | None = None) -> None:
        self.data, self.rnd = data, rnd

    def int(self, lo: int, hi: int) -> int:
        if self.data is not None:
            return self.data.draw(st.integers(lo, hi))
        return self.rnd.randint(lo, hi)

    def pick(self, seq):
        return seq[self.int(0, len(seq) - 1)]

    def frac(self, lo: int, hi: int, dens=(1, 2, 3, 4, 7, 10)) -> F:
        return F(self.int(lo, hi), self.pick(dens))


def sphere_point(d: Draw, n: int) -> list[F]:
    """A rational point exactly on the unit sphere in n dimensions (inverse stereographic projection)."""
    if n == 1:
        return [F(d.pick((-1, 1)))]
    u = [d.frac(-6, 6, (1, 2, 3, 5)) for _ in range(n - 1)]
    s = sum(c * c for c in u)
    return [2 * c / (s + 1) for c in u] + [(s - 1) / (s + 1)]


def ball_point(d: Draw, n: int) -> list[F]:
    """A rational point of the closed unit ball (a sphere point scaled by a factor in [0, 1])."""
    t = F(d.int(0, 16), 16)
    return [t * c for c in sphere_point(d, n)]


class Region:
    """Hypotheses (a list of formulas) about `vs`, and rational points inside them by construction.

    kind: `ball` sum (x_i - c_i)^2 <= rho^2; `ellipsoid` sum m_i^2 (x_i - c_i)^2 <= rho^2 (the
    weights are squares so boundary points stay rational); `box` lo_i <= x_i <= hi_i (lo == hi
    allowed); `ballbox` a ball cut by a box that contains its centre."""

    def __init__(self, d: Draw, n: int) -> None:
        self.vs = [Real(nm) for nm in NAMES[:n]]
        self.n = n
        self.kind = d.pick(("ball", "ellipsoid", "box", "ballbox"))
        self.strict = False
        self.hyps: list[Node] = []
        self.c = [d.frac(-5, 5) for _ in range(n)]
        if self.kind != "box":
            self.rho = d.pick((F(1, 1000), F(1, 10), F(1, 2), F(1), F(3), F(20)))
            weights = (F(1, 2), F(1), F(2), F(3))
            self.m = [F(1)] * n if self.kind != "ellipsoid" else [d.pick(weights) for _ in range(n)]
            self.strict = d.int(0, 4) == 0
            self.hyps.append(self._ellipsoid_formula(d))
        if self.kind in ("box", "ballbox"):
            self.lo, self.hi = [], []
            for k in range(n):
                if self.kind == "box":
                    lo = d.frac(-5, 5)
                    hi = lo + d.pick((F(0), F(1, 100), F(1, 2), F(1), F(4)))
                else:
                    lo = self.c[k] - d.pick((F(1, 10), F(1, 2), F(10))) * self.rho
                    hi = self.c[k] + d.pick((F(1, 10), F(1, 2), F(10))) * self.rho
                self.lo.append(lo)
                self.hi.append(hi)
                v = self.vs[k]
                if lo == hi and d.int(0, 1):
                    self.hyps.append(v == lo)
                else:
                    self.hyps.extend((v >= lo, hi >= v) if d.int(0, 1) else (lo <= v, v <= hi))

    def _ellipsoid_formula(self, d: Draw) -> Node:
        vs, c, m, rho = self.vs, self.c, self.m, self.rho
        form = d.int(0, 2)
        if form == 0:  # factored
            q = sum((m[k] ** 2 * (vs[k] - c[k]) ** 2 for k in range(self.n)), const(0))
        elif form == 1:  # expanded by hand, squares written as products
            q = sum((m[k] ** 2 * (vs[k] * vs[k] - 2 * c[k] * vs[k] + c[k] ** 2) for k in range(self.n)),
                    const(0))
        else:  # through a division by a constant
            q = sum(((m[k] * 2 * (vs[k] - c[k])) ** 2 / 4 for k in range(self.n)), const(0))
        if d.int(0, 1):
            return q < rho**2 if self.strict else q <= rho**2
        return rho**2 - q > 0 if self.strict else rho**2 - q >= 0

    def point(self, d: Draw, boundary: bool = False) -> dict[str, F]:
        """A rational point of the region; on its boundary when asked (and the region is closed)."""
        for _ in range(50):
            if self.kind == "box":
                p = [self.lo[k] + (self.hi[k] - self.lo[k]) * (F(d.pick((0, 1))) if boundary
                                                               else F(d.int(0, 8), 8)) for k in range(self.n)]
            else:
                u = sphere_point(d, self.n) if boundary and not self.strict else ball_point(d, self.n)
                if self.strict:
                    u = [t * F(99, 100) for t in u]
                p = [self.c[k] + u[k] * self.rho / self.m[k] for k in range(self.n)]
            pt = {v.payload: val for v, val in zip(self.vs, p)}
            if all(truth(h, pt) for h in self.hyps):
                return pt
        return {v.payload: cv for v, cv in zip(self.vs, self.c)}  # the centre is in every region here

    def points(self, d: Draw, count: int) -> list[dict[str, F]]:
        pts = [{v.payload: cv for v, cv in zip(self.vs, self.c)}]
        if self.kind in ("box", "ballbox"):
            pts.append({v.payload: (lo + hi) / 2 for v, lo, hi in zip(self.vs, self.lo, self.hi)})
            pts = [p for p in pts if all(truth(h, p) for h in self.hyps)]
        pts += [self.point(d, boundary=k % 2 == 0) for k in range(count)]
        return pts


def random_poly(d: Draw, vs: list[Node], degree: int, coeff_scale: int = 1) -> Node:
    """A polynomial of total degree <= degree with at least one monomial of exactly that degree."""
    out = const(d.frac(-5, 5))
    terms = d.int(1, 4)
    for t in range(terms):
        deg = degree if t == 0 else d.int(1, degree)
        mono = const(d.frac(-9, 9, (1, 2, 3, 7, 10)) * coeff_scale or 1)
        for _ in range(deg):
            mono = mono * d.pick(vs)
        out = out + mono
    if d.int(0, 3) == 0:  # sometimes a factored power
        a, b = d.pick(vs), d.frac(-3, 3)
        out = out + d.frac(-3, 3, (1, 2)) * (a - b) ** d.int(2, 3)
    return out


def goal_for(d: Draw, region: Region, samples: list[dict]) -> Node:
    """A random comparison `q rel t`, with t placed around q's sampled range (true, tight or false)."""
    q = random_poly(d, region.vs, d.int(1, 3))
    vals = [evaluate(q, p) for p in samples]
    hi, lo = max(vals), min(vals)
    delta = d.pick((F(-1), F(-1, 100), F(0), F(0), F(1, 10**6), F(1, 100), F(1, 2), F(3), F(100)))
    rel = d.pick(("<=", "<", ">=", ">", "==", "!=", "not>", "not<"))
    if rel == "<=":
        return q <= hi + delta
    if rel == "<":
        return q < hi + delta
    if rel == ">=":
        return q >= lo - delta
    if rel == ">":
        return q > lo - delta
    if rel == "==":
        return q == d.pick(vals) + (delta if d.int(0, 1) else 0)
    if rel == "!=":
        return q != (hi + delta if d.int(0, 1) else d.pick(vals))
    if rel == "not>":
        return Not(q > hi + delta)
    return Not(q < lo - delta)


def random_goal(d: Draw, region: Region, samples: list[dict]) -> Node:
    g = goal_for(d, region, samples)
    shape = d.int(0, 5)
    if shape == 1:
        return Or(g, goal_for(d, region, samples))
    if shape == 2:
        return And(g, goal_for(d, region, samples))
    if shape == 3:
        return Implies(goal_for(d, region, samples), g)
    if shape == 4:
        return Not(Not(g))
    return g


def assemble(d: Draw, hyps: list[Node], goal: Node) -> Node:
    """hyps -> goal, in one of several equivalent shapes the DNF must read alike."""
    shape = d.int(0, 4)
    if shape == 0:
        return Implies(And(*hyps), goal)
    if shape == 1:
        return Or(Not(And(*hyps)), goal)
    if shape == 2:
        return Not(And(*hyps, Not(goal)))
    if shape == 3:  # curried: H1 -> (H2 -> ... -> G)
        out = goal
        for h in reversed(hyps):
            out = Implies(h, out)
        return out
    return Or(*(Not(h) for h in hyps), goal)


def random_claim(d: Draw):
    region = Region(d, d.int(1, 4))
    samples = region.points(d, 6)
    goal = random_goal(d, region, samples)
    return region, samples, assemble(d, region.hyps, goal)


def check_proved_claim_is_valid(d: Draw, region: Region, samples: list[dict], f: Node) -> None:
    """boxes proved f: f must hold at every point, in the region and outside it, and z3 must not refute it."""
    for p in samples + region.points(d, 12):
        assert truth(f, p), f"boxes proved `{f}`, false at {p}"
    for _ in range(6):  # points anywhere: a valid formula holds there too
        p = {v.payload: d.frac(-40, 40) for v in region.vs}
        assert truth(f, p), f"boxes proved `{f}`, false at {p}"
    # z3 may take tens of seconds on a random cubic in four variables: a wall-clock cap keeps the
    # file fast; an answer cut off is "unknown", which only weakens this witness, never fakes one
    answer = check_valid(f, RLIMIT, wall_s=Z3_WALL_S)
    assert answer.status != "sat", f"boxes proved `{f}`, z3 refutes it: {answer.model}"


# --------------------------------------------------------------------------- 1. property tests


@settings(max_examples=60)
@given(st.data())
def test_a_proved_random_claim_has_no_counterexample(data):
    d = Draw(data=data)
    region, samples, f = random_claim(d)
    if boxes.proves(f):
        check_proved_claim_is_valid(d, region, samples, f)


def test_the_random_claims_exercise_both_answers():
    """The generator above, seeded: boxes proves some claims (each then checked as above) and refuses
    some false ones; a generator whose claims were all false, or all unprovable, would test nothing."""
    d = Draw(rnd=random.Random(20261127))
    proved = refused_false = 0
    for _ in range(30):
        region, samples, f = random_claim(d)
        if boxes.proves(f):
            proved += 1
            check_proved_claim_is_valid(d, region, samples, f)
        elif not all(truth(f, p) for p in samples):
            refused_false += 1
    assert proved >= 5, proved
    assert refused_false >= 5, refused_false


# --------------------------------------------------------------------------- 5. false by construction


def false_goal(d: Draw, region: Region, p: dict) -> Node:
    """A goal that fails at the point p of the region."""
    q = random_poly(d, region.vs, d.int(1, 3))
    q2 = random_poly(d, region.vs, d.int(2, 3))
    qp, q2p = evaluate(q, p), evaluate(q2, p)
    eps = d.pick((F(1, 10**30), F(1, 10**6), F(1, 3)))
    return d.pick((
        q > qp,
        q < qp,
        q != qp,
        Not(q == qp),
        q >= qp + eps,
        q <= qp - eps,
        Or(q > qp, q2 < q2p),
        Or(q > qp, q2 != q2p),
        And(q2 > q2p - 1, q < qp),
        Implies(q2 == q2p, q != qp),
        Implies(q2 >= q2p, q > qp),
        Iff(q > qp, q2 > q2p + 1),  # false or not: Iff is read as `true`, so never proved here
    ))


@settings(max_examples=40)
@given(st.data())
def test_a_claim_false_at_a_point_of_the_region_is_never_proved(data):
    d = Draw(data=data)
    region = Region(d, d.int(1, 4))
    p = region.point(d, boundary=d.int(0, 1) == 1)
    goal = false_goal(d, region, p)
    f = assemble(d, region.hyps, goal)
    if evaluate(goal, p) is not False:
        return  # only the Iff shape can hold at p; it is covered by its own test below
    assert truth(f, p) is False
    assert boxes.proves(f) is False, f"boxes proved `{f}`, false at {p}"


def test_false_by_construction_seeded_sweep():
    """The same construction without hypothesis' shrinking, over many more seeded claims (cheap:
    no z3), with every region kind and the point both inside and on the boundary."""
    d = Draw(rnd=random.Random(7))
    checked = 0
    for _ in range(45):
        region = Region(d, d.int(1, 4))
        p = region.point(d, boundary=d.int(0, 1) == 1)
        goal = false_goal(d, region, p)
        if evaluate(goal, p) is not False:
            continue
        f = assemble(d, region.hyps, goal)
        assert truth(f, p) is False
        assert boxes.proves(f) is False, f"boxes proved `{f}`, false at {p}"
        checked += 1
    assert checked >= 30


# --------------------------------------------------------------------------- 2. adversarial near-misses

ball = (x - 1) ** 2 <= 1  # x in [0, 2]
disc = (x - 3) ** 2 + (y - 1) ** 2 <= 4  # centre (3, 1), radius 2
A = Array("a", INT)

NEAR_MISSES = [
    # the minimum of the goal sits exactly on the boundary: strict goals are false there
    ("strict at boundary", Implies(ball, x > 0), {"x": F(0)}),
    ("strict at far boundary", Implies(ball, x < 2), {"x": F(2)}),
    ("strict square at boundary", Implies(ball, x**2 < 4), {"x": F(2)}),
    ("strict disc edge", Implies(disc, x > 1), {"x": F(1), "y": F(1)}),
    ("strict disc, max of a line at a rational circle point", Implies(disc, 5 * x + 12 * y < 53),
     {"x": F(3) + F(2 * 5, 13), "y": F(1) + F(2 * 12, 13)}),
    ("disc: a circle point beyond a chord", Implies(disc, (x - 3) * 4 + (y - 1) * 3 < 10),
     {"x": F(3) + F(8, 5), "y": F(1) + F(6, 5)}),
    ("strict, by a tiny amount", Implies(ball, x**3 <= 8 - F(1, 10**40)), {"x": F(2)}),
    ("equality goal fails at the boundary", Implies(ball, x * (x - 2) == 0), {"x": F(1)}),
    # false at a single point of the ball
    ("single bad point", Implies(disc, (x - 3) ** 2 + (y - 1) ** 2 > 0), {"x": F(3), "y": F(1)}),
    ("single bad point, != goal", Implies(disc, (x - 3) * (y - 1) != 0), {"x": F(3), "y": F(2)}),
    ("!= goal at the centre", Implies(ball, x**2 != 1), {"x": F(1)}),
    ("!= goal on a line", Implies(disc, x * y != 3 * y), {"x": F(3), "y": F(0)}),
    # not an axis-parallel ellipsoid: the hypotheses do not bound every variable
    ("zero weight", Implies(x**2 + 0 * y**2 <= 1, x * y <= 100), {"x": F(1), "y": F(101)}),
    ("negative weight", Implies(x**2 - y**2 <= 1, y**2 <= 25), {"x": F(0), "y": F(6)}),
    ("hyperbola", Implies(And(x**2 - y**2 <= 1, x**2 <= 1), x * y <= 1), {"x": F(1), "y": F(5)}),
    ("cross term", Implies(x**2 + 3 * x * y + y**2 <= 1, x**2 <= 10), {"x": F(10), "y": F(-10)}),
    ("cross term only", Implies(And(x * y <= 1, x**2 <= 1), y**2 <= 4), {"x": F(0), "y": F(3)}),
    ("linear term without square", Implies(x**2 + y <= 1, y**2 <= 4), {"x": F(0), "y": F(-3)}),
    ("cubic 'ball'", Implies(x**2 + y**3 <= 1, y**2 <= 4), {"x": F(0), "y": F(-3)}),
    ("squared sum is no box", Implies((x + y) ** 2 <= 1, x**2 <= 4), {"x": F(3), "y": F(-3)}),
    ("ellipsoid >=, not <=", Implies(x**2 + y**2 >= 1, x**2 <= 4), {"x": F(3), "y": F(0)}),
    ("product of bounds", Implies((x - 1) * (x + 1) <= 0, x * y <= 1), {"x": F(1), "y": F(2)}),
    # hypotheses under a disjunction or a negation
    ("disjunctive hypothesis", Implies(Or(x <= 1, x >= 5), x**2 <= 1), {"x": F(5)}),
    ("disjunctive ball", Implies(Or((x - 1) ** 2 <= 1, (x - 9) ** 2 <= 1), x**2 <= 4), {"x": F(9)}),
    ("negated ball", Implies(Not(x**2 <= 1), x**2 <= 1), {"x": F(2)}),
    ("negated hypotheses", Implies(Not(And(x >= 0, x <= 1)), x * x <= 1), {"x": F(2)}),
    ("double negation, outside", Implies(Not(Not(x**2 >= 1)), x**2 <= 4), {"x": F(3)}),
    ("hypothesis in the goal's premise only", Or(Implies(x**2 <= 1, y <= 0), x * y <= 1),
     {"x": F(1), "y": F(2)}),
    # a variable only in the goal, or only in a hypothesis that is not a bound
    ("unbounded goal variable", Implies(x**2 <= 1, x * y <= 1), {"x": F(1), "y": F(2)}),
    ("goal variable bounded on one side", Implies(And(x**2 <= 1, y >= 0), x * y <= 1),
     {"x": F(1), "y": F(2)}),
    ("bound through a product", Implies(And(x**2 <= 1, 2 * y * x <= 1, x >= F(1, 2)), y**2 <= 1),
     {"x": F(1, 2), "y": F(-5)}),
    # equalities pinning a variable
    ("pinned, strict at edge", Implies(And(x == 2, y**2 <= 1), x * y < 2), {"x": F(2), "y": F(1)}),
    ("pinned to the wrong value", Implies(And(x == 2, y**2 <= 1), x * x == 4 + y * 0 + y**2),
     {"x": F(2), "y": F(1)}),
    ("pinned by two bounds", Implies(And(x >= 3, x <= 3, y**2 <= 1), x**2 * y != 9), {"x": F(3), "y": F(1)}),
    ("equality of a square does not pin", Implies(And(x**2 == 4, y**2 <= 1), x * y <= 0),
     {"x": F(2), "y": F(1)}),
    # nested implications and Iff (read as `true` on both sides)
    ("nested implication", Implies(x**2 <= 1, Implies(y**2 <= 1, x * y < 1)), {"x": F(1), "y": F(1)}),
    ("nested, bound in inner premise", Implies(x**2 <= 1, Implies(y >= 2, x * y <= 1)),
     {"x": F(1), "y": F(2)}),
    ("iff goal", Implies(x**2 <= 1, Iff(x * x <= 1, y >= 0)), {"x": F(0), "y": F(-1)}),
    ("iff hypothesis", Implies(Iff(x**2 <= 1, y >= 0), x * x <= 1), {"x": F(2), "y": F(-1)}),
    ("iff beside bounds", Implies(And(x**2 <= 1, Iff(y * y <= 1, x >= 0)), y**2 <= 1),
     {"x": F(-1), "y": F(2)}),
    # non-polynomial terms: opaque, and the same term means the same value only
    ("division by a variable", Implies(And(x**2 <= 1, y**2 <= 1), x / y <= 1), {"x": F(1), "y": F(1, 2)}),
    ("x/y bounded, x/z not", Implies(And(x**2 <= 1, x / y >= 0, x / y <= 1), (x / z) ** 2 <= 1),
     {"x": F(1, 2), "y": F(1), "z": F(1, 100)}),
    ("x/y bounded, y/x not", Implies(And(x**2 <= 1, y**2 <= 1, x / y >= 0, x / y <= 1), (y / x) ** 2 <= 1),
     {"x": F(1, 10), "y": F(1, 2)}),
    ("high power is opaque", Implies(And(x**2 <= 1, y**7 >= 0, y**7 <= 1), y**8 < 1), {"x": F(0), "y": F(1)}),
    ("array read at i vs j", Implies(And(x**2 <= 1, A[i] >= 0, A[i] <= 1), A[j] * x <= 1), None),
    # the negated goal is the ellipsoid that bounds the variables
    ("negated goal is a ball, tight", Implies(x * y >= 1, x**2 + y**2 > 2), {"x": F(1), "y": F(1)}),
    ("positive definite, strict at 0", x**2 + y**2 > 0, {"x": F(0), "y": F(0)}),
    ("positive definite, != at 0", x**2 + 3 * y**2 != 0, {"x": F(0), "y": F(0)}),
    ("positive definite, negated ==", Not((x - 1) ** 2 + y**2 == 0), {"x": F(1), "y": F(0)}),
    # false only at irrational points: z3 is the witness (exact evaluation cannot reach them)
    ("irrational: boundary of x^2 <= 2", Implies(x**2 <= 2, x**2 < 2), None),
    ("irrational: max of x y on the circle", Implies(x**2 + y**2 == 1, x * y < F(1, 2)), None),
    ("irrational: root of x^2 = 2", Implies(And(x**2 == 2, x >= 0), x**3 != 2 * x), None),
    ("irrational: tangency on a sphere", Implies(x**2 + y**2 <= 3, (x + y) ** 2 < 6), None),
]


def _near_miss_ids():
    return [name for name, _, _ in NEAR_MISSES]


@pytest.mark.parametrize("name,f,cex", NEAR_MISSES, ids=_near_miss_ids())
def test_near_miss_is_not_proved(name, f, cex):
    if cex is None:  # arrays, irrational counterexamples: z3 is the witness that the claim is false
        assert z3_status(f) == "sat"
        assert boxes.proves(f) is False
        return
    assert_not_proved_false_claim(f, cex)


def test_near_misses_are_false_for_z3_too():
    """Each near-miss's counterexample is checked exactly above; z3 agrees that none is valid."""
    for name, f, _ in NEAR_MISSES:
        assert z3_status(f) != "unsat", name


def test_int_symbols_are_bounded_as_reals_but_never_proved_falsely():
    """Int symbols are boxed as reals (an over-approximation) and `i / 2` is real division for both."""
    f = Implies(And(i >= 0, i <= 3, x**2 <= 1), (i / 2) * (i / 2) < F(9, 4))  # false at i = 3
    assert_not_proved_false_claim(f, {"i": 3, "x": F(0)})
    assert_not_proved_false_claim(Implies(And(i >= 0, i <= 3, x**2 <= 1), i * x < 3), {"i": 3, "x": F(1)})
    assert_not_proved_false_claim(Implies(And(i >= -1, i <= 1, j == i), i * j != 1), {"i": 1, "j": 1})
    ok = Implies(And(i >= 0, i <= 3, x**2 <= 1), (i / 2) * (i / 2) <= F(9, 4) + x * x)
    assert z3_status(ok) == "unsat"
    assert boxes.proves(ok) is False or z3_status(ok) != "sat"
    easy = Implies(And(i >= 0, i <= 3, x**2 <= 1), i * x <= 4)
    assert boxes.proves(easy) is True
    assert z3_status(easy) == "unsat"


def test_quantified_and_boolean_parts_are_read_as_true():
    """Subformulas other than comparisons are over-approximated, in hypotheses and goals alike."""
    p, b = Real("p"), Bool("b")
    weak_hyp = Implies(And(ForAll(p, p + 1 > p), x**2 <= 1), x > 0)
    assert z3_status(weak_hyp) == "sat"
    assert boxes.proves(weak_hyp) is False
    # a quantifier in the goal: its truth (here: false) is not something boxes may claim
    bad = Implies(x**2 <= 1, ForAll(p, p + x >= p))  # false at x = -1
    assert z3_status(bad) == "sat"
    assert boxes.proves(bad) is False
    bad2 = Implies(x**2 <= 1, Not(ForAll(p, p + 1 > p)))
    assert z3_status(bad2) == "sat"
    assert boxes.proves(bad2) is False
    # Bool symbols, bare and under Iff / Not
    assert_not_proved_false_claim(Implies(And(b, x**2 <= 1), Iff(b, x * x < 0)), {"b": True, "x": F(0)})
    assert_not_proved_false_claim(Implies(x**2 <= 1, Or(b, x * x < 0)), {"b": False, "x": F(0)})
    assert_not_proved_false_claim(Implies(And(Not(b), x**2 <= 1), And(Not(b), x * x > 0)),
                                  {"b": False, "x": F(0)})


def test_contradictory_hypotheses_prove_anything():
    for f in (
        Implies(And(x**2 <= 1, x >= 2), x * y == 7),
        Implies(And((x - 5) ** 2 + y**2 <= 1, x <= 0), x * y > 10**9),
        Implies(x**2 + y**2 <= -1, x * y == 3),
        Implies(And(x == 1, x == 2), y * y < 0),
    ):
        assert z3_status(f) == "unsat", str(f)
        assert boxes.proves(f) is True, str(f)


def test_trivial_formulas():
    assert boxes.proves(FALSE) is False
    assert_not_proved_false_claim(Implies(x**2 <= 1, FALSE), {"x": F(0)})
    assert_not_proved_false_claim(Or(x * x < 0, FALSE), {"x": F(0)})
    # valid without any box: the negated goal `x^2 + 1 <= 0` is an empty ellipsoid
    assert boxes.proves(x * x + 1 > 0) is True
    assert boxes.proves(Implies(y * y >= 0, x**2 >= 0)) is True


# --------------------------------------------------------------------------- 3. same term, same value


def test_the_same_opaque_term_is_one_value():
    same = Implies(And(x**2 <= 1, x / y >= 0, x / y <= 1), (x / y) ** 2 <= 2)
    assert z3_status(same) == "unsat"
    assert boxes.proves(same) is True
    read = Implies(And(x**2 <= 1, A[i] >= 0, A[i] <= 1), A[i] * x <= 2)
    assert z3_status(read) == "unsat"
    assert boxes.proves(read) is True


@pytest.mark.parametrize("other,witness", [
    (x / z, {"x": F(1, 2), "y": F(1), "z": F(1, 100)}),
    (z / y, {"x": F(1, 100), "y": F(1, 50), "z": F(1)}),
    (y / x, {"x": F(1, 100), "y": F(1, 50), "z": F(1)}),
    (x / (y + 1), {"x": F(-1, 2), "y": F(-99, 100), "z": F(1)}),
    (x * (1 / y), None),  # x/0 and 1/0 are unrelated values for z3: false only at y = 0
], ids=["x/z", "z/y", "y/x", "x/(y+1)", "x*(1/y)"])
def test_different_opaque_terms_are_not_conflated(other, witness):
    f = Implies(And(x**2 <= 1, y**2 <= 1, x / y >= 0, x / y <= 1), other**2 <= 2)
    if witness is None:
        assert z3_status(f) == "sat", str(f)
        assert boxes.proves(f) is False
    else:
        assert_not_proved_false_claim(f, witness)


# --------------------------------------------------------------------------- 4. deep cases


def test_degree_six():
    hyp = (x - 1) ** 2 + y**2 <= 1  # x in [0, 2], |y| <= 1; x^6 + y^6 = 64 exactly at (2, 0)
    assert_not_proved_false_claim(Implies(hyp, x**6 + y**6 < 64), {"x": F(2), "y": F(0)})
    assert_not_proved_false_claim(Implies(hyp, (x * y) ** 3 != 0), {"x": F(1), "y": F(0)})
    assert_not_proved_false_claim(Implies(hyp, x**3 * y**3 > -1), {"x": F(1), "y": F(-1)})
    ok = Implies(hyp, x**6 + y**6 <= 66)
    assert boxes.proves(ok) is True
    assert z3_status(ok) != "sat"
    # degree 7: beyond MAX_DEGREE, never proved from it
    assert_not_proved_false_claim(Implies(hyp, x**7 < 128), {"x": F(2), "y": F(0)})


def test_tiny_radius():
    c = (F(1, 3), F(2, 7))
    r2 = F(1, 10**40)
    hyp = (x - c[0]) ** 2 + (y - c[1]) ** 2 <= r2
    ok = Implies(hyp, x * y > F(2, 21) - F(1, 10**15))
    assert boxes.proves(ok) is True
    assert z3_status(ok) != "sat"
    # the centre's value itself, strictly: false just below the centre
    below = {"x": c[0] - F(1, 10**20), "y": c[1]}
    assert_not_proved_false_claim(Implies(hyp, x * y >= F(2, 21)), below)
    assert_not_proved_false_claim(Implies(hyp, x * y > F(2, 21) - F(1, 10**50)), below)
    assert_not_proved_false_claim(Implies(hyp, x * y != F(2, 21)), {"x": c[0], "y": c[1]})


def test_huge_radius_and_coefficients():
    big = 10**20
    hyp = x**2 + y**2 <= big**2
    ok = Implies(hyp, x * y <= big**2)
    assert boxes.proves(ok) is True
    assert z3_status(ok) != "sat"
    half = {"x": F(big, 2), "y": F(big, 2)}  # x y = big^2 / 4
    assert_not_proved_false_claim(Implies(hyp, x * y < F(big**2, 4)), half)
    # huge and tiny coefficients in one literal
    assert_not_proved_false_claim(Implies(And(x**2 <= 1, y**2 <= 1),
                                          10**30 * x * y + F(1, 10**30) * x < 10**30), {"x": F(1), "y": F(1)})
    ok2 = Implies(And(x**2 <= 1, y**2 <= 1), 10**30 * x * y + F(1, 10**30) * x <= 10**30 + 10**27)
    assert boxes.proves(ok2) is True
    assert z3_status(ok2) != "sat"
    # a tiny centre offset
    hyp3 = (x - F(1, 10**25)) ** 2 <= F(1, 10**60)
    assert_not_proved_false_claim(Implies(hyp3, x**2 > F(1, 10**50)), {"x": F(1, 10**25)})


def test_degenerate_boxes():
    """lo == hi: a point box, from `x == c`, from two bounds, and from a radius-0 ball."""
    for pin in (x == 3, And(x >= 3, x <= 3), (x - 3) ** 2 <= 0):
        hyp = And(pin, y**2 <= 1)
        assert_not_proved_false_claim(Implies(hyp, x**2 > 9), {"x": F(3), "y": F(0)})
        assert_not_proved_false_claim(Implies(hyp, x**2 * y < 9), {"x": F(3), "y": F(1)})
        assert_not_proved_false_claim(Implies(hyp, x * y != 0), {"x": F(3), "y": F(0)})
        ok = Implies(hyp, x**2 * y <= 10)
        assert boxes.proves(ok) is True, str(ok)
        assert z3_status(ok) != "sat"
    eq = Implies(And(x == 3, y == -2), x**2 * y == -18)
    assert boxes.proves(eq) is True
    assert z3_status(eq) != "sat"
    assert_not_proved_false_claim(Implies(And(x == 3, y == -2), x**2 * y != -18), {"x": F(3), "y": F(-2)})
    # an empty strict ball is not the same as a point
    assert_not_proved_false_claim(Implies((x - 3) ** 2 <= 0, x * x < 9), {"x": F(3)})


def test_many_cases_and_pieces_are_bounded():
    """Past the case or piece budgets the answer is False, never a guess."""
    many = Implies(x**2 + y**2 <= 1, Or(*(x * y > k for k in range(40))))
    assert_not_proved_false_claim(many, {"x": F(0), "y": F(0)})
    # x y <= 1/2 on the unit disc is tight at an irrational point; 12/25 is reached at (3/5, 4/5)
    assert_not_proved_false_claim(Implies(x**2 + y**2 <= 1, x * y < F(12, 25)), {"x": F(3, 5), "y": F(4, 5)})
    # valid, but within 1e-4 of a tangency: whatever boxes answers, z3 must not refute a True
    tangent = Implies(x**2 + y**2 <= 1, x + y <= F(14143, 10000))
    if boxes.proves(tangent):
        assert z3_status(tangent) != "sat"
    easy = Implies(x**2 + y**2 <= 1, x * y + x <= 2)
    assert boxes.proves(easy) is True
    assert z3_status(easy) != "sat"


def test_discharge_check_uses_boxes_only_for_a_proof():
    """The call site: a proved claim is answered `unsat` by the intervals back end, a false one
    still reaches z3 and gets its counterexample."""
    from certiloop.proofs.engine.budget import Budget
    from certiloop.proofs.engine.discharge import _check

    valid = Implies((x - 3) ** 2 + (y - 1) ** 2 <= 4, x * y <= 20)
    answer = _check(valid, Budget())
    assert (answer.status, answer.backend) == ("unsat", "intervals")
    false = Implies((x - 3) ** 2 + (y - 1) ** 2 <= 4, x * y < 10)  # x y = 10.12 at (4.6, 2.2)
    assert truth(false, {"x": F(3) + F(8, 5), "y": F(1) + F(6, 5)}) is False
    answer = _check(false, Budget())
    assert (answer.status, answer.backend) == ("sat", "z3")


# --------------------------------------------------------------------------- exhaustive small grid


def test_tight_thresholds_around_a_disc():
    """For q in a few quadratics and thresholds t near max q over the disc, the four comparisons:
    a proved one holds at all of a dense set of rational circle points, and z3 agrees."""
    hyp = (x - 1) ** 2 + (y + 2) ** 2 <= 1
    circle = []
    for a, b in product(range(-4, 5), range(1, 4)):
        s = F(a, b)
        circle.append({"x": 1 + 2 * s / (s * s + 1), "y": -2 + (s * s - 1) / (s * s + 1)})
    circle.append({"x": F(1), "y": F(-1)})
    for q in (x * y, x**2 - y, x * x + y * y, (x - 1) * (y + 2)):
        vals = [evaluate(q, p) for p in circle]
        hi = max(vals)
        for t in (hi - F(1, 100), hi, hi + F(1, 10**8), hi + 3):
            for goal in (q <= t, q < t):
                f = Implies(hyp, goal)
                if boxes.proves(f):
                    assert all(truth(f, p) for p in circle), str(f)
                    assert z3_status(f) != "sat", str(f)
                elif t == hi + 3:
                    pytest.fail(f"boxes missed an easy claim: {f}")


# --------------------------------------------------------------------------- deep run only


@pytest.mark.deep
def test_deep_sweep_random_seed():
    """`HYPOTHESIS_PROFILE=deep python -m pytest -q tests/proofs/core/test_boxes.py`: both
    constructions at scale, from a fresh seed each run (printed on failure, so a failure reproduces)."""
    seed = random.randrange(2**32)
    d = Draw(rnd=random.Random(seed))
    for _ in range(1500):
        region = Region(d, d.int(1, 4))
        p = region.point(d, boundary=d.int(0, 1) == 1)
        goal = false_goal(d, region, p)
        if evaluate(goal, p) is False:
            f = assemble(d, region.hyps, goal)
            assert boxes.proves(f) is False, f"seed {seed}: boxes proved `{f}`, false at {p}"
        samples = region.points(d, 6)
        f = assemble(d, region.hyps, random_goal(d, region, samples))
        if boxes.proves(f):
            check_proved_claim_is_valid(d, region, samples, f)


@given(st.integers(0, 10**60), st.integers(1, 24))
def test_integer_roots_are_floors(m, n):
    r = boxes._iroot(m, n)
    assert r**n <= m < (r + 1) ** n


@given(st.fractions(min_value=0, max_value=10**12, max_denominator=10**9), st.sampled_from([2, 4, 6, 20]))
def test_rational_roots_bound_from_above_and_are_exact_when_they_can_be(q, n):
    r = boxes._root_up(F(q), n)
    assert r**n >= q
    assert boxes._root_up(r**n, n) == r  # an exact root is returned as it is
