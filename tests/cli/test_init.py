"""`certiloop init` starts a project without overwriting anything; `certiloop list` reads the
project's `[tool.certiloop] models` as `gate` does."""

import json
import tomllib

import pytest

from certiloop.cli import main
from certiloop.models import library


@pytest.fixture
def folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_init_in_an_empty_folder_writes_the_three_files(folder, capsys):
    assert main(["init"]) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["drone_models.py", "pyproject.toml", "test_drone.py"]
    config = tomllib.loads((folder / "pyproject.toml").read_text())
    assert config["tool"]["certiloop"]["models"] == ["drone_models.py:altitude_limiter",
                                                    "drone_models.py:no_reaction_time"]
    out = capsys.readouterr().out
    assert "next steps" in out and "certiloop gate" in out


def test_init_appends_to_an_existing_pyproject_and_keeps_it(folder):
    before = '[project]\nname = "mine"\n\n[tool.ruff]\nline-length = 99'  # no final newline
    (folder / "pyproject.toml").write_text(before)
    assert main(["init"]) == 0
    after = (folder / "pyproject.toml").read_text()
    assert after.startswith(before)
    config = tomllib.loads(after)
    assert config["project"]["name"] == "mine" and config["tool"]["ruff"] == {"line-length": 99}
    assert len(config["tool"]["certiloop"]["models"]) == 2


def test_init_never_clobbers_a_section_or_a_file(folder, capsys):
    mine = '[tool.certiloop]\nmodels = ["m.py:x"]\n'
    (folder / "pyproject.toml").write_text(mine)
    assert main(["init"]) == 2
    err = capsys.readouterr().err.strip()
    assert "already has a [tool.certiloop] section" in err and len(err.splitlines()) == 1
    assert (folder / "pyproject.toml").read_text() == mine
    assert not (folder / "drone_models.py").exists()

    (folder / "pyproject.toml").unlink()
    (folder / "test_drone.py").write_text("# mine\n")
    assert main(["init"]) == 2
    assert "test_drone.py already exists" in capsys.readouterr().err
    assert (folder / "test_drone.py").read_text() == "# mine\n"
    assert not (folder / "pyproject.toml").exists()


def test_init_refuses_a_broken_pyproject_in_one_line(folder, capsys):
    (folder / "pyproject.toml").write_text("[tool\n")
    assert main(["init"]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_list_honours_the_project_models(folder, capsys):
    assert main(["init"]) == 0
    capsys.readouterr()
    assert main(["list", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    # the example model's own text says which verdict it expects
    assert [(m["model"], m["expected"]) for m in listed] == [("drone.altitude_limiter", "proved"),
                                                            ("drone.no_reaction_time", "refuted")]


def test_list_without_a_project_lists_the_library(folder, capsys):
    assert main(["list", "--json"]) == 0
    assert [m["model"] for m in json.loads(capsys.readouterr().out)] == library.names()


def test_the_example_project_proves_and_refutes_as_it_says(folder, capsys):
    assert main(["init"]) == 0
    assert main(["gate", "--no-cache", "--jobs", "1", "--falsify-examples", "50", "-q"]) == 0
    assert "2 passed, 0 failed" in capsys.readouterr().out
