"""Dual-arm SCARA planner (the dual-arm paper): paths through the state database, Definitions 4-5,
Theorems 2 and 4, Properties 2-7.

A path is a list of cells L_0 .. L_{len-1} (the Int arrays Li, Lj); element k is where the
subordinate is at time kΔt, checked against layer k while the principal moves (k < N) and
against the last layer N-1 once it has stopped (k >= N).

Definition 4 as printed checks element k only under the premise that L_k *and* L_{k+1} are
in the grid (D5): the last element (k = len-1, whose successor is past the list's end) is
never checked, a one-element path is not checked at all, and an element off the grid
exempts itself and its predecessor. Properties 3, 4, 6 and 7 are false under it
(`property3_printed`). The repaired definition checks every element: in the grid, free in
layer min(k, N-1), king-adjacent to the next (`is_path_fixed`); under it Properties 2-4 and
Theorems 2/4 hold. Property 5 ("optpath is a path") needs the premise that a path exists
(D8, `property5_unguarded`). Nothing forces len >= N (D6): a path may end before the
principal stops, and the parked subordinate is then never checked against the later
layers (`early_arrival`); the planner therefore requires len >= N.

The printed definition is stated with one quantified index k (not the paper's five bound
variables i j k i' j', which are determined by k); the two are equivalent.
"""

from __future__ import annotations

from certiloop.models.lang.conveniences import for_range, if_
from certiloop.models.lang.programs import assign, branch, choice, havoc, seq, skip, test
from certiloop.models.lang.terms import INT, And, Array, ForAll, Implies, Int, Ints, Or
from certiloop.models.lang.theorem import Theorem

N, m, n, ln = Ints("N m n ln")  # layers, grid size, path length
si, sj, gi, gj = Ints("si sj gi gj")  # start and goal cells
kk, x, found, ok = Ints("kk x found ok")
y = Int("y")
P = Array("P", (INT, INT, INT), INT)
Li = Array("Li", INT, INT)
Lj = Array("Lj", INT, INT)


def in_grid(e):
    """Element e of the path is a cell of the m x n grid."""
    return And(0 <= Li[e], Li[e] < m, 0 <= Lj[e], Lj[e] < n)


def free_at(e):
    """Element e is free in layer min(e, N-1) (written as two implications: Ite is formula-level)."""
    return And(Implies(e < N, P[e][Li[e]][Lj[e]] == 0), Implies(e >= N, P[N - 1][Li[e]][Lj[e]] == 0))


def adjacent(e):
    """Elements e and e+1 are king neighbours (or equal): one step of at most one cell per joint."""
    return And(Li[e + 1] - Li[e] <= 1, Li[e] - Li[e + 1] <= 1, Lj[e + 1] - Lj[e] <= 1, Lj[e] - Lj[e + 1] <= 1)


def ends():
    """Property 2's conclusion: the path starts at the start cell and ends at the goal cell."""
    return And(ln >= 1, Li[0] == si, Lj[0] == sj, Li[ln - 1] == gi, Lj[ln - 1] == gj)


def is_path_printed():
    """Definition 4 as printed: element k is checked only when L_k and L_{k+1} are both in the grid."""
    checked = Implies(And(in_grid(y), in_grid(y + 1)), And(adjacent(y), free_at(y)))
    return And(ends(), ForAll(y, Implies(And(0 <= y, y < ln), checked)))


def element_ok(e, length=ln):
    """The repaired per-element check: in the grid, free in its layer, adjacent to the next."""
    return And(in_grid(e), free_at(e), Implies(e + 1 < length, adjacent(e)))


def is_path_fixed():
    """Definition 4 repaired (D5): every element is checked."""
    return And(ends(), ForAll(y, Implies(And(0 <= y, y < ln), element_ok(y))))


def _dims():
    return And(N >= 1, m >= 1, n >= 1, ln >= 0)


def _pick_element(extra):
    """kk := any index of the path with `extra` (Property 3 quantifies over it)."""
    return seq(havoc(kk), test(And(0 <= kk, kk < ln, extra)))


def property3_printed() -> Theorem:
    """Property 3 under Definition 4 as printed is false: a one-element path [start] whose
    successor (past the list's end, an unspecified value) is off the grid checks nothing, so
    the start may be a cell with P = 1."""
    return Theorem(
        name="cfmpa.property3_printed",
        assumptions=And(_dims(), is_path_printed()),
        program=_pick_element(And(kk < N, in_grid(kk))),
        guarantee=P[kk][Li[kk]][Lj[kk]] == 0,
        expected="refuted",
        constants=(N, m, n, ln, si, sj, gi, gj),
        scenarios=(ln == 1,),
        description="Property 3 under Def 4 as printed: the last element is never checked",
    )


def property3() -> Theorem:
    """Properties 2 and 3 under the repaired Definition 4: the path starts and ends where it
    should, and every element k < N is free in layer k.

    kk is any integer and the range is the guarantee's premise ([kk := *](0 <= kk < min(len, N)
    -> free), the same theorem as `kk := *; ?0 <= kk < min(len, N)` followed by free, with
    Property 2 outside it): a test after the havoc would block most of the falsifier's runs."""
    return Theorem(
        name="cfmpa.property3",
        assumptions=And(_dims(), is_path_fixed()),
        program=havoc(kk),
        guarantee=And(ends(), Implies(And(0 <= kk, kk < ln, kk < N), P[kk][Li[kk]][Lj[kk]] == 0)),
        constants=(N, m, n, ln, si, sj, gi, gj),
        description="Properties 2-3 under the repaired Def 4: ends right, elements k<N free in layer k",
    )


