"""The human-force search on the RCM paper's controller (studies/rcm/push.py): the paper's 4 ms
explicit Euler lets a push into the cloud, the proved guard does not, under the same search.
Small clouds and horizons keep these quick; `certiloop falsify rcm.push_euler` runs the full one."""

import json

import numpy as np
import pytest

from certiloop.cli.main import main
from certiloop.studies.rcm import push as rp
from certiloop.studies.rcm.arm import tool_tip
from certiloop.studies.rcm.demo import D_C

SMALL = {"max_examples": 20, "points": 300, "horizon": 200, "tighten": 1}


@pytest.fixture(scope="module")
def euler():
    return rp.search("rcm.push_euler", seed=0, **SMALL)


def test_the_paper_controller_lets_a_push_in_and_a_brute_force_replay_confirms_it(euler):
    run = euler.run
    assert run is not None and run.entered and run.first_entry >= 0
    again = rp.replay("rcm.push_euler", run.profile, points=300)
    assert again.entered and again.first_entry == run.first_entry
    # the witness by hand: the tip along the entering period's joint path, against every point
    ctrl = rp._controller("rcm.push_euler", 300, 0.02)
    forces = run.profile.forces()
    for force in forces[:-1]:
        ctrl.step([*force, 0, 0, 0])
    q0 = ctrl.q.copy()
    ctrl.step([*forces[-1], 0, 0, 0])
    least = min(float(np.sqrt(((tool_tip(q0 + s * (ctrl.q - q0), ctrl.tool_length)[0] - c) ** 2).sum()))
                for s in np.linspace(0, 1, rp.SUBSTEPS + 1) for c in ctrl.barrier.points) - D_C
    assert least < 0 and least == pytest.approx(again.clearance[-1], abs=1e-12)
    assert run.profile.peak() <= 10.0 + 1e-9  # within the searched operator bound


def test_the_shrunk_push_is_minimal_along_its_scale(euler):
    lo, hi = euler.scale
    assert 0 < hi <= 1 and hi - lo <= 2.0 ** -12 * 1.0001
    assert not rp.replay("rcm.push_euler", euler.unshrunk.scaled(lo), points=300).entered
    assert rp.replay("rcm.push_euler", euler.unshrunk.scaled(hi), points=300).entered


def test_the_guard_keeps_the_same_search_out(euler):
    guarded = rp.search("rcm.push_guarded", seed=0, **SMALL)
    assert guarded.run is None and guarded.examples >= SMALL["max_examples"]
    assert guarded.closest > 0
    # and the push that got the paper's controller in, held 50 periods longer, does not
    longer = rp.Profile((*euler.run.profile.segments, (50, euler.run.profile.segments[-1][1])))
    assert not rp.replay("rcm.push_guarded", longer, points=300).entered


def test_brute_clearance_of_a_capsule_by_hand():
    cloud = np.array([[0.0, 0.0, -0.01], [0.05, 0.0, 0.0]])
    flange, tip = np.array([[0.0, 0.0, 0.1]]), np.array([[0.0, 0.0, 0.0]])
    # nearest: the point 1 cm below the tip, so 0.01 - d_c - radius for the capsule
    got = rp.brute_clearance(cloud, flange, tip, capsule=True)[0]
    assert got == pytest.approx(0.01 - D_C - rp.RADIUS)
    assert rp.brute_clearance(cloud, flange, tip, capsule=False)[0] == pytest.approx(0.01 - D_C)


@pytest.mark.slow
def test_cli_reports_the_push_with_json_and_a_plot(tmp_path):
    out, png = tmp_path / "p.json", tmp_path / "p.png"
    assert main(["falsify", "rcm.push_euler", "--max-examples", "20", "-q", "--json", str(out),
                 "--plot", str(png)]) == 1
    doc = json.loads(out.read_text())
    assert doc["entered"] and doc["least_clearance_m"] < 0 and png.stat().st_size > 10_000


@pytest.mark.parametrize("argv, message", [
    (["falsify", "rcm.push_nope"], "unknown kernel scenario 'rcm.push_nope'"),
    (["falsify", "rcm.push_euler", "sbs.ctrl1"], "cannot be falsified in one call"),
])
def test_bad_input_is_one_line_exit_2(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err
