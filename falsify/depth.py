"""How deep a run's violation is: the guarantee's smallest margin at the end of the run, against
the float tolerance, so that a float-only violation counts only when rounding cannot explain it.
Shared by the hypothesis search and the batch phase (neither imports the other for it)."""

from __future__ import annotations

from typing import Any

from certiloop.falsify.interpreter import Run

FLOAT_TOLERANCE = 1e-6  # relative: a float-only violation must be deeper than this
FLOAT_ONLY = "floating point only"  # how a check starts that nothing exact or validated confirmed
UNCONFIRMED = "unconfirmed candidate"  # the verdict of a run only floating point shows violating


def depth(run: Run) -> tuple[float, float]:
    """The smallest guarantee margin at the end of the run, and the float tolerance."""
    last = run.checkpoints[-1]
    worst = min(last.margins.values(), default=0.0)
    return worst, FLOAT_TOLERANCE * max([1.0] + [abs(v) for v in _numbers(last.state)])


def is_deep(run: Run) -> bool:
    worst, tolerance = depth(run)
    return worst < -tolerance


def _numbers(state: dict[str, Any]):
    for v in state.values():
        if isinstance(v, dict):
            yield from _numbers(v)
        elif isinstance(v, float):
            yield v


def float_only(run: Run, why: str = "") -> str:
    """The float check, for a run no exact or validated replay confirmed, named as such and
    with why the enclosures failed (or "" if rounding could explain the violation)."""
    worst, tolerance = depth(run)
    if worst < -tolerance:
        return (f"{FLOAT_ONLY}: violated by {-worst:.3g}, beyond the tolerance {tolerance:.1g} "
                f"(not validated{': ' + why if why else ''})")
    return ""
