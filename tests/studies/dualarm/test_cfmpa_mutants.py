"""The B4 soundness sampling of benchmarks/bench_cfmpa.py can tell the mutants from the sound
databases: on a few random scenes the original and modified databases never collide, and the
clearest mutants do (the full run, 20,000 samples over 40 scenes, is the benchmark's)."""

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("shapely")
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))

from bench_cfmpa import _soundness_verdict, mutant_soundness  # noqa: E402
from cfmpa_mutants import early_arrival_plans, mutant_databases, random_scene  # noqa: E402

from certiloop.studies.dualarm.arms import builtdr  # noqa: E402
from certiloop.studies.dualarm.planner import check_path  # noqa: E402


@pytest.mark.slow
def test_sampling_separates_sound_from_mutants():
    rows = {r["variant"]: r for r in mutant_soundness(samples=1200, scenes=8, count=5, seed=3)}
    assert rows["original"]["collisions"] == rows["modified"]["collisions"] == 0
    assert rows["original"]["samples"] > 0 and rows["modified"]["samples"] > 0
    for mutant in ("pose only", "wrong σ", "early arrival"):
        assert rows[f"mutant: {mutant}"]["collisions"] > 0, mutant


def test_mutants_change_only_their_piece():
    scene = random_scene(np.random.default_rng(7))
    sound = builtdr(scene, "modified")
    mutants = mutant_databases(scene)
    N, m, n = sound.shape
    assert mutants["floor N"][0].shape[0] <= N and mutants["floor m"][0].shape[1:] <= (m, n)
    # a mutant that only drops points (no apex, pose only) can only free cells
    assert (mutants["no apex"][0] <= mutants["no apex"][1]).all()
    assert (mutants["pose only"][0] <= mutants["pose only"][1]).all()


def test_early_arrival_plans_pass_the_papers_check_and_fail_the_repaired_one():
    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(20):
        scene = random_scene(rng)
        P = builtdr(scene, "modified")
        for path in early_arrival_plans(P, 3, rng):
            assert all(P[k][c] == 0 for k, c in enumerate(path))  # the paper's check
            assert all(max(abs(a - c), abs(b - d)) <= 1 for (a, b), (c, d) in zip(path, path[1:]))
            assert len(path) < P.shape[0] and P[len(path):, path[-1][0], path[-1][1]].any()
            assert not check_path(P, path, path[0], path[-1])[0]  # len < N: the repaired check refuses
            checked += 1
    assert checked >= 10


def test_verdict_needs_every_mutant_to_collide(capsys):
    rows = [{"scene": "s", "dt": 0.1, "variant": "modified", "samples": 10, "collisions": 0},
            {"scene": "s", "dt": 0.1, "variant": "modified, occupied cells (control)", "samples": 10,
             "collisions": 4},
            {"scene": "s", "dt": None, "variant": "mutant: segment", "samples": 10, "collisions": 0}]
    assert _soundness_verdict(rows) == 1
    assert "segment never collides" in capsys.readouterr().out
    rows[2]["collisions"] = 1
    assert _soundness_verdict(rows) == 0
    rows[0]["collisions"] = 1
    assert _soundness_verdict(rows) == 1
