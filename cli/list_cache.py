"""The printed output of `certiloop list`, kept on disk so that listing the library does not
rebuild and check every theorem and lay out a table on each call.

An entry is the exact text `certiloop list` printed, stored under a key that covers everything
the text depends on: the arguments, ./pyproject.toml (its `[tool.certiloop] models`), the
installed studies, every file of certiloop's packages and of the studies' packages (path,
size, modification time), the versions of Python, certiloop and rich, and for a table what
rich's console reads to choose its width, colours and boxes (`terminal()`), read here without
importing rich, which would cost a good part of the listing's time. Only a selection of
library models is stored (a `.py` file or `.kyx` archive is read again each time). An entry
is used only if it parses and names its key and the checksum of its text; anything else is
ignored and the listing is made again. The folder is $CERTILOOP_CACHE/list (default
~/.cache/certiloop/list); it is safe to delete, and without a writable one nothing is stored.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from importlib.util import find_spec
from pathlib import Path

PACKAGES = ("certiloop.models", "certiloop.studies", "certiloop.cli", "certiloop.api", "certiloop.proofs",
            "certiloop.falsify", "certiloop.kernel", "certiloop.testing")
# the environment variables rich's Console reads (rich/console.py): width, height, colours, terminal
RICH_ENV = ("COLUMNS", "LINES", "JUPYTER_COLUMNS", "JUPYTER_LINES", "NO_COLOR", "FORCE_COLOR", "TERM",
            "COLORTERM", "TTY_COMPATIBLE", "TTY_INTERACTIVE", "DATABRICKS_RUNTIME_VERSION")
KEEP = 16  # entries kept in the folder (the newest): one per console width and source state in use


def folder() -> Path | None:
    """Where entries live; None without a home folder to put them in."""
    try:
        return Path(os.environ.get("CERTILOOP_CACHE") or Path.home() / ".cache" / "certiloop") / "list"
    except RuntimeError:  # no $HOME and no user entry: nothing is stored
        return None


def _sources(packages) -> list:
    """(package, relative path, size, mtime) of every file under the packages' folders."""
    found = []
    for package in packages:
        spec = find_spec(package)
        for root in sorted(spec.submodule_search_locations or []) if spec else []:
            for dirpath, dirnames, filenames in os.walk(root):
                dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
                for name in sorted(filenames):
                    path = os.path.join(dirpath, name)
                    try:
                        st = os.stat(path)
                    except OSError:  # gone since the walk listed it (an editor's temporary file)
                        continue
                    found.append((package, path[len(root):], st.st_size, st.st_mtime_ns))
    return found


def terminal() -> list:
    """What a rich Console on stdout decides its width, colours and box characters from: the
    environment variables it reads, whether stdout is a terminal, the size of the first standard
    stream that is one, the encoding and the platform."""
    size = None
    for fd in (0, 1, 2):
        try:
            size = tuple(os.get_terminal_size(fd))
            break
        except (AttributeError, ValueError, OSError):
            pass
    try:
        tty = sys.stdout.isatty()
    except (AttributeError, ValueError, OSError):
        tty = None
    return [[os.environ.get(name) for name in RICH_ENV], tty, size, getattr(sys.stdout, "encoding", None),
            sys.platform]


def key(as_json: bool, models: list[str] | None) -> str:
    """The key of the listing these arguments print (a table: on this process's stdout)."""
    from importlib.metadata import version

    from certiloop.models import library
    from certiloop.models.library.registry import studies

    pyproject = Path.cwd() / "pyproject.toml"
    study_packages = sorted({s.package for s in studies() if s.package})
    facts = {
        "json": as_json,
        "models": models or None,
        "pyproject": pyproject.read_text(errors="replace") if not models and pyproject.is_file() else None,
        "library": library.names(),
        "studies": [[s.name, s.package, s.order, sorted(s.models.items())] for s in studies()],
        "sources": _sources(sorted(set(PACKAGES) | set(study_packages))),
        "versions": [sys.version, version("certiloop"), None if as_json else version("rich")],
        "terminal": None if as_json else terminal(),
    }
    return hashlib.sha256(json.dumps(facts, default=str).encode()).hexdigest()[:32]


def _checksum(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def read(entry_key: str) -> str | None:
    """The stored text, or None when there is none or it is not trustworthy."""
    where = folder()
    if where is None:
        return None
    try:
        entry = json.loads((where / f"{entry_key}.json").read_text())
        if entry["key"] == entry_key and entry["checksum"] == _checksum(entry["text"]):
            return entry["text"]
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return None


def write(entry_key: str, text: str) -> None:
    """Store the text (atomically), dropping all but the newest KEEP entries; never fails."""
    where = folder()
    if where is None:
        return
    try:
        where.mkdir(parents=True, exist_ok=True)
        tmp = where / f".{entry_key}.{os.getpid()}.tmp"
        tmp.write_text(json.dumps({"key": entry_key, "checksum": _checksum(text), "text": text}))
        os.replace(tmp, where / f"{entry_key}.json")
        entries = sorted(where.glob("*.json"), key=lambda p: p.stat().st_mtime_ns, reverse=True)
        for old in entries[KEEP:]:
            old.unlink(missing_ok=True)
    except OSError:
        pass
