"""Initial states under a bounded ∀ over Int (falsify/initial.py): a path's per-element
assumptions are repaired element by element, so most drawn states are kept, and every kept state
satisfies the assumptions, checked here in plain Python, independently of the interpreter."""

from __future__ import annotations

from certiloop.falsify.choosers import RandomChooser
from certiloop.falsify.initial import initial_state
from certiloop.falsify.interpreter import Interpreter, Run
from certiloop.falsify.store import Rejected
from certiloop.models import library


def _is_path_with_free_elements(s) -> bool:
    """The repaired Definition 4 (cfmpa_paths.is_path_fixed) on a drawn state, by hand."""
    N, m, n, ln = (int(s[k]) for k in ("N", "m", "n", "ln"))
    Li, Lj, P = s["Li"], s["Lj"], s["P"]

    def li(k):
        return Li.read((k,))

    def lj(k):
        return Lj.read((k,))

    if not (N >= 1 and m >= 1 and n >= 1 and ln >= 1):
        return False
    if (li(0), lj(0), li(ln - 1), lj(ln - 1)) != (s["si"], s["sj"], s["gi"], s["gj"]):
        return False
    for k in range(ln):
        i, j = li(k), lj(k)
        if not (0 <= i < m and 0 <= j < n) or P.read((min(k, N - 1), i, j)) != 0:
            return False
        if k + 1 < ln and (abs(li(k + 1) - i) > 1 or abs(lj(k + 1) - j) > 1):
            return False
    return True


def test_path_assumptions_are_met_by_repair_and_really_hold():
    interp = Interpreter(library.get("cfmpa.property4"))
    kept = 0
    for seed in range(100):
        chooser = RandomChooser(seed)
        interp.chooser, interp.out = chooser, Run()
        try:
            state = initial_state(interp, chooser)
        except Rejected:
            continue
        kept += 1
        assert _is_path_with_free_elements(state)
    assert kept >= 40  # before the bounded ∀ was instantiated, about 2 in 100 were kept


def test_a_havoc_followed_by_a_range_test_is_drawn_inside_the_range():
    """`k := *; ?(0 <= k < N)`: the open k is drawn within the bounds the test puts on it (with
    N already set), not from the default [-2, 8], so such a run is rarely blocked, and the draw
    still covers the whole range: every k in [0, N - 1] comes up (checked here by hand)."""
    from certiloop.falsify.evaluate import Blocked
    from certiloop.models import Ints, Theorem, havoc, seq, test

    k, N = Ints("k N")
    theorem = Theorem("range", N == 12, seq(havoc(k), test((0 <= k) & (k < N))), k < N - 1)
    interp = Interpreter(theorem)
    seen, blocked = set(), 0
    for seed in range(300):
        try:
            run = interp.run(RandomChooser(seed))
        except Blocked:
            blocked += 1
            continue
        k_value = int(run.checkpoints[-1].state["k"])
        assert 0 <= k_value < 12  # the test held: the interpreter checked it, and so do we
        seen.add(k_value)
    assert blocked == 0 and seen == set(range(12))  # [-2, 8] would miss 9, 10 and 11


def test_a_quadratic_assumption_is_met_at_its_vertex_or_roots():
    """rcm.barrier_clearance's `gap*(23/1000 - gap) >= 529/4000000*Y` holds only for gap in a
    window of width ~0.002 around 0.0115 (Y near 1): a linear repair cannot find it, so 4 in 5
    drawn states were rejected. The quadratic's vertex or roots meet it; every kept state is
    checked here in exact rationals (to rounding: its edge is met in floats), independently of
    the interpreter."""
    from fractions import Fraction

    interp = Interpreter(library.get("rcm.barrier_clearance"))
    kept = 0
    for seed in range(100):
        try:
            s = interp.run(RandomChooser(seed)).checkpoints[0].state
        except Rejected:
            continue
        kept += 1
        gap, Y = Fraction(s["gap"]), Fraction(s["Y"])
        # a root (or the vertex at Y = 1) is the bound's edge: met in floats, here up to rounding
        assert 0 < Y <= 1
        assert gap * (Fraction(23, 1000) - gap) - Fraction(529, 4000000) * Y >= -Fraction(1, 10**12)
    assert kept >= 20  # 0 of 100 before (the repairs of 0 < Y <= 1 with large slacks reject the rest)
