"""Who decides a run's nondeterminism: hypothesis (search), a script (replay), a RNG.

The interpreter asks a chooser for every decision it cannot compute: initial values, the
order in which a choice's alternatives are tried, a nondeterministic value no test pins
down, how long an ODE runs, how many control steps a run has. Recording the answers gives
a script that replays the same run, e.g. in exact arithmetic.
"""

from __future__ import annotations

import random
import sys
from typing import Any, Callable

REAL_RANGE = 10.0  # nondeterministic reals are drawn from [-10, 10]: the models' scale


class Diverged(Exception):
    """A scripted replay asked for a decision the recorded run did not make."""


class Chooser:
    def real(self, what: str) -> float:
        raise NotImplementedError

    def integer(self, what: str, lo: int, hi: int) -> int:
        raise NotImplementedError

    def real_between(self, what: str, lo: float, hi: float) -> float:
        """A value for an open real that a test bounds to [lo, hi] (finite, lo <= hi): drawn
        there, so that a havoc followed by its range test is not rejected most of the time.
        A chooser with nothing better draws as for any real (the test still decides)."""
        return self.real(what)

    def slack(self, strict: bool) -> float:
        """How far inside an inequality a repaired initial value lands (0: on the edge)."""
        raise NotImplementedError

    def fraction(self) -> float:
        """Which share of the longest allowed ODE duration to follow (1: all of it)."""
        raise NotImplementedError

    def duration(self, longest: Callable[[float], float]) -> float:
        """How long an ODE runs: `longest(u)` turns a drawn share u into a duration."""
        return longest(self.fraction())

    def pick(self, what: str, n: int) -> int:
        return self.integer(what, 0, n - 1)

    def pick_label(self, labels: tuple[str, ...]) -> int:
        """Which alternative of a choice to try first."""
        return self.pick("alternative", len(labels))

    def havoc_value(self, target: str) -> Any:
        """A value for `target := *` known in advance (replays), or None: decide later."""
        return None

    def flag(self, what: str) -> bool:
        return self.integer(what, 0, 1) == 1


_INTEGERS: dict[tuple[int, int], Any] = {}  # st.integers(lo, hi) by bounds: hypothesis would
# look each one up in its strategy cache on every draw (the same strategy either way)


class HypothesisChooser(Chooser):
    """Decisions drawn from hypothesis's `data` object, so hypothesis can target, shrink
    and replay them."""

    def __init__(self, data) -> None:
        from hypothesis import strategies as st

        self.data, self.st = data, st
        # DataObject.draw also checks, per draw, that the strategy left the global `random`
        # untouched (two 625-word states compared) and tracks spans for its own reports:
        # ~10 % of a sbs.ctrl2 search. These strategies are hypothesis's own and a run keeps
        # its own script, so draw from the underlying ConjectureData where there is one.
        inner = getattr(data, "conjecture_data", None)
        self._draw = inner.draw if callable(getattr(inner, "draw", None)) else data.draw
        self._real = st.floats(-REAL_RANGE, REAL_RANGE, allow_nan=False, allow_infinity=False,
                               allow_subnormal=False)
        self._slack = st.one_of(st.just(0.0), st.floats(0.0, REAL_RANGE))
        self._strict_slack = st.one_of(st.just(1.0), st.floats(1e-3, REAL_RANGE))
        self._fraction = st.one_of(st.just(1.0), st.floats(0.0, 1.0))

    def real(self, what: str) -> float:
        return self._draw(self._real)

    def integer(self, what: str, lo: int, hi: int) -> int:
        strategy = _INTEGERS.get((lo, hi))
        if strategy is None:
            if len(_INTEGERS) >= 1000:
                _INTEGERS.clear()
            strategy = _INTEGERS[(lo, hi)] = self.st.integers(lo, hi)
        return self._draw(strategy)

    def real_between(self, what: str, lo: float, hi: float) -> float:
        lo, hi = plain_bounds(lo, hi)
        if lo == hi:  # one value: hypothesis refuses an interval [0.0, -0.0] (it orders -0.0 first)
            return lo
        subnormal = _subnormal(lo) or _subnormal(hi)  # hypothesis refuses a subnormal bound otherwise
        return self._draw(self.st.floats(lo, hi, allow_nan=False, allow_infinity=False,
                                         allow_subnormal=subnormal))

    def slack(self, strict: bool) -> float:
        return self._draw(self._strict_slack if strict else self._slack)

    def fraction(self) -> float:
        return self._draw(self._fraction)


