"""Pin hypothesis's pool of "local constants" for a search.

Hypothesis now and then draws a constant it harvested from the source of every non-installed
module imported so far (certiloop's own in a development checkout, the user's model files).
A search then found different examples depending on what the process had imported before:
`gate m` could fail where `gate` passed, and `campaign --search --seed S` gave another fault
after the Raven arm's kernel had been imported. Within `pinned_constants(numbers)` the pool
is exactly `numbers`: the same search in any process, aimed at the numbers that matter.
Hypothesis has no public setting for it; without these internals (another hypothesis version)
this does nothing.
"""

from __future__ import annotations

from collections.abc import Iterable
from contextlib import contextmanager
from fractions import Fraction


@contextmanager
def pinned_constants(numbers: Iterable):
    try:
        from hypothesis.internal.conjecture import providers
        from hypothesis.internal.constants_ast import Constants
    except ImportError:  # pragma: no cover - hypothesis internals moved
        yield
        return
    old = getattr(providers, "_get_local_constants", None)
    cache = getattr(providers, "CONSTANTS_CACHE", None)
    if old is None or cache is None:  # pragma: no cover
        yield
        return
    values = {Fraction(v) for v in numbers}
    pinned = Constants(integers=sorted({int(v) for v in values if v.denominator == 1}),
                       floats=sorted({float(v) for v in values}), bytes=[], strings=[])
    providers._get_local_constants = lambda: pinned
    cache.cache.clear()
    try:
        yield
    finally:
        providers._get_local_constants = old
        cache.cache.clear()
