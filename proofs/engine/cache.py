"""On-disk cache of gate results, keyed by the whole claim and the prover that judged it.

The key covers the theorem's canonical serialisation (sorts, annotations, invariants,
constants, abbreviations, expected verdict, flags, name), the gate's options, and a
fingerprint of certiloop's own source plus the z3 and sympy versions, so editing the prover
invalidates every entry. An entry is trusted only if it parses, names the key it is stored
under, was written under the same fingerprint, and its checksum matches its payload;
anything else (a corrupted file, an entry from another version or another project) is
ignored and the work is done again. The folder is `.certiloop/cache` unless --cache or the
CERTILOOP_CACHE environment variable says otherwise; it is safe to delete.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

DEFAULT = Path(".certiloop") / "cache"


def source_fingerprint() -> str:
    """A hash of every certiloop source file (path and bytes), in a fixed order."""
    import certiloop.falsify
    import certiloop.kernel
    import certiloop.models
    import certiloop.proofs

    digest = hashlib.sha256()
    for package in (certiloop.models, certiloop.proofs, certiloop.falsify, certiloop.kernel):
        for folder in sorted(package.__path__):
            root = Path(folder)
            for path in sorted(root.rglob("*.py")):
                digest.update(f"{package.__name__}/{path.relative_to(root).as_posix()}\n".encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()[:24]


def versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    import sympy
    import z3

    try:
        own = version("certiloop")
    except PackageNotFoundError:  # running from a source tree
        own = "source"
    return {"certiloop": own, "source": source_fingerprint(), "z3": z3.get_version_string(),
            "sympy": sympy.__version__}


def _digest(payload: Any) -> str:
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


class Cache:
    def __init__(self, folder: Path | None = None) -> None:
        self.folder = Path(folder or os.environ.get("CERTILOOP_CACHE") or DEFAULT)
        self.versions = versions()
        self.hits = self.misses = self.ignored = 0

    def key(self, kind: str, content: str) -> str:
        return _digest({"kind": kind, "content": content, "versions": self.versions})

    def get(self, key: str, counted: bool = True) -> Any | None:
        """The payload stored under key, if the entry is sound; counted: in hits, misses and
        ignored (a lookup that goes with another one, such as a verdict's certificate, is not)."""
        before = (self.hits, self.misses, self.ignored)
        got = self._get(key)
        if not counted:
            self.hits, self.misses, self.ignored = before
        return got

    def _get(self, key: str) -> Any | None:
        path = self.folder / f"{key}.json"
        try:
            entry = json.loads(path.read_text())
            ok = (entry["key"] == key and entry["versions"] == self.versions
                  and entry["checksum"] == _digest(entry["payload"]))
        except FileNotFoundError:
            self.misses += 1
            return None
        except (OSError, ValueError, KeyError, TypeError):
            ok = False
        if not ok:
            self.ignored += 1
            return None
        self.hits += 1
        return entry["payload"]

    def put(self, key: str, payload: Any) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        entry = {"key": key, "versions": self.versions, "checksum": _digest(payload), "payload": payload}
        tmp = self.folder / f".{key}.{os.getpid()}.tmp"
        tmp.write_text(json.dumps(entry))
        tmp.replace(self.folder / f"{key}.json")  # atomic: a reader never sees half an entry