def plain_bounds(lo: float, hi: float) -> tuple[float, float]:
    """[lo, hi] with -0.0 read as 0.0 (a bound -(h - H)/T at h = H is -0.0, and hypothesis
    orders -0.0 below 0.0: [0.0, -0.0] would be empty to it)."""
    return float(lo) + 0.0, float(hi) + 0.0


def _subnormal(x: float) -> bool:
    return x != 0 and abs(x) < sys.float_info.min


class RandomChooser(Chooser):
    """Plain pseudo-random decisions (benchmarks, smoke runs)."""

    def __init__(self, seed: int = 0) -> None:
        self.rng = random.Random(seed)

    def real(self, what: str) -> float:
        return self.rng.uniform(-REAL_RANGE, REAL_RANGE)

    def integer(self, what: str, lo: int, hi: int) -> int:
        return self.rng.randint(lo, hi)

    def real_between(self, what: str, lo: float, hi: float) -> float:
        return self.rng.uniform(lo, hi)

    def slack(self, strict: bool) -> float:
        return self.rng.uniform(1e-3 if strict else 0.0, REAL_RANGE) if self.rng.random() < 0.7 else (
            1.0 if strict else 0.0)

    def fraction(self) -> float:
        return 1.0 if self.rng.random() < 0.5 else self.rng.random()


class FirstEnabled(Chooser):
    """The runtime kernel's policy: the first enabled alternative in the model's order,
    the first element of a family, Bool open values tried false first."""

    def real(self, what):
        return 0.0

    def integer(self, what, lo, hi):
        return lo

    def slack(self, strict):
        return 1.0 if strict else 0.0

    def fraction(self):
        return 1.0


class Recording(Chooser):
    """Passes decisions through from another chooser and keeps them as a script."""

    def __init__(self, inner: Chooser) -> None:
        self.inner = inner
        self.script: list[tuple[str, Any]] = []

    def _keep(self, kind: str, value: Any) -> Any:
        self.script.append((kind, value))
        return value

    def real(self, what):
        return self._keep("real", self.inner.real(what))

    def integer(self, what, lo, hi):
        return self._keep("integer", self.inner.integer(what, lo, hi))

    def real_between(self, what, lo, hi):
        return self._keep("real", self.inner.real_between(what, lo, hi))

    def slack(self, strict):
        return self._keep("slack", self.inner.slack(strict))

    def fraction(self):
        return self._keep("fraction", self.inner.fraction())

    def duration(self, longest):
        # the duration itself is kept, so a replay need not recompute floating-point
        # event times
        return self._keep("duration", longest(self.inner.fraction()))


class Scripted(Chooser):
    """Replays a recorded script, decision by decision."""

    def __init__(self, script: list[tuple[str, Any]]) -> None:
        self.script, self.at = script, 0

    def _next(self, kind: str) -> Any:
        if self.at >= len(self.script):
            raise Diverged(f"the replay asked for a {kind} after the recorded run ended")
        got, value = self.script[self.at]
        self.at += 1
        if got != kind:
            raise Diverged(f"the replay asked for a {kind} where the run decided a {got}")
        return value

    def real(self, what):
        return self._next("real")

    def integer(self, what, lo, hi):
        return self._next("integer")

    def slack(self, strict):
        return self._next("slack")

    def fraction(self):
        return self._next("fraction")

    def duration(self, longest):
        return self._next("duration")
