"""Shrink a confirmed counterexample's numbers to short rationals.

Each number the run decided (initial values, open values, ODE durations) is replaced, one
after the other, by the simplest nearby rational the exact replay still confirms: 0, an
integer, then fractions of growing denominators and decimals of growing length. A value is
kept only if the whole run, replayed in exact rational arithmetic with it, still violates
the guarantee, so the result is as confirmed as before. The walk is deterministic (a fixed
order, a replay budget counted in replays): the same run gives the same counterexample.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any, Callable

from certiloop.falsify.evaluate import Table

SHRINK_REPLAYS = 160  # exact replays in all
SHRUNK_KINDS = ("real", "slack", "duration", "fraction")
DENOMINATORS = (2, 4, 10, 100, 1000, 10**4, 10**6)


def simpler(v: Any) -> list[Fraction]:
    """Rationals near v, simplest first, each simpler than v itself (v excluded)."""
    if isinstance(v, bool) or not isinstance(v, (int, float, Fraction)):
        return []
    if isinstance(v, float) and not math.isfinite(v):
        return []
    x = Fraction(v)
    out: list[Fraction] = [Fraction(0), Fraction(math.floor(x)), Fraction(math.ceil(x))]
    for d in DENOMINATORS:  # nearest, below and above: a run near an edge keeps to its side
        out += [Fraction(round(x * d), d), Fraction(math.floor(x * d), d), Fraction(math.ceil(x * d), d)]
    out += [x.limit_denominator(d) for d in DENOMINATORS]
    seen: set[Fraction] = set()
    ranked = []
    for c in out:
        if c != x and c not in seen and _size(c) < _size(x):
            seen.add(c)
            ranked.append(c)
    return sorted(ranked, key=lambda c: (_size(c), abs(c - x)))


def _size(x: Fraction) -> int:
    return len(str(abs(x.numerator))) + len(str(x.denominator))


def shrink(script: list[tuple[str, Any]], initial: dict[str, Any] | None,
           confirms: Callable[[list[tuple[str, Any]], dict[str, Any] | None], bool],
           budget: int = SHRINK_REPLAYS) -> tuple[list[tuple[str, Any]], dict[str, Any] | None]:
    """The script and initial state with every number as short as `confirms` allows."""
    script = list(script)
    initial = dict(initial) if initial is not None else None
    left = budget
    for name in sorted(initial or {}):
        value = initial[name]
        if isinstance(value, (Table, range)):
            continue
        for c in simpler(value):
            if left <= 0:
                return script, initial
            left -= 1
            trial = {**initial, name: c}
            if confirms(script, trial):
                initial = trial
                break
    for k, (kind, value) in enumerate(script):
        if kind not in SHRUNK_KINDS:
            continue
        for c in simpler(value):
            if left <= 0:
                return script, initial
            if kind == "fraction" and not 0 <= c <= 1:
                continue
            left -= 1
            trial = [*script[:k], (kind, c), *script[k + 1:]]
            if confirms(trial, initial):
                script = trial
                break
    return script, initial
