"""pytest plugin: every theorem in a `*_models.py` file is a test of its `expected` verdict.

Registered as the `certiloop` pytest11 entry point (or load it with
`-p certiloop.testing.plugin`). In a file whose name matches `certiloop_model_files`
(default `*_models.py`) and is not already a test module (`python_files`, e.g.
`test_models.py`), each module-level `Theorem`, and each public zero-argument function
defined there that returns one (called at collection), becomes an item named after the
variable or function: `expected="proved"` runs `assert_proved`, `"refuted"` runs
`assert_refuted`. ini options: `certiloop_rlimit`, `certiloop_falsify` (examples; 0 = off).

This module imports only pytest: certiloop's prover loads when the first item runs, so
ordinary test collection is not slowed.
"""

from __future__ import annotations

import inspect
from fnmatch import fnmatch
from pathlib import Path

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini("certiloop_model_files", "file name patterns whose theorems are collected",
                  type="args", default=["*_models.py"])
    parser.addini("certiloop_rlimit", "z3 resource units per obligation form (certiloop's default if empty)",
                  default="")
    parser.addini("certiloop_falsify", "falsifier examples per theorem besides the proof (0 = off)",
                  default="0")


def _is_models_file(file_path: Path, config: pytest.Config) -> bool:
    """Named like a models file, and not a test module (tests/test_models.py is pytest's)."""
    return (file_path.suffix == ".py"
            and any(fnmatch(file_path.name, p) for p in config.getini("certiloop_model_files"))
            and not any(fnmatch(file_path.name, p) for p in config.getini("python_files")))


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    if parent.session.isinitpath(file_path) or not _is_models_file(file_path, parent.config):
        return None  # a file named on the command line comes through pytest_pycollect_makemodule
    return ModelsFile.from_parent(parent, path=file_path)


@pytest.hookimpl(tryfirst=True)
def pytest_pycollect_makemodule(module_path: Path, parent: pytest.Collector) -> pytest.Module | None:
    """`pytest my_models.py`: pytest collects a file named on the command line as a test
    module; make it a models file instead, so that an imported `test` is not a test."""
    if _is_models_file(module_path, parent.config):
        return ModelsFile.from_parent(parent, path=module_path)
    return None


class ModelsFile(pytest.Module):
    """A models file, imported the way pytest imports test modules (`--import-mode`, so
    it can import modules beside it); its items are theorems, not test functions."""

    def collect(self):
        from certiloop.models.lang.theorem import Theorem

        module, seen = self.obj, set()
        for name, value in list(vars(module).items()):
            if name.startswith("_"):
                continue
            if inspect.isfunction(value) and value.__module__ == module.__name__ and _no_arguments(value):
                try:
                    value = value()
                except Exception as exc:  # a model that cannot be built is a collection error
                    raise self.CollectError(f"{self.path.name}: {name}() failed: "
                                            f"{type(exc).__name__}: {exc}") from exc
            if isinstance(value, Theorem) and id(value) not in seen:
                seen.add(id(value))
                yield TheoremItem.from_parent(self, name=name, theorem=value)


def _no_arguments(fn) -> bool:
    params = inspect.signature(fn).parameters.values()
    return all(p.default is not p.empty or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in params)


class TheoremItem(pytest.Item):
    def __init__(self, *, theorem, **kwargs) -> None:
        super().__init__(**kwargs)
        self.theorem = theorem
        self.extra_keyword_matches.add(theorem.name)  # -k selects by the theorem's name too

    def runtest(self) -> None:
        from certiloop.testing.assertions import assert_proved, assert_refuted

        rlimit = self.config.getini("certiloop_rlimit")
        options = {"rlimit": int(rlimit) if rlimit else None,
                   "falsify": int(self.config.getini("certiloop_falsify") or 0)}
        check = assert_proved if self.theorem.expected == "proved" else assert_refuted
        check(self.theorem, **options)

    def repr_failure(self, excinfo, style=None):
        if isinstance(excinfo.value, AssertionError):
            return str(excinfo.value)  # the verdict, obligations and run: our frames add nothing
        return super().repr_failure(excinfo, style)

    def reportinfo(self):
        return self.path, None, f"{self.name} ({self.theorem.name}, expected {self.theorem.expected})"
