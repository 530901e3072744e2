"""Memos for the term transforms the prover repeats over a model's obligations (their
hypotheses share nodes and terms): results kept by key or by node identity. Nothing here
changes a result, only how often it is rebuilt."""

from __future__ import annotations

from typing import Any

from certiloop.models.lang.terms import Node, substitute

_SUBSTITUTED: dict[tuple, Node] = {}
SUBSTITUTED_KEPT = 4096  # results kept; then the memo starts afresh (one family's obligations fit)


def substitute_shared(n: Node, env: dict[str, Node]) -> Node:
    """`substitute`, remembered by the terms' keys: for callers that substitute the same few
    terms into the same templates again and again (the weakenings, per obligation: 7,338
    calls, 218 distinct, on sbs.ctrl2 and ctrl2_dynamic). Equal keys give equal results,
    so this only saves the rebuilding."""
    key = (n.key, tuple([(name, t.key) for name, t in env.items()]))
    got = _SUBSTITUTED.get(key)
    if got is None:
        if len(_SUBSTITUTED) >= SUBSTITUTED_KEPT:
            _SUBSTITUTED.clear()
        got = _SUBSTITUTED[key] = substitute(n, env)
    return got


class NodeMemo:
    """A pure function's results by node identity, kept across calls: a model's obligations
    share their hypotheses' nodes, so each transform meets the same subterms once per
    obligation. The memo holds each node it remembers, so no id is reused while it is in
    the memo; past `size` entries it starts afresh."""

    def __init__(self, size: int = 100_000) -> None:
        self._seen: dict[int, tuple[Node, Any]] = {}
        self.size = size

    def get(self, n: Node, default: Any = None) -> Any:
        got = self._seen.get(id(n))
        return default if got is None else got[1]

    def put(self, n: Node, value: Any) -> Any:
        if len(self._seen) >= self.size:
            self._seen.clear()
        self._seen[id(n)] = (n, value)
        return value
