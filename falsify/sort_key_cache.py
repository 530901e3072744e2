"""Remember hypothesis's sort key of each run it keeps in its pareto front.

With an example database, hypothesis keeps a pareto front of the runs it has seen and, for
every new run, compares it with up to about twenty kept ones. Each comparison recomputes both
runs' sort keys from scratch (an index per decision; a float's index takes bit reversals), and
on the sbs models that was a quarter of a search's time. A run's decisions never change once
it ran, so within `cached_sort_keys()` each key is computed once per run and looked up after:
the same keys, so the same comparisons, random draws and examples. Hypothesis has no public
setting for it; without these internals (another hypothesis version) this does nothing.
"""

from __future__ import annotations

from contextlib import contextmanager

MAX_REMEMBERED = 100_000  # runs whose key is kept (the front holds at most max_examples runs)


@contextmanager
def cached_sort_keys():
    try:
        from hypothesis.internal.conjecture import pareto
    except ImportError:  # pragma: no cover - hypothesis internals moved
        yield
        return
    original = getattr(pareto, "sort_key", None)
    if original is None:  # pragma: no cover
        yield
        return
    remembered: dict[int, tuple] = {}

    def sort_key(nodes):
        got = remembered.get(id(nodes))
        if got is not None and got[0] is nodes:
            return got[1]
        key = original(nodes)
        if isinstance(nodes, tuple):  # immutable: its key cannot change
            if len(remembered) >= MAX_REMEMBERED:
                remembered.clear()
            remembered[id(nodes)] = (nodes, key)  # the nodes are kept, so that their id is not reused
        return key

    pareto.sort_key = sort_key
    try:
        yield
    finally:
        pareto.sort_key = original
