"""What a user sees: tables readable at 80 columns, progress only on a terminal, --quiet and
--verbose, "rule failed" instead of "refuted" for a rule that did not apply, output paths
checked before any work, Ctrl-C, and where hypothesis keeps its files."""

import io
import json
import os
import pty
import select
import signal
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ET

import pytest
from rich.console import Console

from certiloop.api import gate_run as gate_module
from certiloop.cli import main, ui
from certiloop.cli.gate_view import show_gate
from certiloop.models import library
from certiloop.proofs.core.vcgen import generate

NON_POLYNOMIAL = textwrap.dedent("""
    from certiloop.models import And, Reals, Theorem, assign, ode

    x, t = Reals("x t")
    # a rotation has no polynomial solution: without invariants= dW applies, and it fails
    # (x <= 1 holds, by x^2 + t^2 = 1, which no automatic candidate gives)
    square = Theorem("np.square", And(x == 1, t == 0), ode({x: t, t: -x}), x <= 1)
    square_inv = Theorem("np.square_inv", And(x >= 1, t == 0),
                         ode({x: x * x, t: 1}, t <= 1, invariants=[x >= 1]), x >= 1)
    # true (x = 1/(1/x0 + t) >= 1/2 while t <= 1), but the annotation is no invariant and the
    # guarantee is none either (x' = -x^2 has no sign, the cofactor leaves -1/4 >= 0)
    bad_inv = Theorem("np.bad_inv", And(x >= 1, t == 0),
                      ode({x: -x * x, t: 1}, t <= 1, invariants=[x >= 1]), x >= 0.5)
    # straight-line and false: a genuine counterexample to its one obligation
    step_down = Theorem("np.step_down", x >= 0, assign(x, x - 1), x >= 0)
""")


