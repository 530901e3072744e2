"""An example database that keeps its writes to itself until told to pass them on.

A search running beside the batch phase (`forked.py`) may turn out not to count: the batch
found a counterexample first, and a search run one after the other would never have started.
Its hypothesis database then must not change, or the next search would replay other runs
first. So it reads the real database and records its own saves and deletes, seen by its own
reads at once; `replay_on` writes them to the real database once the search's result is used.
"""

from __future__ import annotations

from collections.abc import Iterable

from hypothesis.database import ExampleDatabase


class RecordingDatabase(ExampleDatabase):
    def __init__(self, inner: ExampleDatabase) -> None:
        super().__init__()
        self.inner = inner
        self.writes: list[tuple[str, bytes, bytes]] = []  # ("save" | "delete", key, value), in order
        self._saved: dict[bytes, dict[bytes, None]] = {}
        self._deleted: dict[bytes, set[bytes]] = {}

    def fetch(self, key: bytes) -> Iterable[bytes]:
        deleted = self._deleted.get(key, set())
        seen = set()
        for value in self.inner.fetch(key):
            if value not in deleted:
                seen.add(value)
                yield value
        for value in list(self._saved.get(key, {})):
            if value not in seen:
                yield value

    def save(self, key: bytes, value: bytes) -> None:
        self.writes.append(("save", key, value))
        self._saved.setdefault(key, {})[value] = None
        self._deleted.get(key, set()).discard(value)

    def delete(self, key: bytes, value: bytes) -> None:
        self.writes.append(("delete", key, value))
        self._saved.get(key, {}).pop(value, None)
        self._deleted.setdefault(key, set()).add(value)


def replay_on(database: ExampleDatabase, writes: list[tuple[str, bytes, bytes]]) -> None:
    for op, key, value in writes:
        (database.save if op == "save" else database.delete)(key, value)
