"""The cfmpa.* theorems (the dual-arm paper): verdicts, and what each counterexample shows, re-read here
in plain Python on the exact values of the refutation (independently of the engine)."""

from fractions import Fraction

import pytest

from certiloop.models import library
from certiloop.proofs.engine.prover import Prover

CFMPA = [n for n in library.names() if n.startswith("cfmpa.")]
REFUTED = [n for n in CFMPA if library.get(n).expected == "refuted"]
# the step-by-step execution models and the printed Property 3 take tens of seconds on a loaded
# 2-core machine: they run under `-m slow` (and in `certiloop gate cfmpa`)
LOOPED = ("cfmpa.execution", "cfmpa.execution_original", "cfmpa.original_backward_half_unreachable",
          "cfmpa.execution_wrong_direction", "cfmpa.execution_layers_floor", "cfmpa.execution_grid_floor",
          "cfmpa.execution_early_arrival", "cfmpa.execution_pose_only", "cfmpa.property3",
          "cfmpa.property3_printed")
QUICK = [n for n in CFMPA if n not in LOOPED]


@pytest.fixture(scope="module")
def prover():
    with Prover(jobs=2) as p:
        yield p


@pytest.fixture(scope="module")
def results(prover):
    return {name: prover.prove(library.get(name)) for name in QUICK}


@pytest.fixture(scope="module")
def looped(prover):
    return {name: prover.prove(library.get(name)) for name in LOOPED}


def test_the_family_covers_the_paper():
    expected = {
        "cfmpa.builtdr", "cfmpa.builtdr_skips_last_row", "cfmpa.builtdr_inclusive", "cfmpa.property8",
        "cfmpa.property8_converse", "cfmpa.segment_printed", "cfmpa.halfspace_convex",
        "cfmpa.hull_in_halfplane", "cfmpa.sat_separates", "cfmpa.arc_in_chord_hull", "cfmpa.arc_in_triangle",
        "cfmpa.joint_box_monotone", "cfmpa.property3_printed", "cfmpa.property3", "cfmpa.property4",
        "cfmpa.property5_unguarded", "cfmpa.searchoptpath", "cfmpa.early_arrival", "cfmpa.check_path",
        "cfmpa.execution", "cfmpa.execution_original", "cfmpa.original_backward_half_unreachable",
        "cfmpa.execution_wrong_direction", "cfmpa.execution_layers_floor", "cfmpa.execution_grid_floor",
        "cfmpa.execution_early_arrival", "cfmpa.execution_pose_only", "cfmpa.execution_segment_original",
        "cfmpa.execution_segment_modified", "cfmpa.segment_modified_full_speed",
    }
    assert set(CFMPA) == expected
    assert len(REFUTED) >= 10
    for name in CFMPA:
        assert library.get(name).description


@pytest.mark.parametrize("name", QUICK)
def test_verdict_is_the_expected_one(results, name):
    theorem, result = library.get(name), results[name]
    assert result.verdict == theorem.expected, result.reason
    if theorem.expected == "proved":
        assert all(o.verdict == "proved" for o in result.obligations)
    else:
        assert result.run is not None and result.run.replayed, result.reason


def _final(result) -> dict[str, Fraction]:
    ref = result.refutation
    assert ref is not None and ref.trace
    state = dict(ref.initial)
    for step in ref.trace:
        if step.kind != "choice":
            state.update(step.state)
    return {k: Fraction(v) for k, v in state.items() if _is_number(v)}


def _is_number(v) -> bool:
    try:
        Fraction(v)
        return True
    except (TypeError, ValueError):
        return False


def test_arc_leaves_the_chord_hull(results):
    """The run's point on the arc lies strictly beyond the chord: c(1 + ca) + s sa > 1 + ca."""
    s = _final(results["cfmpa.arc_in_chord_hull"])
    assert s["cs"] ** 2 + s["sn"] ** 2 == 1 and s["sn"] >= 0
    assert s["cs"] * (1 + s["ca"]) + s["sn"] * s["sa"] > 1 + s["ca"]


def test_printed_segment_leaves_the_half_plane(results):
    s = _final(results["cfmpa.segment_printed"])
    assert s["x2"] >= 0 and s["y2"] >= 0 and 0 <= s["t"] <= 1
    assert s["t"] * s["x2"] + (s["t"] - 1) * s["y2"] < 0


def test_segment_reading_of_the_original_needs_opposite_signs(results):
    """The original segment is missed only when the joints turn opposite ways (v1 v2 < 0)."""
    s = _final(results["cfmpa.execution_segment_original"])
    assert s["v1"] * s["v2"] < 0
    assert s["lam"] > 0


def test_segment_reading_of_the_modified_needs_a_speed_ratio_mismatch(results):
    s = _final(results["cfmpa.execution_segment_modified"])
    assert abs(s["v1"]) * s["w2"] != abs(s["v2"]) * s["w1"]


def test_property8_converse_meets_only_the_backward_half(results):
    """The cell is free for S' but the original region meets it through S - S'."""
    ref = results["cfmpa.property8_converse"].refutation
    text = repr(ref.trace[-1].state) + repr(ref.initial)
    assert "P2" in text


@pytest.mark.slow
@pytest.mark.parametrize("name", LOOPED)
def test_looped_verdict_is_the_expected_one(looped, name):
    theorem, result = library.get(name), looped[name]
    assert result.verdict == theorem.expected, result.reason
    if theorem.expected == "refuted":
        assert result.run is not None and result.run.replayed, result.reason


def _array(text: str):
    """A refutation's array value `[k: v; ...; else: d]` as a lookup function."""
    entries, default = {}, None
    for part in text.strip("[]").split(";"):
        key, value = (x.strip() for x in part.split(":"))
        if key == "else":
            default = int(value)
        else:
            entries[int(key)] = int(value)
    return lambda i: entries.get(i, default)


@pytest.mark.slow
def test_printed_property3_leaves_a_blocked_cell_unchecked(looped):
    """The run: a path whose element kk is a grid cell with P != 0 (blocked), which the printed
    Def 4 never checked because the next element is off the grid (or past the list's end)."""
    ref = looped["cfmpa.property3_printed"].refutation
    state = {**ref.initial, **ref.trace[-1].state}
    Li, Lj, P = _array(state["Li"]), _array(state["Lj"]), state["P"]
    kk, m, n = int(state["kk"]), int(state["m"]), int(state["n"])
    assert 0 <= Li(kk) < m and 0 <= Lj(kk) < n
    assert not (0 <= Li(kk + 1) < m and 0 <= Lj(kk + 1) < n)
    if P.count("[") == 1 and ";" not in P:  # a constant array `[else: d]`: the cell holds d
        assert _array(P)(0) != 0
    else:  # nested stores: at least the default is not 0 (the replay checked the cell itself)
        assert "else: 0]" not in P


@pytest.mark.slow
def test_early_arrival_run_is_shorter_than_n(looped):
    s = _final(looped["cfmpa.execution_early_arrival"])
    assert s["ln"] < s["N"] and s["seen"] == 1
    assert s["lo"] >= s["ln"]  # the observed instant is in a layer no path element was checked in