def property4() -> Theorem:
    """Property 4 under the repaired Definition 4: elements k >= N (the principal has stopped)
    are free in the last layer N-1."""
    return Theorem(
        name="cfmpa.property4",
        assumptions=And(_dims(), is_path_fixed()),
        program=havoc(kk),
        guarantee=Implies(And(N <= kk, kk < ln), P[N - 1][Li[kk]][Lj[kk]] == 0),
        constants=(N, m, n, ln, si, sj, gi, gj),
        description="Property 4 under the repaired Def 4: elements k>=N free in layer N-1",
    )


def property5_unguarded() -> Theorem:
    """Property 5 (`is_path(optpath s g) s g` for all s, g) lacks the premise that a path
    exists (D8): with the start cell blocked in layer 0 there is none, and Hilbert's ε in
    Definition 5 then picks an arbitrary list, which is no path."""
    return Theorem(
        name="cfmpa.property5_unguarded",
        assumptions=And(_dims(), 0 <= si, si < m, 0 <= sj, sj < n, 0 <= gi, gi < m, 0 <= gj, gj < n,
                        P[0][si][sj] == 1),
        program=seq(havoc(ln), havoc(Li), havoc(Lj)),
        guarantee=is_path_fixed(),
        expected="refuted",
        constants=(N, m, n, si, sj, gi, gj),
        description="Property 5 without 'a path exists': with the start blocked, ε's pick is no path",
    )


def every_element_free():
    """Properties 6 and 7: every element is a grid cell free in layer min(k, N-1)."""
    return ForAll(y, Implies(And(0 <= y, y < ln), And(in_grid(y), free_at(y))))


def searchoptpath() -> Theorem:
    """Theorems 2 and 4 at the level of the specification: searchoptpath either reports no
    path (found = 0, the paper's Null) or returns a list that passes the repaired Definition 4
    with len >= N (D6). Its post, Properties 6 and 7 plus len >= N, then holds with the
    precondition T: Theorems 2/4 need nothing of the database (D9); safety comes only from
    composing with Theorems 1/3. Optimality (Definition 5) is the planner's business and is
    tested against brute force, as sums over all paths are not expressible here."""
    plan = seq(havoc(ln), havoc(Li), havoc(Lj), test(And(is_path_fixed(), ln >= N)), assign(found, 1))
    return Theorem(
        name="cfmpa.searchoptpath",
        assumptions=_dims(),
        program=choice(branch("no path: Null", assign(found, 0)), branch("a path", plan)),
        guarantee=Implies(found == 1, And(ends(), ln >= N, every_element_free())),
        constants=(N, m, n, si, sj, gi, gj),
        description="Theorems 2/4 (Props 6-7 + len >= N) for any path searchoptpath returns; pre T",
    )


def early_arrival() -> Theorem:
    """D6: the repaired Definition 4 alone lets a path reach the goal before the principal has
    stopped (len < N). The subordinate then parks at the goal during layers len .. N-1, which
    no element of the path checks: the claim that the parked cell is free there is refuted
    (a goal cell free early and blocked later, e.g. where the principal ends up)."""
    return Theorem(
        name="cfmpa.early_arrival",
        assumptions=And(_dims(), is_path_fixed()),
        program=seq(havoc(kk), test(And(ln <= kk, kk < N))),
        guarantee=P[kk][gi][gj] == 0,
        expected="refuted",
        constants=(N, m, n, ln, si, sj, gi, gj),
        scenarios=(And(ln == 1, N == 2),),
        description="D6: a path shorter than N leaves the parked goal cell unchecked in later layers",
    )


def check_path() -> Theorem:
    """The runtime path checker, a loop over the elements: ok = 1 exactly when the list is a
    path under the repaired Definition 4 with len >= N. This is the check the planner must
    pass before it returns a plan."""
    head = And(ends(), ln >= N)
    body = if_(element_ok(x), skip(), assign(ok, 0), labels=("element ok", "element fails: ok := 0"))
    prefix_ok = And(head, ForAll(y, Implies(And(0 <= y, y < x), element_ok(y))))
    inv = And(Or(ok == 0, ok == 1), Implies(ok == 1, prefix_ok), Implies(prefix_ok, ok == 1))
    return Theorem(
        name="cfmpa.check_path",
        assumptions=_dims(),
        program=seq(if_(head, assign(ok, 1), assign(ok, 0),
                        labels=("ends and length ok", "ends or length wrong")),
                    for_range(x, 0, ln, body, inv, label="for each element")),
        guarantee=And(Implies(ok == 1, And(is_path_fixed(), ln >= N)),
                      Implies(And(is_path_fixed(), ln >= N), ok == 1)),
        constants=(N, m, n, ln, si, sj, gi, gj),
        description="the path checker: ok = 1 iff the list is a repaired-Def-4 path with len >= N",
    )
