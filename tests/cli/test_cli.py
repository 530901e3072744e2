"""End-to-end CLI: exit codes, JSON, SMT-LIB, user models, one-line errors."""

import json
import os
import subprocess
import sys
import textwrap

import pytest
import z3

from certiloop.cli import main


def run(*args, cwd=None):
    """Run the installed console script as a user would (no terminal: no progress bar)."""
    proc = subprocess.run([sys.executable, "-m", "certiloop.cli", *args],
                          capture_output=True, text=True, cwd=cwd, timeout=300,
                          env={**os.environ, "COLUMNS": "200"})
    return proc.returncode, proc.stdout, proc.stderr


def test_list_shows_models_and_expectations():
    code, out, _ = run("list")
    assert code == 0
    assert "sbs.ctrl1" in out and "sbs.ctrl1_broken" in out and "refuted" in out


def test_prove_proved_model_exits_0_and_writes_json(tmp_path):
    out_file = tmp_path / "r.json"
    code, out, err = run("prove", "sbs.ctrl1", "--json", str(out_file), "--jobs", "2")
    assert code == 0, err
    assert "proved" in out
    data = json.loads(out_file.read_text())
    assert data["model"] == "sbs.ctrl1" and data["verdict"] == "proved"
    assert set(data) >= {"model", "verdict", "seconds", "obligations"}
    for ob in data["obligations"]:
        assert set(ob) >= {"id", "path", "verdict", "seconds", "backend", "counterexample"}
        assert ob["verdict"] == "proved"
    assert err == ""  # piped: no progress bar


def test_prove_refuted_model_exits_1_and_prints_the_run():
    code, out, _ = run("prove", "sbs.ctrl1_broken")
    assert code == 1
    assert "counterexample run" in out and "past boundary, towards" in out
    assert "violated: py >= 0" in out


def test_json_to_stdout_for_several_models():
    code, out, _ = run("prove", "textbook.train", "textbook.water_tank_late_check", "--json", "-")
    assert code == 1
    data = json.loads(out)
    assert [d["verdict"] for d in data] == ["proved", "refuted"]
    assert data[1]["counterexample"]["trace"]


def test_smtlib_files_recheck_with_a_fresh_solver(tmp_path):
    code, _, _ = run("prove", "textbook.water_tank", "--smtlib", str(tmp_path))
    assert code == 0
    files = sorted(tmp_path.glob("*.smt2"))
    assert files
    for f in files:
        solver = z3.Solver()
        solver.from_file(str(f))
        assert solver.check() == z3.unsat, f.name  # unsat negation = valid obligation


def test_smtlib_names_archive_entries_with_slashes_and_colons(tmp_path):
    archive = tmp_path / "a.kyx"
    archive.write_text('ArchiveEntry "Family/Sub: entry"\n ProgramVariables Real x; End.\n'
                       ' Problem x >= 0 -> [x := x + 1;] x >= 0 End.\nEnd.\n')
    code, _, err = run("prove", str(archive), "--smtlib", str(tmp_path / "smt"))
    assert code == 0, err
    assert [f.name for f in (tmp_path / "smt").iterdir()] == ["Family_Sub_entry.o1.smt2"]


