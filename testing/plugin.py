"""pytest plugin: every theorem in a `*_models.py` file is a test of its `expected` verdict.

Registered as the `certiloop` pytest11 entry point (or load it with
`-p certiloop.testing.plugin`). In a file whose name matches `certiloop_model_files`
(default `*_models.py`) and is not already a test module (`python_files`, e.g.
`test_models.py`), these become items named after the variable or function:

* each module-level `Theorem`, defined there or imported;
* each public zero-argument function defined there that returns one (called at collection);
* each imported zero-argument function annotated `-> Theorem` (a library's model builder,
  `from mylib.models import train`), unless a theorem of the same name is already an item.
  Other imported functions are never called.

`expected="proved"` runs `assert_proved`, `"refuted"` runs `assert_refuted`. A models file
that yields no theorem gets a warning (`CertiloopModelsWarning`) saying what counts.

Work in progress: a model whose proof is not finished yet can be listed in pyproject.toml,

    [tool.certiloop]
    wip = ["train_v2", "arm.*"]     # item names or theorem names (fnmatch patterns)

Its item is reported as xfail while its verdict is `unknown`, and as XPASS once it meets its
expectation (time to take it off the list). A wrong verdict (a counterexample to a model
expected proved, or a proof of one expected refuted) still fails.

ini options: `certiloop_rlimit`, `certiloop_falsify` (examples; 0 = off).

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


class CertiloopModelsWarning(pytest.PytestWarning):
    """A models file the plugin collects nothing from."""


_WIP = pytest.StashKey[tuple]()


def pytest_configure(config: pytest.Config) -> None:
    """`[tool.certiloop] wip = [...]` in the rootdir's pyproject.toml, read once per run (a
    malformed list is a usage error before anything is collected)."""
    config.stash[_WIP] = _read_wip(config.rootpath / "pyproject.toml")


def _wip_patterns(config: pytest.Config) -> tuple:
    return config.stash.get(_WIP, ())


def _read_wip(path: Path) -> tuple:
    import tomllib

    if not path.is_file():
        return ()
    try:
        wip = tomllib.loads(path.read_text()).get("tool", {}).get("certiloop", {}).get("wip", [])
    except tomllib.TOMLDecodeError as exc:
        raise pytest.UsageError(f"{path}: not valid TOML: {exc}") from None
    if not isinstance(wip, list) or not all(isinstance(w, str) for w in wip):
        raise pytest.UsageError(f"{path}: [tool.certiloop] wip must be a list of model names, "
                                'e.g. wip = ["train_v2"]')
    return tuple(wip)


def _is_models_file(file_path: Path, config: pytest.Config) -> bool:
    """Named like a models file, and not a test module (tests/models/test_models.py is pytest's)."""
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

        module, seen, names = self.obj, set(), set()
        for name, value in list(vars(module).items()):
            if name.startswith("_"):
                continue
            if inspect.isfunction(value) and value.__module__ == module.__name__ and _no_arguments(value):
                value = self._build(name, value)
            if isinstance(value, Theorem) and id(value) not in seen:
                seen.add(id(value))
                names.add(value.name)
                yield TheoremItem.from_parent(self, name=name, theorem=value)
        for name, value in list(vars(module).items()):  # imported builders, after what is defined here
            if (name.startswith("_") or not inspect.isfunction(value) or value.__module__ == module.__name__
                    or not _no_arguments(value) or not _returns_theorem(value)):
                continue
            value = self._build(name, value)
            if isinstance(value, Theorem) and value.name not in names:
                names.add(value.name)
                yield TheoremItem.from_parent(self, name=name, theorem=value)
        if not names:
            self.warn(CertiloopModelsWarning(
                f"{self.path.name} matches certiloop_model_files but yields no certiloop theorem: "
                "define a Theorem at module level, a public function of no arguments returning one, "
                "or import a builder annotated `-> Theorem`"))

    def _build(self, name: str, builder):
        try:
            return builder()
        except Exception as exc:  # a model that cannot be built is a collection error
            raise self.CollectError(f"{self.path.name}: {name}() failed: "
                                    f"{type(exc).__name__}: {exc}") from exc


def _returns_theorem(fn) -> bool:
    """Annotated `-> Theorem` (the class or, under `from __future__ import annotations`, its name)."""
    returned = inspect.signature(fn).return_annotation
    name = returned if isinstance(returned, str) else getattr(returned, "__name__", "")
    return name.rsplit(".", 1)[-1] == "Theorem"


def _no_arguments(fn) -> bool:
    params = inspect.signature(fn).parameters.values()
    return all(p.default is not p.empty or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in params)


class TheoremItem(pytest.Item):
    def __init__(self, *, theorem, **kwargs) -> None:
        super().__init__(**kwargs)
        self.theorem = theorem
        self.extra_keyword_matches.add(theorem.name)  # -k selects by the theorem's name too
        if any(fnmatch(n, p) for p in _wip_patterns(self.config) for n in (self.name, theorem.name)):
            from certiloop.testing.assertions import VerdictUnknown

            # only `unknown` is expected: a wrong verdict still fails, a proof shows as XPASS
            self.add_marker(pytest.mark.xfail(raises=VerdictUnknown, strict=False,
                                              reason="work in progress ([tool.certiloop] wip)"))

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
