"""Certified FMT* planning (the Raven-II paper): kinematics, interval enclosures, the
independent certificate check, `certiloop plan` / `check-path`, and tracking.

Independent witnesses: the closed-form kinematics is checked against the 4x4 DH product of
`studies/raven/arm.py`; a certificate's verdict is checked against dense float sampling with
that same 4x4 product (not the code that proved it); a path straight through the partition
must be rejected, and sampling shows it does cross. Planning tests need OMPL and are
skipped (with the reason) without it; the bad-input and no-OMPL tests always run.
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from certiloop.cli.main import main
from certiloop.studies.raven import arm as raven
from certiloop.studies.raven.plan import intervals as iv
from certiloop.studies.raven.plan import kinematics
from certiloop.studies.raven.plan.certify import enclose_points, prove_segment
from certiloop.studies.raven.plan.check import check_run
from certiloop.studies.raven.plan.scenes import FRS_BOX, SCENES, box_faces


def _have_ompl() -> bool:
    try:
        import ompl  # noqa: F401
    except ImportError:
        return False
    return True


HAVE_OMPL = _have_ompl()
needs_ompl = pytest.mark.skipif(not HAVE_OMPL,
                                reason="ompl is not installed: pip install 'certiloop[plan]' (Linux wheels)")


def dense_clearance(scene, qa, qb, points: int = 4001) -> np.ndarray:
    """The least clause slack along a joint segment by float sampling, with the 4x4 DH
    product of studies/raven/arm.py (not the closed form the planner uses)."""
    t = np.linspace(0.0, 1.0, points)[:, None]
    q = np.asarray(qa) + t * (np.asarray(qb) - np.asarray(qa))
    frames = raven.frames(q, scene.arm)
    wrist, tip = frames[:, 4, :3, 3], frames[:, 5, :3, 3]
    worst = np.full(len(q), np.inf)
    for clause in scene.clauses:
        best = np.full(len(q), -np.inf)
        for n, c in clause:
            best = np.maximum(best, np.minimum(wrist @ np.array(n), tip @ np.array(n)) - c - scene.margin)
        worst = np.minimum(worst, best)
    return worst


# ----------------------------------------------------------------------------- kinematics


def test_closed_form_matches_the_dh_product():
    q = np.random.default_rng(3).uniform(-3.2, 3.2, (1000, 6))
    for arm in ("left", "right"):
        frames = raven.frames(q, arm)
        wrist, tip = kinematics.points(q, arm)
        assert np.abs(wrist - frames[:, 4, :3, 3]).max() < 1e-12
        assert np.abs(tip - frames[:, 5, :3, 3]).max() < 1e-12


@given(st.floats(-10, 10), st.floats(0, 7))
def test_interval_cos_sin_enclose_every_point(lo, width):
    x = iv.Interval(np.array([lo]), np.array([lo + width]))
    c, s = iv.cos(x), iv.sin(x)
    pts = np.linspace(lo, lo + width, 2001)
    assert np.all(c.lo <= np.cos(pts)) and np.all(np.cos(pts) <= c.hi)
    assert np.all(s.lo <= np.sin(pts)) and np.all(np.sin(pts) <= s.hi)


@given(st.lists(st.floats(0, 1), min_size=6, max_size=6), st.lists(st.floats(0, 0.2), min_size=6, max_size=6),
       st.sampled_from(["left", "right"]))
def test_interval_kinematics_enclose_the_dh_product(centre, widths, arm):
    lo = FRS_BOX.lo + np.array(centre) * (FRS_BOX.hi - FRS_BOX.lo)
    hi = lo + np.array(widths)
    wrist, tip = enclose_points([iv.Interval(np.array([a]), np.array([b])) for a, b in zip(lo, hi)], arm)
    q = lo + np.random.default_rng(0).random((500, 6)) * (hi - lo)
    q = np.vstack([q, lo, hi])
    frames = raven.frames(q, arm)
    for k in range(3):  # float FK is within ~1e-15 of the exact point the enclosure holds
        for enclosure, points in ((wrist, frames[:, 4, :3, 3]), (tip, frames[:, 5, :3, 3])):
            assert np.all(enclosure[k].lo - 1e-13 <= points[:, k])
            assert np.all(points[:, k] <= enclosure[k].hi + 1e-13)


def test_outward_rounding_encloses_exact_sums_and_products():
    a, b = 0.1, 0.2
    s, p = iv.Interval(a) + iv.Interval(b), iv.Interval(a) * iv.Interval(b)
    exact_s, exact_p = Fraction(a) + Fraction(b), Fraction(a) * Fraction(b)
    assert Fraction(float(s.lo)) <= exact_s <= Fraction(float(s.hi))
    assert Fraction(float(p.lo)) <= exact_p <= Fraction(float(p.hi))


def test_planning_modules_load_no_solver_and_no_ompl_until_planning():
    code = ("import sys, certiloop.studies.raven.plan.planner, certiloop.studies.raven.plan.certify, "
            "certiloop.studies.raven.plan.check, certiloop.studies.raven.plan.scenes; "
            "print(sorted(m for m in ('z3', 'sympy', 'hypothesis', 'scipy', 'ompl', 'mpmath') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


# ----------------------------------------------------------------------------- the scene


def test_frs_box_scene_is_what_its_docstring_says():
    _, tip = kinematics.points(np.array([FRS_BOX.start, FRS_BOX.goal]))
    assert np.allclose(tip[0], [-0.045, -0.16, 0.02], atol=2e-5)
    assert np.allclose(tip[1], [0.045, -0.16, 0.02], atol=2e-5)
    assert len(FRS_BOX.clauses) == 6 and len(box_faces((0, 0, 0), (1, 1, 1))) == 6
    # the straight joint path runs through the partition (sampled with the DH product)
    assert dense_clearance(FRS_BOX, FRS_BOX.start, FRS_BOX.goal).min() < -0.01


def straight_run(pieces: int = 64) -> dict:
    """A path straight from start to goal, through the partition, with a fine certificate."""
    return {"success": True, "waypoints": [list(FRS_BOX.start), list(FRS_BOX.goal)],
            "certificate": {"scene": FRS_BOX.to_json(),
                            "segments": [{"index": 0, "pieces": [str(Fraction(k, pieces))
                                                                 for k in range(pieces + 1)]}]}}


def test_a_path_through_the_partition_is_rejected_by_both_checks():
    assert not prove_segment(FRS_BOX, FRS_BOX.start, FRS_BOX.goal).proved
    result = check_run(straight_run(), SCENES)
    assert not result.ok and result.bad_segment == 0 and "segment 0" in result.reason


def test_check_path_rejects_the_straight_path_exit_1(tmp_path, capsys):
    f = tmp_path / "straight.json"
    f.write_text(json.dumps({"runs": [straight_run()]}))
    assert main(["check-path", str(f)]) == 1
    out = " ".join(capsys.readouterr().out.split())
    assert "REJECTED" in out and "segment 0" in out


def test_a_short_clear_segment_is_proved_and_sampling_agrees():
    qa = np.array(FRS_BOX.start)
    qb = qa + np.array([0.0, 0.0, 0.05, 0.1, 0.0, 0.0])  # retract 5 cm (d3 up: the wrist nears the RCM), roll
    proof = prove_segment(FRS_BOX, qa, qb)
    assert proof.proved and proof.least_margin >= 0
    assert dense_clearance(FRS_BOX, qa, qb).min() >= proof.least_margin - 1e-12


unit6 = st.lists(st.floats(0, 1), min_size=6, max_size=6)


@settings(max_examples=40)
@given(unit6, st.lists(st.floats(-0.15, 0.15), min_size=6, max_size=6))
def test_whatever_the_prover_proves_the_checker_accepts_and_sampling_confirms(start, step):
    span = FRS_BOX.hi - FRS_BOX.lo
    qa = FRS_BOX.lo + np.array(start) * span
    qb = np.clip(qa + np.array(step) * span, FRS_BOX.lo, FRS_BOX.hi)
    assume(FRS_BOX.valid(np.array([qa, qb])).all())
    proof = prove_segment(FRS_BOX, qa, qb)
    sampled = dense_clearance(FRS_BOX, qa, qb, points=2001).min()
    if not proof.proved:
        return
    assert sampled >= -1e-12, "the prover proved a segment that sampling shows crossing"
    scene = FRS_BOX.to_json()
    run = {"waypoints": [list(qa), list(qb)],
           "certificate": {"scene": {**scene, "start": list(qa), "goal": list(qb)},
                           "segments": [{"index": 0, "pieces": proof.breakpoints()}]}}
    assert check_run(run).ok  # no library comparison: the start and goal are this segment's


# ----------------------------------------------------------------------------- bad input


def test_plan_without_ompl_exits_2_with_install_hint():
    code = ("import sys; sys.modules['ompl'] = None\n"
            "from certiloop.cli.main import main\n"
            "sys.exit(main(['plan', 'raven.frs_box', '--samples', '50']))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "certiloop[plan]" in lines[0] and "Traceback" not in done.stderr


@pytest.mark.parametrize("args, words", [
    (["plan", "raven.nowhere", "--samples", "50"], "unknown scenario"),
    (["plan", "raven.frs_box", "--samples", "1"], "--samples"),
    (["plan", "raven.frs_box", "--samples", "50", "--eta", "0.1"], "--eta"),
    (["plan", "raven.frs_box", "--samples", "50", "--eta", "a,b"], "--eta"),
    (["plan", "raven.frs_box", "--samples", "50", "--runs", "0"], "--runs"),
    (["plan", "raven.frs_box", "--samples", "50", "--seed", "-1"], "--seed"),
    (["plan", "raven.frs_box", "--samples", "50", "--json", "/no/such/dir/f.json"], "--json"),
    (["plan", "raven.frs_box"], "--samples"),
    (["check-path", "/no/such/file.json"], "no such file"),
])
def test_bad_input_exit_2_one_line(args, words, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err


def test_check_path_malformed_files_exit_2(tmp_path, capsys):
    for text in ("not json", json.dumps([1, 2]), json.dumps({"runs": [{"success": True}]})):
        f = tmp_path / "bad.json"
        f.write_text(text)
        assert main(["check-path", str(f)]) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1


@pytest.mark.parametrize("pieces", [[], [0], "0,1", None])
def test_check_path_segment_without_breakpoints_is_one_line_exit_2(tmp_path, capsys, pieces):
    # a segment whose breakpoints are missing or too few: a malformed certificate, not a crash
    scene = FRS_BOX.to_json()
    run = {"success": True, "waypoints": [list(scene["start"]), list(scene["goal"])],
           "certificate": {"scene": scene, "segments": [{"pieces": pieces}]}}
    f = tmp_path / "pieces.json"
    f.write_text(json.dumps({"runs": [run]}))
    assert main(["check-path", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "pieces" in err and "Traceback" not in err, err


# ----------------------------------------------------------------------------- planning (OMPL)


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    if not HAVE_OMPL:
        pytest.skip("ompl is not installed: pip install 'certiloop[plan]'")
    f = tmp_path_factory.mktemp("plan") / "pl.json"
    code = main(["plan", "raven.frs_box", "--samples", "200", "--runs", "3", "--seed", "0", "-q",
                 "--json", str(f)])
    doc = json.loads(f.read_text())
    return code, doc, f


@needs_ompl
def test_plan_writes_runs_with_certificates(planned):
    code, doc, _ = planned
    assert code == 0 and doc["scenario"] == "raven.frs_box" and len(doc["runs"]) == 3
    ok = [r for r in doc["runs"] if r["success"]]
    assert ok, "no run found a path at n = 200"
    for r in doc["runs"]:
        assert {"success", "planning_s", "cost", "waypoints", "certificate"} <= set(r)
    for r in ok:
        assert r["waypoints"][0] == list(FRS_BOX.start) and r["waypoints"][-1] == list(FRS_BOX.goal)
        assert len(r["certificate"]["segments"]) == len(r["waypoints"]) - 1


@needs_ompl
def test_check_path_accepts_and_dense_sampling_agrees(planned, capsys):
    _, doc, f = planned
    assert main(["check-path", str(f)]) == 0
    for r in (r for r in doc["runs"] if r["success"]):
        q = np.array(r["waypoints"])
        for a, b in zip(q, q[1:]):
            assert dense_clearance(FRS_BOX, a, b).min() >= -1e-12


@needs_ompl
def test_moving_a_wall_1mm_into_a_segment_names_that_segment(planned, tmp_path, capsys):
    _, doc, _ = planned
    run = next(r for r in doc["runs"] if r["success"])
    q = np.array(run["waypoints"])
    # the wall that comes nearest to the path, and by dense sampling the segments it would cut
    walls = [k for k, clause in enumerate(FRS_BOX.clauses) if len(clause) == 1]
    best = None
    for k in walls:
        n, c = FRS_BOX.clauses[k][0]
        one = copy.copy(FRS_BOX)
        object.__setattr__(one, "clauses", (FRS_BOX.clauses[k],))
        slack = [dense_clearance(one, a, b).min() for a, b in zip(q, q[1:])]
        if best is None or min(slack) < best[2]:
            best = (k, slack, min(slack))
    k, slack, least = best
    shift = least + 0.001  # the plane moves so the nearest segment is 1 mm past the margin
    expected = next(i for i, s in enumerate(slack) if s < shift)
    tampered = copy.deepcopy(run)
    tampered["certificate"]["scene"]["clauses"][k][0]["offset"] += shift
    f = tmp_path / "moved.json"
    f.write_text(json.dumps({"runs": [tampered]}))
    assert main(["check-path", str(f)]) == 1
    out = " ".join(capsys.readouterr().out.split())
    assert f"segment {expected} " in out and "REJECTED" in out


@needs_ompl
def test_check_path_rejects_a_certificate_for_other_planes(planned, tmp_path, capsys):
    _, doc, _ = planned
    run = copy.deepcopy(next(r for r in doc["runs"] if r["success"]))
    run["certificate"]["scene"]["clauses"][0][0]["offset"] -= 0.01  # a wall moved *away*: path still clear
    f = tmp_path / "other.json"
    f.write_text(json.dumps({"runs": [run]}))
    assert main(["check-path", str(f)]) == 1
    assert "differ from the library scene" in " ".join(capsys.readouterr().out.split())


@needs_ompl
def test_same_seed_same_path_and_seeds_differ():
    from certiloop.studies.raven.plan.planner import plan_once

    a, b, c = (plan_once(FRS_BOX, 150, s) for s in (4, 4, 5))
    assert a.waypoints == b.waypoints and a.cost == b.cost and a.success == b.success
    assert a.waypoints != c.waypoints or a.success != c.success


@needs_ompl
def test_tracking_with_the_fixture_crosses_no_boundary(planned):
    from certiloop.studies.raven.plan.track import track

    _, doc, _ = planned
    run = next(r for r in doc["runs"] if r["success"])
    # a nominal operator reaches the goal, with the fixture, crossing nothing
    nominal = track(FRS_BOX, run["waypoints"], per_segment=100, settle=300)
    assert nominal.min_wall >= -1e-12 and nominal.min_block >= -1e-12 and nominal.final_error < 1e-3
    # a sloppy operator (lagging 3x more) cuts into the partition without the fixture ...
    bare = track(FRS_BOX, run["waypoints"], per_segment=100, settle=300, pull=3.0, fixture_on=False)
    held = track(FRS_BOX, run["waypoints"], per_segment=100, settle=300, pull=3.0)
    assert min(bare.min_wall, bare.min_block) < -1e-3
    # ... and the fixture holds it out (it may stop short of the goal: ctrl2 scales, never slides)
    assert held.min_wall >= -1e-12 and held.min_block >= -1e-12


def test_joint_pd_tracking_sees_a_crossing_on_the_straight_path():
    from certiloop.studies.raven.plan.track import track_joints

    straight = track_joints(FRS_BOX, [FRS_BOX.start, FRS_BOX.goal])
    assert straight.min_clearance < -0.005 and straight.final_error < 2e-3


@needs_ompl
def test_joint_pd_tracking_of_a_planned_path_reaches_the_goal(planned):
    from certiloop.studies.raven.plan.track import track_joints

    _, doc, _ = planned
    run = next(r for r in doc["runs"] if r["success"])
    result = track_joints(FRS_BOX, run["waypoints"])
    assert result.final_error < 2e-3 and np.isfinite(result.min_clearance)
    assert result.seconds == pytest.approx(0.35 * (len(run["waypoints"]) - 1) + 0.3)