@pytest.mark.parametrize("args, message", [
    (["prove", "sbs.nope"], "unknown model 'sbs.nope'"),
    (["prove", "missing.py:thm"], "missing.py: no such file"),
    (["prove", "sbs.ctrl1", "--timeout", "0"], "--timeout must be a positive number"),
    (["prove", "sbs.ctrl1", "--jobs", "0"], "--jobs must be at least 1"),
    # values that used to reach the engine: "internal error" (NaN, inf as milliseconds, numpy's
    # seed) or one process per job
    (["prove", "sbs.ctrl1", "--timeout", "nan"], "--timeout must be a positive number"),
    (["prove", "sbs.ctrl1", "--timeout", "inf"], "--timeout must be a positive number"),
    (["prove", "sbs.ctrl1", "--timeout", "1e308"], "--timeout must be a positive number"),
    (["gate", "sbs.ctrl1", "--jobs", "100000"], "--jobs must be at most"),
    (["falsify", "sbs.ctrl1", "--jobs", "100000"], "--jobs must be at most"),
    (["falsify", "sbs.ctrl1", "--seed", "-1"], "--seed must be a non-negative integer"),
    (["prove", ":MODEL"], "':MODEL' names no file"),  # was " is a folder: ..., as /FILE.py:THEOREM"
    (["prove"], "the following arguments are required"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_input_is_one_line_exit_2(args, message):
    code, out, err = run(*args)
    assert code == 2
    assert message in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


USER_MODEL = textwrap.dedent("""
    from certiloop.models import Reals, Theorem, And, assign, havoc, loop, seq, test

    x, v = Reals("x v")

    def safe():
        step = seq(havoc(v), test(And(v >= 0, v <= 1)), assign(x, x + v))
        return Theorem("user.safe", x >= 0, loop(step, x >= 0), x >= 0)

    unsafe = Theorem("user.unsafe", x >= 0, loop(seq(havoc(v), assign(x, x + v)), x >= 0), x >= 0,
                     expected="refuted")
    bad_division = "not a theorem"

    def broken():
        return Theorem("user.broken", True, assign(x, 1 / v), x >= 0)
""")


def test_user_model_files(tmp_path):
    f = tmp_path / "mymodel.py"
    f.write_text(USER_MODEL)
    assert run("prove", f"{f}:safe")[0] == 0
    code, out, _ = run("prove", f"{f}:unsafe")
    assert code == 1 and "refuted" in out
    code, _, err = run("prove", f"{f}:nothing")
    assert code == 2 and "defines no theorem named 'nothing'" in err
    code, _, err = run("prove", f"{f}:bad_division")
    assert code == 2 and "not a certiloop Theorem" in err
    code, _, err = run("prove", f"{f}:broken")
    assert code == 2 and "ill-defined" in err and "1/v" in err and "Traceback" not in err


def test_syntax_error_in_user_file_names_the_line(tmp_path):
    f = tmp_path / "bad.py"
    f.write_text("x = (\n")
    code, _, err = run("prove", f"{f}:thm")
    assert code == 2 and "bad.py:" in err and "syntax error" in err


def test_main_returns_codes_in_process(capsys):
    assert main(["prove", "textbook.cart_forward", "--jobs", "1"]) == 0
    assert main(["prove", "textbook.cart_may_brake", "--jobs", "1"]) == 1
    assert main(["prove", "nope"]) == 2


def test_missing_z3_is_a_one_line_error(tmp_path):
    fake = tmp_path / "z3"
    fake.mkdir()
    (fake / "__init__.py").write_text("raise ImportError('No module named z3')\n")
    proc = subprocess.run([sys.executable, "-m", "certiloop.cli", "prove", "sbs.ctrl1"],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert proc.returncode == 2
    assert "z3 is not installed: pip install z3-solver" in proc.stderr
    assert "Traceback" not in proc.stderr


GATE_MODELS = textwrap.dedent("""
    from certiloop.models import Reals, Theorem, And, assign, havoc, loop, seq, test, ode

    x, v, y = Reals("x v y")
    # claims to be safe but is not: the gate must fail it
    wrongly_expected = Theorem("user.wrong", x >= 0, loop(seq(havoc(v), assign(x, x + v)), x >= 0),
                               x >= 0, expected="proved")
    fine = Theorem("user.fine", x >= 0, loop(seq(havoc(v), test(v >= 0), assign(x, x + v)), x >= 0),
                   x >= 0)
    # nonlinear enough that a microscopic timeout leaves it unknown
    hard = Theorem("user.hard", And(x > 1, y > 1), seq(havoc(v), test(v*v*v*x - y*y*v + x*y > 7),
                   assign(x, x * v * v + y)), x*x*x + y*y*x - v*x*y > -1000)
""")


def test_gate_passes_and_fails_as_it_should(tmp_path):
    f = tmp_path / "gm.py"
    f.write_text(GATE_MODELS)
    code, out, _ = run("gate", f"{f}:fine", "sbs.ctrl1_broken", "--no-cache")
    assert code == 0 and "2 passed, 0 failed" in out
    code, out, _ = run("gate", f"{f}:fine", f"{f}:wrongly_expected", "--json", str(tmp_path / "g.json"),
                       "--no-cache")
    assert code == 1 and "FAIL user.wrong: expected proved, but it is refuted" in out
    report = json.loads((tmp_path / "g.json").read_text())
    assert [e["passed"] for e in report] == [True, False]


def test_gate_fails_a_proof_that_became_unknown(tmp_path):
    f = tmp_path / "gm.py"
    f.write_text(GATE_MODELS)
    code, out, _ = run("gate", f"{f}:hard", "--timeout", "0.001", "--jobs", "1", "--no-cache")
    if "as expected" in out or code == 0:
        pytest.skip("z3 decided the obligation within a millisecond on this machine")
    assert code == 1 and "the proof is unknown" in out


def test_list_json_names_every_library_model(capsys):
    from certiloop.models import library

    assert main(["list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["model"] for r in rows] == library.names()
    assert {r["expected"] for r in rows} == {"proved", "refuted"}


def test_a_family_name_selects_all_its_models(capsys):
    from certiloop.models import library

    assert main(["prove", "textbook", "--jobs", "1"]) == 1  # it holds refuted designs
    out = capsys.readouterr().out
    family = [n for n in library.names() if n.startswith("textbook.")]
    assert len(family) >= 2 and all(f"{n}:" in out for n in family)


def test_an_empty_selection_is_bad_input(tmp_path, capsys):
    (tmp_path / "pyproject.toml").write_text("[tool.certiloop]\nmodels = []\n")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        assert main(["gate"]) == 2
    finally:
        os.chdir(cwd)
    assert "no model selected" in capsys.readouterr().err


def test_a_model_file_imports_its_sibling_module(tmp_path):
    (tmp_path / "limits.py").write_text("LIMIT = 5\n")
    (tmp_path / "m.py").write_text(textwrap.dedent("""
        from limits import LIMIT
        from certiloop.models import Reals, Theorem, assign
        x, y = Reals("x y")
        t = Theorem("u.sibling", x >= LIMIT, assign(y, x), y >= LIMIT)
    """))
    assert main(["prove", f"{tmp_path / 'm.py'}:t", "--jobs", "1"]) == 0


def test_the_command_collects_garbage_less_often_and_restores_the_setting(monkeypatch):
    """The CLI raises the cyclic collector's threshold for its run (forked workers inherit
    it) and puts the caller's setting back, for in-process callers such as this test."""
    import gc
    import importlib

    from certiloop.cli import guards

    cli_main = importlib.import_module("certiloop.cli.main")

    seen = []
    monkeypatch.setattr(cli_main, "_main", lambda argv: seen.append(gc.get_threshold()) or 0)
    before = gc.get_threshold()
    assert main(["list"]) == 0
    assert seen == [guards.GC_THRESHOLDS] and gc.get_threshold() == before
