"""The gate reports `proved` only for proofs the separate proof checker accepted, and caches the
certificate it accepted beside the verdict."""

import json
import subprocess
import sys

from certiloop.api import gate_run as gate_module
from certiloop.cli import main
from certiloop.proofs.engine import certificate_writer

MODEL = "textbook.train"


def gate(tmp_path, *extra):
    return main(["gate", MODEL, "--cache", str(tmp_path / "cache"), "--jobs", "1",
                 "--falsify-examples", "20", "--json", str(tmp_path / "gate.json"), *extra])


def entry(tmp_path):
    (only,) = json.loads((tmp_path / "gate.json").read_text())
    return only


def test_a_cold_gate_checks_the_proof_and_caches_the_certificate_it_accepted(tmp_path):
    assert gate(tmp_path) == 0
    row = entry(tmp_path)
    assert row["verdict"] == "proved" and row["checked"].startswith(f"accepted: {MODEL} (")
    kept = [json.loads(p.read_text())["payload"] for p in (tmp_path / "cache").glob("*.json")]
    certificates = [p for p in kept if isinstance(p, dict) and "leaves" in p]
    assert len(certificates) == 1 and certificates[0]["theorem"]["name"] == MODEL
    # the cached certificate stands on its own: `check-proof` in a fresh process accepts it
    path = tmp_path / "kept.json"
    path.write_text(json.dumps(certificates[0]))
    done = subprocess.run([sys.executable, "-m", "certiloop.cli", "check-proof", str(path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr


def test_a_warm_gate_whose_certificate_is_gone_proves_again(tmp_path, monkeypatch):
    assert gate(tmp_path) == 0
    kept = (tmp_path / "cache").glob("*.json")
    gone = [p for p in kept if "leaves" in json.loads(p.read_text())["payload"]]
    assert len(gone) == 1  # the certificate; the verdict stays
    gone[0].unlink()
    seen = []
    real = gate_module.check_model
    monkeypatch.setattr(gate_module, "check_model", lambda *a: seen.append(a[0].name) or real(*a))
    assert gate(tmp_path) == 0
    assert seen == [MODEL] and entry(tmp_path)["checked"].startswith("accepted")


def test_a_proof_the_checker_rejects_fails_the_gate_and_is_not_cached(tmp_path, monkeypatch):
    """One leaf of the certificate changed (a `<=` made `<`, a different claim): the prover still
    says proved, the checker must not accept it, and the gate must not pass or remember it."""
    real = certificate_writer.certificate

    def tampered(*args, **kwargs):
        doc = real(*args, **kwargs)
        leaf = next(leaf for leaf in doc["leaves"] if "(<= " in leaf["smtlib"])
        leaf["smtlib"] = leaf["smtlib"].replace("(<= ", "(< ", 1)
        return doc

    monkeypatch.setattr(certificate_writer, "certificate", tampered)
    assert gate(tmp_path) == 1
    row = entry(tmp_path)
    assert row["verdict"] == "unknown" and not row["passed"]
    assert "proof checker did not accept its certificate: rejected" in row["message"]
    monkeypatch.setattr(certificate_writer, "certificate", real)
    seen = []
    real_check = gate_module.check_model
    monkeypatch.setattr(gate_module, "check_model", lambda *a: seen.append(a[0].name) or real_check(*a))
    assert gate(tmp_path) == 0  # nothing of the rejected proof was kept: proved and checked afresh
    assert seen == [MODEL] and entry(tmp_path)["checked"].startswith("accepted")


def test_an_entry_says_proved_only_with_the_checkers_acceptance_recorded():
    def entry(checked):
        return gate_module.GateEntry("m", "proved", "proved", 0.1, [], checked=checked,
                                     falsify={"verdict": "no counterexample"})

    assert entry("accepted: m (0123): assumptions -> [program] guarantee, 3 leaves").passed
    for missing in (None, "", "rejected: leaf o1 (postcondition): z3 says sat, not unsat"):
        assert not entry(missing).passed
        assert "acceptance of its certificate is not recorded" in entry(missing).message
