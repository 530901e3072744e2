"""The model library: dotted names -> theorem builders, in the order `certiloop list` shows.

The textbook systems are built in; each case study adds its models through the registry
(`registry.py`), so this package imports none of them."""

from __future__ import annotations

import difflib
from functools import cache
from typing import TYPE_CHECKING

from certiloop.models.library.registry import resolve, studies

if TYPE_CHECKING:
    from certiloop.models.lang.theorem import Theorem

TEXTBOOK_ORDER = 30  # between the dual-arm planner and the RCM controller, as the list always showed
TEXTBOOK = {name: f"certiloop.models.library.textbook:{name}" for name in (
    "bouncing_ball", "bouncing_ball_superelastic", "train", "train_no_lookahead", "water_tank",
    "water_tank_late_check", "cart_forward", "cart_may_brake", "adaptive_cruise",
    "adaptive_cruise_no_lookahead")}


@cache
def _builders() -> dict[str, str]:
    textbook = {f"textbook.{name}": target for name, target in TEXTBOOK.items()}
    builders: dict[str, str] = {}
    placed = False
    for study in studies():
        if study.order > TEXTBOOK_ORDER and not placed:
            builders.update(textbook)
            placed = True
        builders.update(study.models)
    if not placed:
        builders.update(textbook)
    return builders


def names() -> list[str]:
    return list(_builders())


def get(name: str) -> Theorem:
    from certiloop.models.lang.terms import ModelError

    builders = _builders()
    try:
        target = builders[name]
    except KeyError:
        close = difflib.get_close_matches(name, list(builders), n=3, cutoff=0.6)
        hint = f"; did you mean {', '.join(close[:3])}?" if close else "; `certiloop list` shows them"
        raise ModelError(f"unknown model {name!r}{hint}") from None
    theorem = resolve(target)()
    if theorem.name != name:
        raise ModelError(f"library entry {name} builds a theorem named {theorem.name}")
    return theorem
