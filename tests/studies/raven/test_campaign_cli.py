"""`certiloop campaign`: exit codes per scenario, byte-identical CSV, Wilson intervals, bad input."""

import csv
import json
import math

import pytest

from certiloop.cli.main import main
from certiloop.studies.raven.campaign.metrics import summarize, wilson
from certiloop.studies.raven.campaign.run import SETUPS, replay, run_setup


def campaign(*args):
    return main(["campaign", *args])


def test_wilson_interval_by_hand():
    # 8 of 10, z = 1.959964, z² = 3.841459: centre (0.8 + z²/20) / (1 + z²/10) = 0.992073 / 1.384146
    # = 0.716740, half z·sqrt(0.8·0.2/10 + z²/400) / 1.384146 = 1.959964 · 0.160011 / 1.384146 = 0.226578
    lo, hi = wilson(8, 10)
    assert lo == pytest.approx(0.716740 - 0.226578, abs=2e-6)
    assert hi == pytest.approx(0.716740 + 0.226578, abs=2e-6)
    assert wilson(0, 20)[0] == 0.0 and wilson(20, 20)[1] == 1.0
    assert all(math.isnan(x) for x in wilson(0, 0))


def test_stop_margin_holds_exit_0(tmp_path, capsys):
    assert campaign("raven.stop_margin", "--runs", "150", "--json", str(tmp_path / "s.json")) == 0
    doc = json.loads((tmp_path / "s.json").read_text())
    assert doc["holds"] and doc["by_kind"]["all"]["crossings"] == 0 and doc["first_crossing"] is None
    assert set(doc["by_kind"]) == {"stuck", "delay", "drop", "jump", "noise", "drift", "none", "all"}
    assert "holds" in capsys.readouterr().out


def test_haptic_only_crosses_exit_1_and_names_the_run(tmp_path, capsys):
    assert campaign("raven.haptic_only", "--runs", "150", "-q", "--json", str(tmp_path / "h.json")) == 1
    out = capsys.readouterr().out
    first = json.loads((tmp_path / "h.json").read_text())["first_crossing"]
    assert f"run seed {first['seed']}" in out and first["kind"] in out
    rec = replay(SETUPS["raven.haptic_only"], first["seed"])  # the printed seed replays the crossing alone
    assert rec.crossings == 1 and rec.min_distance[0] == first["min_distance"]


@pytest.mark.slow  # 32 s of the Raven arm at 1 kHz, twice: about 14 s
def test_paper_schedule_all_four_windows_alarm_and_nothing_else(tmp_path):
    json_file, csv_file = tmp_path / "p.json", tmp_path / "p.csv"
    assert campaign("raven.paper", "-q", "--json", str(json_file), "--csv", str(csv_file)) == 0
    doc = json.loads(json_file.read_text())
    assert doc["holds"] and doc["by_kind"]["override"]["TP"] == 4 and doc["by_kind"]["none"]["TN"] == 2
    rows = list(csv.DictReader(csv_file.open()))
    assert [int(r["start"]) for r in rows if r["kind"] == "override"] == [4000, 12000, 20000, 28000]


def test_csv_is_byte_identical_for_the_same_seed_and_agrees_with_the_json(tmp_path):
    a, b, c = (tmp_path / n for n in ("a.csv", "b.csv", "c.csv"))
    args = ["raven.stop_margin", "--runs", "120", "--ticks", "800", "--seed", "3", "-q"]
    assert campaign(*args, "--csv", str(a), "--json", str(tmp_path / "a.json")) == 0
    assert campaign(*args, "--csv", str(b)) == 0
    assert campaign(*args[:-2], "4", "-q", "--csv", str(c)) == 0
    assert a.read_bytes() == b.read_bytes() != c.read_bytes()
    rows = list(csv.DictReader(a.open()))
    assert len(rows) == 120 and rows[0]["seed"] == str(3 * 1_000_000)
    summary = json.loads((tmp_path / "a.json").read_text())["by_kind"]["all"]
    for k in ("TP", "FP", "FN", "TN"):
        assert summary[k] == sum(r["outcome"] == k for r in rows)


def test_batching_does_not_change_a_run():
    """50 random faults stepped together, in batches of 7, and 12 of them one run at a time:
    equal rows."""
    setup = SETUPS["raven.haptic_only"]
    whole = run_setup(setup, runs=50, seed=5, ticks=600, batch=50)
    assert run_setup(setup, runs=50, seed=5, ticks=600, batch=7) == whole
    # one at a time: a run depends only on its seed, so the first 12 are the first 12 rows
    assert run_setup(setup, runs=12, seed=5, ticks=600, batch=1) == whole[:12]
    assert summarize(whole)["runs"] == 50 and len({r["kind"] for r in whole}) >= 5


@pytest.mark.parametrize("args, message", [
    (["raven.nope"], "unknown scenario 'raven.nope'"),
    (["raven.stop_margin", "--faults", "stuck,foo"], "unknown fault kind 'foo'"),
    (["raven.stop_margin", "--runs", "0"], "--runs must be between 1"),
    (["raven.stop_margin", "--ticks", "10"], "--ticks must be at least 400"),
    (["raven.stop_margin", "--seed", "-1"], "--seed must be between 0"),
    (["raven.paper", "--runs", "5"], "raven.paper is a fixed experiment; --runs does not apply"),
    (["raven.stop_margin", "--csv", "no/such/dir/r.csv"], "--csv no/such/dir/r.csv: the folder"),
    (["raven.stop_margin", "--json", "no/such/dir/s.json"], "--json no/such/dir/s.json: the folder"),
])
def test_bad_input_is_one_line_exit_2(args, message, capsys):
    assert campaign(*args) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
