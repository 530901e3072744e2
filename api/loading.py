"""Resolve a MODEL argument: a library name (`sbs.ctrl1`) or `path/to/file.py:theorem`."""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import dataclass
from pathlib import Path

from certiloop.models import library
from certiloop.models.lang.terms import ModelError
from certiloop.models.lang.theorem import Theorem


@dataclass(frozen=True)
class Unsupported:
    """An archive entry certiloop cannot read or prove: one row saying why, the others run."""

    name: str
    reason: str

    def to_json(self) -> dict[str, str]:
        return {"model": self.name, "verdict": "not supported", "reason": self.reason}


def load_all(specs: list[str], keep_unsupported: bool = False) -> list:
    """Every MODEL argument resolved, in order; a family name (`sbs`) selects all its models.
    A selection that matches nothing is bad input. With `keep_unsupported`, an entry of a
    whole archive that certiloop cannot read is an `Unsupported` in its place; else (and
    always for an entry named alone) it is bad input."""
    theorems: list = []
    for spec in specs:
        if _kyx_spec(spec) is not None:
            theorems.extend(load_kyx(*_kyx_spec(spec), keep_unsupported=keep_unsupported))
            continue
        family = [n for n in library.names() if n.startswith(f"{spec}.")] if "." not in spec else []
        if family:
            theorems.extend(library.get(n) for n in family)
        else:
            theorems.append(load(spec))
    if not theorems:
        raise ModelError("no model selected: name a library model (certiloop list), a family, or "
                         "path/to/file.py:THEOREM")
    return theorems


def _kyx_spec(spec: str) -> tuple[str, str | None] | None:
    """`FILE.kyx` or `FILE.kyx:"Entry name"` (entry names may hold ':', quotes optional)."""
    cut = spec.find(".kyx")
    while cut != -1:
        end = cut + len(".kyx")
        if end == len(spec):
            return spec, None
        if spec[end] == ":":
            entry = spec[end + 1:]
            if len(entry) >= 2 and entry[0] == entry[-1] == '"':
                entry = entry[1:-1]
            return spec[:end], entry
        cut = spec.find(".kyx", end)
    return None


_HINT_NOTES: dict[str, tuple[str, ...]] = {}  # a read .kyx entry's canonical text -> its notes


def hint_notes(theorem) -> tuple[str, ...]:
    """For a theorem read from a .kyx entry: which invariants its Tactic names were used as
    hints, and why the others were not (empty for any other theorem)."""
    return _HINT_NOTES.get(getattr(theorem, "canonical", ""), ())


def load_kyx(path_text: str, entry: str | None = None, keep_unsupported: bool = False) -> list:
    """Every entry of a KeYmaera X archive, or the one named; an entry certiloop cannot read
    is bad input, named with its line and column (with `keep_unsupported` and no entry
    named, an `Unsupported` in its place)."""
    from certiloop.models.kyx import read_entries

    path = Path(path_text)
    if not path.is_file():
        raise ModelError(f"{path_text}: no such file (paths are relative to the current folder)")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path_text}: cannot be read: {exc}") from None
    entries = read_entries(text, path_text, only=entry)
    _HINT_NOTES.update({e.theorem.canonical: e.notes for e in entries if e.theorem is not None and e.notes})
    if entry is not None:
        chosen = [e for e in entries if e.name == entry]
        if not chosen:
            names = ", ".join(repr(e.name) for e in entries[:5])
            raise ModelError(f"{path_text}: no entry named {entry!r} (it has: {names}"
                             f"{', ...' if len(entries) > 5 else ''})")
        entries = chosen
    if keep_unsupported and entry is None and entries:
        return [e.theorem if e.theorem is not None else Unsupported(e.name, e.error or "not readable")
                for e in entries]
    bad = [e for e in entries if e.theorem is None]
    if bad:
        more = f" (and {len(bad) - 1} more entries)" if len(bad) > 1 else ""
        raise ModelError(f"entry {bad[0].name!r}: {bad[0].error}{more}")
    if not entries:
        raise ModelError(f"{path_text}: the archive has no entries")
    return [e.theorem for e in entries if e.theorem is not None]


def load(spec: str) -> Theorem:
    if _kyx_spec(spec) is not None:
        found = load_kyx(*_kyx_spec(spec))
        if len(found) != 1:
            raise ModelError(f"{spec}: holds {len(found)} entries; name one, as {spec}:\"Entry name\"")
        return found[0]
    before = spec.rsplit(":", 1)[0]
    if ":" in spec and (before.endswith(".py") or "/" in spec or Path(before).exists()):
        return _from_file(*spec.rsplit(":", 1))
    if spec.endswith(".py"):
        raise ModelError(f"{spec}: name the theorem too, as {spec}:THEOREM")
    return library.get(spec)


