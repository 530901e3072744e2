"""`certiloop --help` and `certiloop list` start without the prover's and simulators' heavy
modules, and `list`'s stored output is what listing the library afresh prints."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from certiloop.cli import list_cache
from certiloop.cli.main import main

HEAVY = ("sympy", "z3", "numpy", "scipy", "cvxpy", "hypothesis", "lark")


def imported_after(argv: list[str], cache) -> dict:
    """The heavy top-level packages in sys.modules after main(argv), in a fresh interpreter."""
    probe = textwrap.dedent(f"""
        import contextlib, io, json, sys
        from certiloop.cli.main import main
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                code = main({argv!r})
        except SystemExit as exc:   # --help
            code = exc.code
        heavy = sorted({{m.split(".")[0] for m in sys.modules}} & set({HEAVY!r}))
        print(json.dumps({{"code": code, "heavy": heavy, "rich": "rich" in sys.modules}}))
    """)
    env = {**os.environ, "CERTILOOP_CACHE": str(cache)}
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.splitlines()[-1])


@pytest.mark.parametrize("argv", [["list"], ["list", "--json"], ["--help"], ["prove", "--help"]])
def test_help_and_list_import_no_prover_or_simulator(argv, tmp_path):
    first = imported_after(argv, tmp_path)          # nothing stored yet: the models are built
    again = imported_after(argv, tmp_path)          # the stored listing
    for seen in (first, again):
        assert seen["code"] == 0 and seen["heavy"] == [], seen
    if argv[0] == "list":
        assert not again["rich"]                    # printing the stored text needs no console


def library_rows() -> list[dict]:
    """The witness: every library model built here, its own name, expectation and text."""
    from certiloop.models import library

    rows = []
    for name in library.names():
        t = library.get(name)
        rows.append({"model": t.name, "expected": t.expected, "description": t.description})
    return rows


def test_the_stored_listing_is_the_library(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CERTILOOP_CACHE", str(tmp_path))
    monkeypatch.chdir(tmp_path)                      # no project file: the whole library
    outputs = []
    for _ in range(2):                               # built and stored, then read back
        assert main(["list", "--json"]) == 0
        outputs.append(capsys.readouterr().out)
    assert len(list((tmp_path / "list").glob("*.json"))) == 1
    assert outputs[0] == outputs[1]
    assert json.loads(outputs[1]) == library_rows()


def test_the_table_follows_the_terminal_width(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CERTILOOP_CACHE", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    widths = {}
    for columns in ("60", "150", "60"):
        monkeypatch.setenv("COLUMNS", columns)
        assert main(["list"]) == 0
        widths.setdefault(columns, []).append(max(len(line) for line in capsys.readouterr().out.splitlines()))
    assert widths["60"][0] == widths["60"][1] <= 60 < widths["150"][0] <= 150


def test_an_untrustworthy_entry_is_ignored(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CERTILOOP_CACHE", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    key = list_cache.key(True, ["textbook"])
    (tmp_path / "list").mkdir()
    entry = tmp_path / "list" / f"{key}.json"
    entry.write_text(json.dumps({"key": key, "checksum": "0" * 64, "text": "[]\n"}))   # checksum wrong
    assert main(["list", "--json", "textbook"]) == 0
    assert [r["model"] for r in json.loads(capsys.readouterr().out)] == [
        r["model"] for r in library_rows() if r["model"].startswith("textbook.")]
    entry.write_text("{not json")
    assert main(["list", "--json", "textbook"]) == 0
    assert len(json.loads(capsys.readouterr().out)) >= 2


def test_the_key_follows_sources_project_and_terminal(tmp_path, monkeypatch):
    package = tmp_path / "pkg_for_list_key"
    package.mkdir()
    (package / "__init__.py").write_text("X = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(list_cache, "PACKAGES", ("pkg_for_list_key",))
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "80")
    base = list_cache.key(False, None)
    assert list_cache.key(False, None) == base
    (package / "__init__.py").write_text("X = 22\n")                       # a source edited
    edited = list_cache.key(False, None)
    assert edited != base
    (tmp_path / "pyproject.toml").write_text('[tool.certiloop]\nmodels = ["sbs"]\n')
    project = list_cache.key(False, None)
    assert project != edited
    monkeypatch.setenv("COLUMNS", "81")
    assert list_cache.key(False, None) != project
    assert list_cache.key(False, ["sbs"]) != list_cache.key(False, ["rcm"])


def test_an_archive_listing_is_not_stored(tmp_path, monkeypatch, capsys):
    from pathlib import Path

    archive = Path(__file__).resolve().parents[1] / "fixtures" / "kyx_legacy.kyx"
    monkeypatch.setenv("CERTILOOP_CACHE", str(tmp_path))
    assert main(["list", "--json", str(archive)]) == 0
    assert json.loads(capsys.readouterr().out)
    assert not (tmp_path / "list").exists() or not list((tmp_path / "list").glob("*.json"))
