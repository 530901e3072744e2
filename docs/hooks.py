"""MkDocs hooks: the pages generated from the code and the records, so they cannot drift —
the CLI reference (from the argument parser), the model library (from the library), the
performance page (from
benchmarks/results/*.json) and the changelog (CHANGELOG.md at the top of the repository)."""

from __future__ import annotations

import sys
from pathlib import Path

from mkdocs.structure.files import File

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import gen_cli  # noqa: E402
import gen_library  # noqa: E402
import gen_perf  # noqa: E402

SOURCE_TREE = HERE.parent / ".cache" / "docs-src"  # mkdocs.yml: mkdocstrings' `paths`
DOCUMENTED = ("models", "api")  # the packages whose docstrings the reference renders


def _source_tree() -> Path:
    """certiloop's packages are mapped from top-level folders (models/ is certiloop.models), which
    mkdocstrings cannot find by path: a folder with certiloop/models linking to them can be."""
    package = SOURCE_TREE / "certiloop"
    package.mkdir(parents=True, exist_ok=True)
    (package / "__init__.py").write_text("")
    for name in DOCUMENTED:
        link = package / name
        if not link.is_symlink():
            link.symlink_to(HERE.parent / name, target_is_directory=True)
    return SOURCE_TREE


_source_tree()  # at import: before mkdocstrings looks for its paths


def _changelog() -> str:
    return (HERE.parent / "CHANGELOG.md").read_text(encoding="utf-8")


def on_files(files, config):
    for path, make in (
        ("reference/cli.md", gen_cli.page),
        ("reference/library.md", gen_library.page),
        ("reference/performance.md", gen_perf.page),
        ("changelog.md", _changelog),
    ):
        files.append(File.generated(config, path, content=make()))
    return files