@pytest.fixture
def narrow(monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")


@pytest.fixture
def models_file(tmp_path):
    f = tmp_path / "np_models.py"
    f.write_text(NON_POLYNOMIAL)
    return f


def lines_of(text: str) -> list[str]:
    return text.splitlines()


def assert_fits(text: str, width: int = 80) -> None:
    too_wide = [line for line in lines_of(text) if len(line) > width]
    assert not too_wide, too_wide


def has_whole(text: str, word: str) -> bool:
    return any(word in line for line in lines_of(text))


# --------------------------------------------------------------------------- 80 columns


def _entry(name, expected, verdict, passed=True, **extra):
    obligations = [{"id": "o1", "path": "loop step / ODE dW / invariant preserved",
                    "verdict": "proved" if passed else "refuted", "rule": "dW", "reason": "",
                    "seconds": 0.1}]
    falsify = {"verdict": "refuted" if expected == "refuted" else "no counterexample", "examples": 300}
    replay = {"violated": True, "message": ""} if verdict == "refuted" else None
    checked = f"accepted: {name}" if verdict == "proved" else None
    return gate_module.GateEntry(name, expected, verdict, 1.5, obligations, falsify=falsify, replay=replay,
                                 nonblocking={"verdict": "proved"}, checked=checked, **extra)


def render_gate(entries, width, level=ui.NORMAL):
    out = Console(file=io.StringIO(), width=width)
    show_gate(out, entries, cross_check=False, level=level, tail=" (1.0 s)")
    return out.file.getvalue()


def test_gate_table_fits_80_columns_and_keeps_names_and_verdicts_whole():
    longest = max(library.names(), key=len)
    entries = [_entry(longest, "proved", "proved"), _entry("sbs.ctrl1_broken", "refuted", "refuted"),
               _entry("user.wrong", "proved", "unknown", passed=False, reason="1 obligation not proved")]
    text = render_gate(entries, 80)
    assert_fits(text)
    for e in entries:
        assert has_whole(text, e.model) and has_whole(text, f"{e.verdict} ")
    assert "falsifier" not in text.splitlines()[1]  # folded: the details are under the failure
    assert has_whole(text, "user.wrong: expected: proved; obligations proved: 0/1; step runs: proved")
    wide = render_gate(entries, 200)
    assert "falsifier" in wide and "replay" in wide and "kernel" in wide  # every column fits


def test_a_name_too_long_for_any_table_gets_a_line_of_its_own():
    name = "user." + "very_long_model_name_" * 4
    text = render_gate([_entry(name, "proved", "proved")], 80)
    assert has_whole(text, name) and has_whole(text, "PASS")
    assert all(len(line) <= 80 for line in lines_of(text) if name not in line)


def test_prove_at_80_columns(narrow, capsys, models_file):
    assert main(["prove", "sbs.ctrl1", f"{models_file}:square", "--jobs", "1"]) == 1
    out = capsys.readouterr().out
    assert_fits(out)
    for words in ("sbs.ctrl1: proved", "np.square: unknown", "rule failed", "1 of 2 models proved"):
        assert has_whole(out, words), words


def test_list_at_80_columns(narrow, capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert_fits(out)
    for name in library.names():
        assert any(line.split()[:1] == [name] for line in lines_of(out)), name


def test_falsify_at_80_columns(narrow, capsys):
    assert main(["falsify", "textbook.cart_may_brake", "--max-examples", "30", "--database", "none"]) == 1
    out = capsys.readouterr().out
    assert_fits(out)
    assert has_whole(out, "textbook.cart_may_brake: counterexample")
    assert has_whole(out, "1 of 1 model with a violating run")


def test_piped_output_has_no_ansi_codes_no_box_drawing_and_no_progress():
    proc = subprocess.run([sys.executable, "-m", "certiloop.cli", "prove", "textbook.cart_forward",
                           "--jobs", "1"], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "COLUMNS": "80"})
    assert proc.returncode == 0
    assert "\x1b[" not in proc.stdout and proc.stderr == ""
    assert not any(ch in proc.stdout for ch in "┏━│└╇")


# --------------------------------------------------------------------------- rule failed


def test_obligations_remember_the_incomplete_rule_they_depend_on(models_file):
    from certiloop.api.loading import load

    rules = {name: [o.rule for o in generate(load(f"{models_file}:{name}"))]
             for name in ("square", "bad_inv", "step_down")}
    assert rules["square"] == ["dW"]
    assert rules["bad_inv"] == ["dI-init", "dI", "dC"]
    assert rules["step_down"] == [""]
    loops = {o.rule for o in generate(library.get("sbs.ctrl1"))}
    assert loops <= {"loop-invariant", "loop-init", "guarantee-as-invariant", "dW", "dI", "dC", "dI-init", ""}


def test_a_rule_that_fails_is_not_called_refuted(capsys, models_file, tmp_path):
    report = tmp_path / "r.json"
    assert main(["prove", f"{models_file}:square", "--jobs", "1", "--json", str(report)]) == 1
    out = capsys.readouterr().out
    row = next(line for line in lines_of(out) if line.strip().startswith("o1 ") and "ODE dW" in line)
    assert "rule failed" in row and "refuted" not in row
    assert "refuted" not in out.replace("expected proved", "")
    text = " ".join(out.split())  # the console wraps long lines
    assert "ode(..., invariants=[...]); kyx: `{x' = ...}@invariant(...)`" in text
    data = json.loads(report.read_text())  # what counts as proved is unchanged
    assert data["verdict"] == "unknown"
    assert data["obligations"][0]["verdict"] == "refuted" and data["obligations"][0]["rule"] == "dW"


def test_a_failed_differential_invariant_is_a_failed_rule_and_a_good_one_proves(capsys, models_file):
    assert main(["prove", f"{models_file}:bad_inv", "--jobs", "1"]) == 1
    out = capsys.readouterr().out
    assert "ODE dI 1 / derivative condition: rule failed" in out and "derivative condition fails" in out
    assert main(["prove", f"{models_file}:square_inv", "--jobs", "1"]) == 0


def test_a_genuine_counterexample_is_still_refuted(capsys, models_file):
    assert main(["prove", f"{models_file}:step_down", "--jobs", "1"]) == 1
    out = capsys.readouterr().out
    assert "o1 postcondition: refuted" in out and "rule failed" not in out


# --------------------------------------------------------------------------- --quiet / --verbose


def test_quiet_prove_prints_only_failures_and_the_summary(capsys, models_file):
    assert main(["prove", "textbook.cart_forward", f"{models_file}:square", "--jobs", "1", "-q"]) == 1
    out = capsys.readouterr().out
    assert "cart_forward" not in out  # proved: not a failure
    assert "np.square: unknown" in out and "rule failed" in out
    assert lines_of(out)[-1].startswith("1 of 2 models proved")
    assert "path in the proof tree" not in out  # no table


def test_verbose_prove_details_every_obligation(capsys):
    assert main(["prove", "textbook.cart_forward", "--jobs", "1", "-v"]) == 0
    out = capsys.readouterr().out
    n = len(generate(library.get("textbook.cart_forward")))
    assert sum(": proved — by " in line for line in lines_of(out)) == n


def test_quiet_gate_has_no_table(capsys, tmp_path, models_file):
    code = main(["gate", "textbook.cart_forward", f"{models_file}:square", "--no-cache", "--jobs", "1",
                 "--falsify-examples", "10", "-q"])
    out = capsys.readouterr().out
    assert code == 1
    assert "certiloop gate" not in out and "textbook.cart_forward" not in out
    assert "FAIL np.square" in out and lines_of(out)[-1].startswith("1 passed, 1 failed")


def test_quiet_falsify_and_extract(capsys, tmp_path):
    assert main(["falsify", "textbook.cart_forward", "--max-examples", "10", "--database", "none", "-q"]) == 0
    out = lines_of(capsys.readouterr().out)
    assert len(out) == 1 and out[0].startswith("0 of 1 model with a violating run")
    target = tmp_path / "k.py"
    assert main(["extract", "sbs.ctrl1", "-o", str(target), "--no-cache", "--jobs", "1", "-q"]) == 0
    assert target.is_file() and capsys.readouterr().err == ""


def test_quiet_and_verbose_together_is_bad_input(capsys):
    assert main(["gate", "-q", "-v"]) == 2
    assert "not allowed with" in capsys.readouterr().err


# --------------------------------------------------------------------------- output paths


@pytest.fixture
def no_work(monkeypatch):
    """Any proof or search fails the test: the output path must be refused before work starts."""
    from certiloop.falsify import search
    from certiloop.proofs.engine.prover import Prover

    monkeypatch.setattr(Prover, "prove", lambda *a, **k: pytest.fail("work started"))
    monkeypatch.setattr(search, "falsify", lambda *a, **k: pytest.fail("work started"))


@pytest.mark.parametrize("command, flag", [
    (["prove", "sbs.ctrl1"], "--json"),
    (["falsify", "sbs.ctrl1"], "--json"),
    (["falsify", "sbs.ctrl1"], "--plot"),
    (["gate", "sbs.ctrl1"], "--json"),
    (["gate", "sbs.ctrl1"], "--junit"),
    (["gate", "sbs.ctrl1"], "--markdown"),
    (["extract", "sbs.ctrl1"], "-o"),
])
@pytest.mark.parametrize("problem", ["missing folder", "a folder"])
def test_output_files_are_checked_before_any_work(command, flag, problem, tmp_path, capsys, no_work):
    name = "out.png" if flag == "--plot" else "out.txt"
    target = tmp_path / "nowhere" / name if problem == "missing folder" else tmp_path
    if problem == "a folder" and flag == "--plot":
        target = tmp_path / "dir.png"
        target.mkdir()
    assert main([*command, flag, str(target)]) == 2
    err = capsys.readouterr().err
    shown = "--output" if flag == "-o" else flag
    assert len(err.strip().splitlines()) == 1 and f"{shown} {target}" in err
    assert ("does not exist" if problem == "missing folder" else "is a folder") in err


@pytest.mark.parametrize("command, flag", [
    (["prove", "sbs.ctrl1"], "--smtlib"),
    (["gate", "sbs.ctrl1"], "--cache"),
    (["extract", "sbs.ctrl1"], "--cache"),
    (["falsify", "sbs.ctrl1"], "--database"),
])
def test_output_folders_are_checked_before_any_work(command, flag, tmp_path, capsys, no_work):
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    assert main([*command, flag, str(a_file / "sub")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and f"{flag} {a_file / 'sub'}" in err
    assert "is a file, not a folder" in err


# --------------------------------------------------------------------------- bad input classes


BAD_MODELS = textwrap.dedent("""
    from certiloop.models import Reals, Theorem, assign

    x, y = Reals("x y")

    def chained():
        return Theorem("b.chained", 0 <= x <= 1, assign(y, x), y >= 0)

    def writes_constant():
        return Theorem("b.const", x >= 0, assign(x, 1), x >= 0, constants=(x,))

    def needs_arguments(a):
        return None

    def raises():
        raise RuntimeError("boom")
""")


@pytest.mark.parametrize("args, message", [
    # flags
    (["prove", "sbs.ctrl1", "--jobs", "x"], "invalid int value: 'x' (see `certiloop prove --help`)"),
    (["prove", "sbs.ctrl1", "--bogus"], "unrecognized arguments: --bogus"),
    (["gate", "--falsify-examples", "0"], "--falsify-examples must be at least 1"),
    (["falsify", "sbs.ctrl1", "--plot", "x.jpg"], "give a name ending in .png"),
    # names
    (["prove", "sbs.ctrl"], "did you mean"),
    (["extract", "nothing"], "`certiloop list` shows them"),
    # files
    (["prove", "{dir}:thm"], "is a folder: name a Python file in it"),
    (["prove", "{dir}/notes.txt:thm"], "not a Python file"),
    (["prove", "{dir}/bad.py:missing"], "defines no theorem named 'missing'"),
    (["prove", "{dir}/bad.py"], "name the theorem too"),
    # malformed models
    (["prove", "{dir}/bad.py:chained"], "write `And(0 <= x, x <= D)` instead"),
    (["prove", "{dir}/bad.py:writes_constant"], "declared constant but the program assigns to it"),
    (["prove", "{dir}/bad.py:needs_arguments"], "a function of no arguments that returns one"),
    (["prove", "{dir}/bad.py:raises"], "building the theorem failed: RuntimeError: boom"),
])
def test_each_class_of_bad_input_gets_one_line_naming_the_fix(args, message, tmp_path, capsys):
    (tmp_path / "bad.py").write_text(BAD_MODELS)
    (tmp_path / "notes.txt").write_text("")
    assert main([a.format(dir=tmp_path) for a in args]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and message in err and "Traceback" not in err


# --------------------------------------------------------------------------- Ctrl-C, .hypothesis


def _interrupt_when(marker: str, args: list[str], cwd, timeout: float = 240) -> tuple[int, str]:
    """Run the CLI with stderr on a terminal (so it shows progress), send Ctrl-C to its process
    group once `marker` appears there, and return its exit code and what it printed."""
    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "certiloop.cli", *args], cwd=cwd,
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=slave,
                            start_new_session=True)
    os.close(slave)
    seen, sent, deadline = b"", False, time.monotonic() + timeout
    try:
        while proc.poll() is None and time.monotonic() < deadline:
            if select.select([master], [], [], 0.1)[0]:
                try:
                    seen += os.read(master, 65536)
                except OSError:
                    break
            if not sent and marker.encode() in seen:
                os.killpg(proc.pid, signal.SIGINT)
                sent = True
        code = proc.wait(timeout=30)
        while select.select([master], [], [], 0.1)[0]:
            try:
                seen += os.read(master, 65536)
            except OSError:
                break
    finally:
        os.close(master)
        if proc.poll() is None:
            proc.kill()
    assert sent, seen.decode(errors="replace")[-500:]
    return code, seen.decode(errors="replace")


def test_ctrl_c_during_the_gate_exits_130_and_keeps_partial_reports(tmp_path):
    args = ["gate", "textbook.cart_forward", "sbs.ctrl1", "textbook.water_tank", "--no-cache", "--jobs", "2",
            "--json", "g.json", "--junit", "g.xml", "--markdown", "g.md"]
    code, err = _interrupt_when("2/3 models", args, tmp_path)
    assert code == 130
    assert err.strip().splitlines()[-1].strip().endswith("certiloop: interrupted")
    assert "Traceback" not in err
    report = json.loads((tmp_path / "g.json").read_text())
    assert report["partial"] is True and report["selected"] == 3
    assert [e["model"] for e in report["results"]] == ["textbook.cart_forward"]
    suites = ET.parse(tmp_path / "g.xml").getroot()
    assert suites.get("partial") == "true" and suites[0].get("name") == "textbook.cart_forward"
    assert "interrupted" in (tmp_path / "g.md").read_text()


def test_ctrl_c_during_prove_keeps_the_finished_models_json(tmp_path):
    args = ["prove", "textbook.cart_forward", "sbs.ctrl1", "sbs.ctrl2", "--jobs", "1", "--json", "p.json"]
    code, err = _interrupt_when("3/3 models", args, tmp_path)
    assert code == 130 and "Traceback" not in err
    report = json.loads((tmp_path / "p.json").read_text())
    assert report["partial"] is True and report["finished"] == 2


def test_falsify_keeps_hypothesis_files_under_certiloop(tmp_path):
    # a model outside the batch phase's fragment, so that hypothesis (and its database) runs
    proc = subprocess.run([sys.executable, "-m", "certiloop.cli", "falsify",
                           "cfmpa.early_arrival", "--max-examples", "20"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120,
                          env={k: v for k, v in os.environ.items() if k != "HYPOTHESIS_STORAGE_DIRECTORY"})
    assert proc.returncode == 1, proc.stderr
    assert not (tmp_path / ".hypothesis").exists()
    assert (tmp_path / ".certiloop" / "hypothesis").is_dir()


def test_no_fix_is_suggested_when_a_run_shows_the_design_is_unsafe(capsys):
    assert main(["prove", "sbs.ctrl1_broken", "--jobs", "1"]) == 1
    out = capsys.readouterr().out
    assert "sbs.ctrl1_broken: refuted" in out and "rule failed" in out and "hint:" not in out