def _from_file(path_text: str, attr: str) -> Theorem:
    path = Path(path_text)
    if not path_text:
        raise ModelError(f"':{attr}' names no file: write the model as path/to/file.py:{attr or 'THEOREM'}")
    if path.is_dir():
        raise ModelError(f"{path_text} is a folder: name a Python file in it, as {path_text}/FILE.py:THEOREM")
    if not path.is_file():
        raise ModelError(f"{path_text}: no such file (paths are relative to the current folder)")
    if path.suffix != ".py":
        raise ModelError(f"{path_text}: not a Python file: models are written in .py files")
    if not attr.isidentifier():
        raise ModelError(f"{path_text}: {attr!r} is not a Python name")
    module_name = f"certiloop_user_{abs(hash(path.resolve()))}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    if spec is None or spec.loader is None:
        raise ModelError(f"{path_text}: cannot be loaded as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    folder = str(path.resolve().parent)  # a model file may import its sibling modules
    sys.path.insert(0, folder)
    try:
        spec.loader.exec_module(module)
    except ModelError as exc:
        raise ModelError(f"{_user_place(exc, path, path_text)}: {exc}") from None
    except SyntaxError as exc:
        column = f":{exc.offset}" if exc.offset else ""
        where = f"{exc.filename}:{exc.lineno}{column}" if exc.filename else f"{path_text}:{exc.lineno}"
        raise ModelError(f"{where}: syntax error: {exc.msg} (fix the Python syntax there)") from None
    except Exception as exc:  # the user's module failed while importing
        raise ModelError(f"{_user_place(exc, path, path_text)}: failed to import: "
                         f"{type(exc).__name__}: {exc}") from None
    finally:
        sys.path.remove(folder)
    if not hasattr(module, attr):
        found = [k for k, v in vars(module).items() if isinstance(v, Theorem) or
                 (callable(v) and getattr(v, "__module__", None) == module_name and not k.startswith("_"))]
        hint = f" (it defines: {', '.join(found[:5])})" if found else ""
        raise ModelError(f"{path_text}: defines no theorem named {attr!r}{hint}")
    obj = getattr(module, attr)
    if callable(obj) and not isinstance(obj, Theorem):
        _no_arguments_needed(obj, f"{path_text}:{attr}")
        try:
            obj = obj()
        except ModelError as exc:
            raise ModelError(f"{_user_place(exc, path, path_text)}: {attr}: {exc}") from None
        except Exception as exc:
            raise ModelError(f"{_user_place(exc, path, path_text)}: {attr}: building the theorem failed: "
                             f"{type(exc).__name__}: {exc}") from None
    if not isinstance(obj, Theorem):
        raise ModelError(f"{path_text}:{attr} is a {type(obj).__name__}, not a certiloop Theorem")
    return obj


def _user_place(exc: BaseException, path: Path, path_text: str) -> str:
    """FILE:LINE of the innermost line of the user's own files the exception passed through
    (the model file or a module beside it), else the model file's name."""
    folder = path.resolve().parent
    place = path_text
    frame = exc.__traceback__
    while frame is not None:
        name = Path(frame.tb_frame.f_code.co_filename)
        if name.is_absolute() and name.parent == folder and name.suffix == ".py":
            shown = path_text if name == path.resolve() else str(name)
            place = f"{shown}:{frame.tb_lineno}"
        frame = frame.tb_next
    return place


def _no_arguments_needed(builder, where: str) -> None:
    import inspect

    try:
        params = inspect.signature(builder).parameters.values()
    except (TypeError, ValueError):  # a builtin or a class without a signature: just call it
        return
    needed = [p.name for p in params if p.default is p.empty
              and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    if needed:
        raise ModelError(f"{where} needs arguments ({', '.join(needed)}): name a Theorem, or a function "
                         "of no arguments that returns one")


def project_models(folder: Path | None = None) -> list[str]:
    """The gate's default: `[tool.certiloop] models = [...]` in ./pyproject.toml if there is
    one, else the whole library."""
    import tomllib

    path = (folder or Path.cwd()) / "pyproject.toml"
    if path.is_file():
        try:
            config = tomllib.loads(path.read_text()).get("tool", {}).get("certiloop", {})
        except tomllib.TOMLDecodeError as exc:
            raise ModelError(f"{path}: not valid TOML: {exc}") from None
        models = config.get("models")
        if models is not None:
            if not isinstance(models, list) or not all(isinstance(m, str) for m in models):
                raise ModelError(f"{path}: [tool.certiloop] models must be a list of MODEL strings")
            return models
    return library.names()
