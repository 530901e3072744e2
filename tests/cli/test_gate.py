"""The CI gate: cache, reports, kernel drift, project configuration, Dask executor."""

import json
import xml.etree.ElementTree as ET

import pytest

from certiloop.api import gate_run as gate_module
from certiloop.api.loading import project_models
from certiloop.cli import main
from certiloop.models import library
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine.cache import Cache
from certiloop.proofs.engine.prover import Prover

SMALL = ["sbs.ctrl1", "sbs.ctrl1_broken", "textbook.water_tank_late_check"]


def gate(tmp_path, *extra):
    return main(["gate", *SMALL, "--cache", str(tmp_path / "cache"), "--jobs", "2",
                 *extra])


def test_warm_gate_reuses_verdicts_and_reports_the_same(tmp_path, capsys, monkeypatch):
    assert gate(tmp_path, "--json", str(tmp_path / "cold.json")) == 0
    calls = []
    monkeypatch.setattr(gate_module, "check_model", lambda *a: calls.append(a) or pytest.fail("re-proved"))
    monkeypatch.setattr(gate_module, "_import_for_workers", lambda: pytest.fail("warm: imported"))
    assert gate(tmp_path, "--json", str(tmp_path / "warm.json")) == 0
    assert "3 from the cache" in capsys.readouterr().out
    cold, warm = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("cold", "warm"))
    assert [(e["model"], e["verdict"], e["passed"]) for e in cold] == \
        [(e["model"], e["verdict"], e["passed"]) for e in warm]
    assert all(e["cached"] for e in warm)


def test_a_cold_gate_imports_the_workers_modules_before_forking_them(monkeypatch):
    """Forked workers inherit what the main process imported: the falsifier's modules are
    imported before the prover (and its worker pool) starts, and all of them exist."""
    events = []
    real = gate_module._import_for_workers
    monkeypatch.setattr(gate_module, "_import_for_workers", lambda: events.append("import") or real())

    def start_prover():
        events.append("start")
        raise KeyboardInterrupt  # stop before any work

    with pytest.raises(KeyboardInterrupt):
        gate_module.run_gate([library.get("sbs.ctrl1")], start_prover, 1000, gate_module.GateOptions())
    assert events == ["import", "start"]


def test_corrupted_or_foreign_cache_entries_are_ignored(tmp_path):
    cache = Cache(tmp_path)
    key = cache.key("gate", "model text")
    cache.put(key, {"verdict": "proved"})
    assert Cache(tmp_path).get(key) == {"verdict": "proved"}
    entry = tmp_path / f"{key}.json"
    data = json.loads(entry.read_text())
    data["payload"]["verdict"] = "refuted"  # tampered: checksum no longer matches
    entry.write_text(json.dumps(data))
    assert Cache(tmp_path).get(key) is None
    data = {**json.loads(entry.read_text()), "versions": {"certiloop": "0.0.0"}}  # another version
    entry.write_text(json.dumps(data))
    assert Cache(tmp_path).get(key) is None
    entry.write_text("{not json")
    fresh = Cache(tmp_path)
    assert fresh.get(key) is None and fresh.ignored == 1


def test_no_cache_reproves(tmp_path, monkeypatch):
    assert gate(tmp_path) == 0
    seen = []
    real = gate_module.check_model
    monkeypatch.setattr(gate_module, "check_model", lambda *a: seen.append(a[0].name) or real(*a))
    assert gate(tmp_path, "--no-cache") == 0
    assert seen == SMALL


def test_junit_and_markdown_reports(tmp_path):
    junit, md = tmp_path / "j.xml", tmp_path / "summary.md"
    assert gate(tmp_path, "--junit", str(junit), "--markdown", str(md)) == 0
    root = ET.parse(junit).getroot()
    assert [s.get("name") for s in root] == SMALL
    ctrl1 = root[0]
    obligations = len(generate(library.get("sbs.ctrl1")))  # safety and well-definedness
    assert len(ctrl1) == 1 + obligations and all(c.find("failure") is None for c in ctrl1)
    assert any(c.find("skipped") is not None for c in root[1])  # refuted model: failed branches expected
    text = md.read_text()
    assert "3/3 models met their expected verdict" in text and "| `sbs.ctrl1` | proved | proved |" in text


def test_kernel_drift_fails_the_gate(tmp_path, capsys, monkeypatch):
    import certiloop.kernel.extract as extract

    monkeypatch.setattr(extract, "shipped_drift", lambda model: "ctrl2.py differs from a fresh extraction")
    monkeypatch.setattr(gate_module, "check_model", _stub_passing)
    monkeypatch.setattr(gate_module, "falsify_task", _no_falsifier)
    assert main(["gate", "sbs.ctrl2", "--no-cache"]) == 1
    assert "ctrl2.py differs" in capsys.readouterr().out


def _no_falsifier(theorem, opts):
    return None


def _stub_passing(theorem, prover, opts, falsifier=None):
    return gate_module.GateEntry(theorem.name, "proved", "proved", 0.0, [],
                                 checked=f"accepted: {theorem.name}",
                                 falsify={"verdict": "no counterexample"},
                                 kernel=gate_module._kernel_check(theorem))


def test_project_models_come_from_pyproject(tmp_path):
    (tmp_path / "pyproject.toml").write_text('[tool.certiloop]\nmodels = ["sbs.ctrl1", "m.py:thm"]\n')
    assert project_models(tmp_path) == ["sbs.ctrl1", "m.py:thm"]
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "x"\n')
    assert "sbs.ctrl2" in project_models(tmp_path)


@pytest.mark.slow
def test_dask_executor_gives_the_same_verdicts():
    distributed = pytest.importorskip("distributed")
    from certiloop.models import library

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None, host="127.0.0.1") as cluster:
        with Prover(executor=cluster.scheduler_address) as remote:
            far = [remote.prove(library.get(m)) for m in ("sbs.ctrl2_2d", "sbs.ctrl1_broken")]
    with Prover(jobs=2) as local:
        near = [local.prove(library.get(m)) for m in ("sbs.ctrl2_2d", "sbs.ctrl1_broken")]
    for a, b in zip(far, near):
        assert a.verdict == b.verdict
        assert [(o.path, o.verdict) for o in a.obligations] == [(o.path, o.verdict) for o in b.obligations]


def test_unreachable_scheduler_is_a_one_line_error(capsys):
    pytest.importorskip("distributed")
    assert main(["prove", "sbs.ctrl1", "--executor", "tcp://127.0.0.1:9"]) == 2
    assert capsys.readouterr().err.count("\n") == 1
