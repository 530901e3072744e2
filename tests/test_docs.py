"""Every code block of the README and the documentation runs, so an example cannot rot.

Per page, in a fresh temporary folder, the blocks run in the order they appear:

* a block right after `<!-- file: PATH -->` is written to PATH (```python ones are compiled,
  ```toml parsed, ```yaml parsed when PyYAML is there) — the files a later block or command uses;
* any other ```python block is executed (one namespace per page, the folder on sys.path), and
  each `test_*` function it defines is called;
* each `$ certiloop ...` line of a ```console block is run as a command, and must exit with the
  code of the `<!-- exit: N -->` line before the block (0 if none). Its output in the page is an
  excerpt (timings vary), so only the exit code is compared. Other `$` lines (pip, pytest) and
  ```sh blocks are installation steps, not run here.

A block after `<!-- docs-test: requires MODULE -->` runs only where MODULE imports (an optional
extra, such as OMPL for planning); one after `<!-- docs-test: skip REASON -->` never runs — use
it only where running is impossible (a network service).
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^```(\w*)\s*$")
MARKER = re.compile(r"^<!--\s*(file|exit|docs-test):\s*(.*?)\s*-->\s*$")


@dataclass
class Block:
    page: Path
    line: int
    lang: str
    text: str
    markers: dict[str, str]

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def blocks(page: Path) -> list[Block]:
    found, markers, lines = [], {}, page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        marker = MARKER.match(lines[i])
        fence = FENCE.match(lines[i])
        if marker:
            markers[marker.group(1)] = marker.group(2)
        elif fence:
            end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
            found.append(Block(page, i + 1, fence.group(1), "\n".join(lines[i + 1 : end]) + "\n", markers))
            markers, i = {}, end
        elif lines[i].strip():
            markers = {}  # a marker belongs to the block right after it
        i += 1
    return found


def runnable(block: Block) -> bool:
    return (
        "file" in block.markers
        or block.lang == "python"
        or (block.lang == "console" and any(c[0] == "certiloop" for c in commands(block)))
    )


def commands(block: Block) -> list[list[str]]:
    return [shlex.split(line[2:]) for line in block.text.splitlines() if line.startswith("$ ")]


def test_every_page_is_found_and_the_markers_are_known():
    assert (ROOT / "docs" / "tutorial.md") in PAGES
    for page in PAGES:
        for block in blocks(page):
            assert set(block.markers) <= {"file", "exit", "docs-test"}, block.where
            if "docs-test" in block.markers:
                assert block.markers["docs-test"].split(" ", 1)[0] in ("skip", "requires"), block.where


@pytest.mark.parametrize(
    "page", [p for p in PAGES if any(runnable(b) for b in blocks(p))], ids=lambda p: str(p.relative_to(ROOT))
)
def test_the_code_blocks_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    before = set(sys.modules)
    namespace: dict = {"__name__": "docs_page"}
    env = {**os.environ, "COLUMNS": "100", "CERTILOOP_CACHE": str(tmp_path / ".cache")}
    try:
        for block in blocks(page):
            if not runnable(block) or not wanted(block):
                continue
            if "file" in block.markers:
                write(block, tmp_path)
            elif block.lang == "python":
                run_python(block, namespace)
            else:
                run_console(block, env)
    finally:  # a module a page wrote (drone_models) must not leak into the next page
        for name in set(sys.modules) - before:
            if getattr(sys.modules[name], "__file__", "") and str(tmp_path) in sys.modules[name].__file__:
                del sys.modules[name]


def wanted(block: Block) -> bool:
    how, _, what = block.markers.get("docs-test", "run").partition(" ")
    if how == "requires":
        import importlib.util

        return importlib.util.find_spec(what) is not None
    return how != "skip"


def write(block: Block, folder: Path) -> None:
    target = folder / block.markers["file"]
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(block.text, encoding="utf-8")
    if block.lang == "python":
        compile(block.text, block.where, "exec")
    elif block.lang == "toml":
        tomllib.loads(block.text)
    elif block.lang == "yaml":
        yaml = pytest.importorskip("yaml", reason="PyYAML is not installed")
        assert yaml.safe_load(block.text), block.where


def run_python(block: Block, namespace: dict) -> None:
    known = set(namespace)
    exec(compile(block.text, block.where, "exec"), namespace)
    for name, value in list(namespace.items()):
        if name.startswith("test_") and name not in known and callable(value):
            value()


def run_console(block: Block, env: dict) -> None:
    expected = int(block.markers.get("exit", "0"))
    for argv in commands(block):
        if argv[0] != "certiloop":
            continue
        done = subprocess.run(
            [sys.executable, "-m", "certiloop.cli", *argv[1:]],
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == expected, (
            f"{block.where}: `{shlex.join(argv)}` exited {done.returncode}, the page says {expected}\n"
            f"{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
        )


def test_the_tutorial_model_is_what_certiloop_init_writes():
    """The tutorial walks through the files `certiloop init` writes: the same text."""
    written = {
        b.markers["file"]: b.text for b in blocks(ROOT / "docs" / "tutorial.md") if "file" in b.markers
    }
    templates = ROOT / "cli" / "templates"
    for name in ("drone_models.py", "test_drone.py"):
        assert written[name] == (templates / name).read_text(encoding="utf-8"), name


def test_the_readme_is_short_and_has_no_history():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    assert not re.search(r"\b20\d\d-\d\d-\d\d\b", text)  # dates
    assert not re.search(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b", text)  # commit hashes
    for word in ("seed 00", "helper", "sitting"):
        assert word not in text.lower(), word


def test_no_page_speaks_of_the_papers_by_number():
    for page in PAGES:
        assert not re.search(r"seed[ -]?00\d", page.read_text(encoding="utf-8"), re.I), page


def generator(name: str):
    sys.path.insert(0, str(ROOT / "docs"))
    try:
        return __import__(name)
    finally:
        sys.path.remove(str(ROOT / "docs"))


def test_the_cli_reference_has_every_flag_of_every_command():
    from certiloop.cli.parser import build_parser

    page = generator("gen_cli").page()
    parser = build_parser()
    commands = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction").choices
    assert {"init", "list", "prove", "falsify", "gate", "extract", "export", "campaign"} <= set(commands)
    for name, sub in commands.items():
        assert f"## certiloop {name}" in page, name
        flags = set(re.findall(r"(?<![\w-])--?[a-zA-Z][\w-]*", sub.format_help())) - {"-h", "--help"}
        missing = [f for f in flags if f"`{f}`" not in page]
        assert not missing, (name, missing)


def test_the_performance_page_has_each_records_rows_with_a_command():
    import json

    page = generator("gen_perf").page()
    for name in ("prove.json", "falsify.json", "kernel_c.json", "monitors.json"):
        record = json.loads((ROOT / "benchmarks" / "results" / name).read_text())
        section = page.split(f"`benchmarks/results/{name}`", 1)[1].split("\n## ", 1)[0]
        rows = [line for line in section.splitlines() if line.startswith("| ")]  # "|---" is not one
        assert len(rows) - 1 == len(record["rows"]), name  # the header, then one line per measurement
        assert all(re.search(r"\| `(python benchmarks/|certiloop )[^`]+` \|$", row) for row in rows[1:]), name
    assert "old_" not in page and "new_" not in page  # no before/after history


def test_each_case_study_has_a_page_named_by_its_paper():
    from certiloop.models.library.registry import studies

    for study in studies():
        page = (ROOT / "docs" / "studies" / f"{study.name}.md").read_text(encoding="utf-8")
        assert page.splitlines()[0] == f"# {study.title}", study.name
        assert f"studies/{study.name}.md" in (ROOT / "mkdocs.yml").read_text(), study.name


def test_the_library_page_lists_every_model_with_its_expectation():
    from certiloop.models import library

    page = generator("gen_library").page()
    for name in library.names():
        assert f"| `{name}` | {library.get(name).expected} |" in page, name
