"""Campaign batches on other executors, the worst-case fault search, the ROC/latency plots."""

import json
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from certiloop.cli.main import main
from certiloop.studies.raven.campaign.fault_search import replay_fault, worst_case
from certiloop.studies.raven.campaign.plots import roc_points
from certiloop.studies.raven.campaign.run import SETUPS, Fault, run_campaign, run_setup


def test_rows_do_not_depend_on_the_executor_or_the_batch_size():
    setup = SETUPS["raven.haptic_only"]
    alone = run_setup(setup, runs=24, seed=5, ticks=400, batch=24)
    with ThreadPoolExecutor(2) as threads:
        threaded = run_setup(setup, runs=24, seed=5, ticks=400, batch=7, executor=threads)
    with ProcessPoolExecutor(2) as processes:
        forked = run_setup(setup, runs=24, seed=5, ticks=400, batch=5, executor=processes)
    assert alone == threaded == forked
    assert [r["run"] for r in forked] == list(range(24))


def test_jobs_flag_gives_the_same_csv(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    args = ["campaign", "raven.haptic_only", "--runs", "60", "--ticks", "400", "-q"]
    main([*args, "--csv", str(a)])
    main([*args, "--jobs", "2", "--csv", str(b)])
    assert a.read_bytes() == b.read_bytes() and a.read_text().count("\n") == 61


def test_search_finds_and_shrinks_a_crossing_without_margin():
    setup = SETUPS["raven.no_margin"]
    result = worst_case(setup, max_examples=300, seed=0)
    assert result.fault is not None and result.examples <= 300 + 2 * 2 * 26  # generation + shrinking
    assert result.min_distance < 0
    # the search stops each run when its fault's window closes; the whole 2,000-tick run (the
    # campaign's, with the same run seed) must cross too, by the same depth
    whole = run_campaign([result.fault], setup.scenario(2000), run_seeds=[0])
    assert whole.min_distance[0] == pytest.approx(result.min_distance, abs=1e-15)
    # the same fault in the proved design's 6 mm margin does not cross
    assert run_campaign([result.fault], SETUPS["raven.stop_margin"].scenario(2000),
                        run_seeds=[0]).min_distance[0] >= 0


def test_search_shrinks_towards_a_minimal_fault():
    # a jump on the command stream is the simplest crossing: below tol (no alarm) but deeper
    # than the 2 mm the fixture keeps
    result = worst_case(SETUPS["raven.no_margin"], kinds=("jump",), max_examples=300, seed=1)
    f = result.fault
    assert f is not None and f.kind == "jump" and f.stream == "command" and f.duration == 1
    assert 0.002 < f.magnitude < 0.003  # deeper than the margin, under tol = 3 mm: no alarm
    # one grid step smaller does not cross (the shrink kept the smallest crossing magnitude)
    smaller = Fault(f.kind, f.stream, f.start, f.duration, 0.002)
    assert replay_fault(SETUPS["raven.no_margin"], smaller, seed=1).min_distance[0] >= 0
    assert replay_fault(SETUPS["raven.no_margin"], f, seed=1).first_alarm[0] == -1


def test_search_is_deterministic_for_a_seed():
    a = worst_case(SETUPS["raven.no_margin"], kinds=("jump", "drift"), max_examples=100, seed=3)
    b = worst_case(SETUPS["raven.no_margin"], kinds=("jump", "drift"), max_examples=100, seed=3)
    assert a.fault is not None and a.fault == b.fault and a.examples == b.examples


SEARCH_AFTER_IMPORTS = """
import importlib, sys
sys.path.insert(0, sys.argv[1])
for name in sys.argv[2:]:
    importlib.import_module(name)
from certiloop.studies.raven.campaign.run import SETUPS
from certiloop.studies.raven.campaign.fault_search import worst_case
r = worst_case(SETUPS["raven.no_margin"], kinds=("jump", "drift"), max_examples=100, seed=3)
print(r.fault, r.found_after)
"""


def test_search_does_not_depend_on_what_the_process_imported_before(tmp_path):
    """Hypothesis harvests constants from every local module imported so far; the search pins
    that pool, so a process that imported a module full of new numbers searches the same (it
    did not: the Raven arm's kernel, imported by a campaign, changed which fault came first)."""
    numbers = ", ".join(f"{0.0021 + k * 1e-5!r}, {101 + 3 * k}" for k in range(200))  # fault starts
    (tmp_path / "many_new_numbers.py").write_text(f"NUMBERS = [{numbers}]\n")

    def search(*imports: str) -> str:
        done = subprocess.run([sys.executable, "-c", SEARCH_AFTER_IMPORTS, str(tmp_path), *imports],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        return done.stdout

    plain = search()
    assert plain.startswith("Fault(") and plain == search("many_new_numbers")


def test_search_on_the_proved_margin_finds_no_crossing(tmp_path):
    out = tmp_path / "s.json"
    assert main(["campaign", "raven.stop_margin", "--search", "--max-examples", "100", "-q",
                 "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["holds"] and doc["crossing"] is None and doc["examples"] == 100


def test_search_cli_reports_the_crossing_exit_1(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert main(["campaign", "raven.no_margin", "--search", "--faults", "jump", "--max-examples", "300",
                 "--json", str(out)]) == 1
    doc = json.loads(out.read_text())
    c = doc["crossing"]
    assert not doc["holds"] and c["kind"] == "jump" and c["min_distance"] < 0
    assert "replay_fault" in capsys.readouterr().out
    fault = Fault(c["kind"], c["stream"], c["start"], c["duration"], c["magnitude"])
    assert replay_fault(SETUPS["raven.no_margin"], fault).min_distance[0] == c["min_distance"]


@pytest.mark.parametrize("argv, message", [
    (["--search", "--runs", "5"], "--runs does not apply to --search"),
    (["--max-examples", "5"], "--max-examples applies to --search only"),
    (["--search", "--max-examples", "0"], "--max-examples must be between"),
    (["--jobs", "0"], "--jobs must be at least 1"),
    (["--jobs", "2", "--executor", "tcp://127.0.0.1:1"], "exclude each other"),
])
def test_search_and_executor_bad_input(argv, message, capsys):
    assert main(["campaign", "raven.no_margin", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_roc_points_by_hand():
    taus, fpr, tpr = roc_points([0.5, 2.0, 3.0], [0.1, 2.5])
    # strictest first: nothing alarms; loosest last: everything does
    assert (fpr[0], tpr[0]) == (0.0, 0.0) and (fpr[-1], tpr[-1]) == (1.0, 1.0)
    at = {t: (f, p) for t, f, p in zip(taus, fpr, tpr)}
    assert at[2.0] == (0.5, 1 / 3)  # > 2.0: 3.0 of the faulty, 2.5 of the golden
    assert at[0.1] == (0.5, 1.0)
    assert np.all(np.diff(fpr) >= 0) and np.all(np.diff(tpr) >= 0)


def test_plot_writes_a_png(tmp_path):
    pytest.importorskip("matplotlib")
    png = tmp_path / "c.png"
    argv = ["campaign", "raven.haptic_only", "--runs", "80", "--ticks", "600", "-q", "--plot", str(png)]
    assert main(argv) == 1
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


@pytest.mark.slow
def test_dask_executor_gives_the_same_rows():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        rows = run_setup(SETUPS["raven.haptic_only"], runs=30, seed=2, ticks=400, batch=8,
                         executor=client.get_executor())
    assert rows == run_setup(SETUPS["raven.haptic_only"], runs=30, seed=2, ticks=400, batch=30)


def test_positioning_closed_form_matches_the_full_chain_and_its_differences():
    from certiloop.studies.raven.arm import Positioning, jacobian, tip
    rng = np.random.default_rng(7)
    q = np.zeros((300, 6))
    q[:, 0], q[:, 1] = rng.uniform(0, 1.6, 300), rng.uniform(0.8, 2.4, 300)
    q[:, 2] = rng.uniform(0.23, 0.56, 300)
    for side in ("left", "right"):
        kin = Positioning(side)
        p, J = kin.tip_and_jacobian(q[:, :3])
        assert np.abs(p - tip(q, side)).max() < 1e-14  # the six 4x4 frames
        assert np.abs(J - jacobian(q, side)[:, :, :3]).max() < 1e-8  # central differences


def test_ik_converges_quadratically_near_the_rest_pose():
    from certiloop.studies.raven.arm import Positioning, RavenArm
    kin, rng = Positioning(), np.random.default_rng(1)
    q = RavenArm().rest(100).q[:, :3]
    target = kin.tip(q) + rng.normal(size=(100, 3)) * 1e-3
    errors = []
    for _ in range(3):
        q = kin.ik_step(target, q)
        errors.append(np.abs(kin.tip(q) - target).max())
    assert errors[0] < 1e-3 and errors[1] < 1e-6 and errors[2] < 1e-12


def test_arm_plant_calibration_deviation_grows_with_speed_and_stays_under_tol():
    from certiloop.studies.raven.campaign.run import Scenario
    peaks = []
    for speed in (0.025, 0.05):
        rec = run_campaign([None] * 8, Scenario(ticks=600, plant="arm", reach_speed=speed), seed=0)
        assert np.all(rec.first_alarm == -1) and np.all(rec.min_distance > 0)
        peaks.append(rec.peak_deviation.max())
    assert 0 < peaks[0] < peaks[1] < 0.003  # the PD lag: about 29 ms times the speed


def test_arm_plant_stop_design_holds_where_haptic_only_crosses():
    faults = [Fault("drift", "command", 150, 300, 1.6e-4)] * 2
    stop = run_campaign(faults, SETUPS["raven.stop_margin_arm"].scenario(800), seed=0)
    haptic = run_campaign(faults, SETUPS["raven.haptic_only_arm"].scenario(800), seed=0)
    assert np.all(stop.min_distance >= 0) and np.all(stop.first_alarm >= 150)
    assert np.all(haptic.min_distance < 0)
