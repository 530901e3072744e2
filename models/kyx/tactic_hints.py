"""The invariants a KeYmaera X `Tactic` names, read as hints (never trusted).

A tactic is a proof script; certiloop does not run it. It does name the invariants its
author found: `loop("J", 1)` (or ``loop({`J`}, 1)``) proves a loop with invariant J,
`dC("J", 1)` and `diffInvariant("J", 1)` cut J into an ODE, `dI("J", 1)` proves J of it, and
`dG("y'=a*y+b", "P", 1)` proves P with a ghost y (usable here only when P does not mention
the ghost). This module finds those calls in the tactic's text, in the order they are
written. The reader (reader.py) attaches the formulas to the program like `@invariant`
annotations, where the entry has none; the prover proves each hint it uses, so a wrong one
can only cost the proof.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

# tactic -> which argument holds the formula (0-based) and what it is a hint for
_HINT_CALLS = {"loop": (0, "loop"), "dC": (0, "ode"), "diffCut": (0, "ode"),
               "diffInvariant": (0, "ode"), "dI": (0, "ode"), "dG": (1, "ode")}
_CALL = re.compile(r"\b(" + "|".join(_HINT_CALLS) + r")\s*\(")
_ODE_LOCATOR = re.compile(r"^'R\s*==\s*\"\s*\[\s*\{(.*)")


@dataclass(frozen=True)
class Hint:
    kind: str  # loop | ode
    text: str  # the formula as written
    tactic: str  # the call it came from, for notes: `dC`, `loop`, ...
    locator: str = ""  # an ODE named by the call's position (`'R=="[{x'=v...}]..."`): its start
    ghost: str = ""  # dG's ghost ODE (`y'=-y`)


def tactic_hints(text: str) -> list[Hint]:
    """The hints in one tactic's text, in the order they are written."""
    text = re.sub(r"/\*[\s\S]*?\*/", " ", text)
    out: list[Hint] = []
    for m in _CALL.finditer(text):
        if _inside_string(text, m.start()):
            continue
        args = _arguments(text, m.end())
        if args is None:
            continue
        index, kind = _HINT_CALLS[m.group(1)]
        formulas = [_formula(a) for a in args]
        if len(args) <= index or formulas[index] is None:
            continue  # dI(1), loop('R): no formula
        if m.group(1) == "dG" and (len(args) < 2 or formulas[0] is None):
            continue
        locator = ""
        if len(args) > index + 1 and (found := _ODE_LOCATOR.match(args[index + 1].strip())):
            locator = found.group(1)
        ghost = formulas[0] if m.group(1) == "dG" else ""
        out.append(Hint(kind, formulas[index], m.group(1), locator, ghost))
    return out


def _inside_string(text: str, at: int) -> bool:
    """Is position `at` inside a "..." string (a locator's formula mentions `loop(` rarely,
    but a string is never a call)?"""
    quotes = len(re.findall(r'(?<!\\)"', text[:at]))
    return quotes % 2 == 1


def _arguments(text: str, start: int) -> list[str] | None:
    """The call's arguments as written (split at top-level commas), from just after `(`."""
    args: list[str] = []
    depth, i, begin = 0, start, start
    while i < len(text):
        c = text[i]
        if c == '"':
            end = _string_end(text, i)
            if end is None:
                return None
            i = end
        elif c == "{" and text.startswith("{`", i):
            end = text.find("`}", i + 2)
            if end < 0:
                return None
            i = end + 1
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            if depth == 0:
                args.append(text[begin:i])
                return args
            depth -= 1
        elif c == "," and depth == 0:
            args.append(text[begin:i])
            begin = i + 1
        i += 1
    return None


def _string_end(text: str, i: int) -> int | None:
    j = i + 1
    while j < len(text):
        if text[j] == "\\":
            j += 2
            continue
        if text[j] == '"':
            return j
        j += 1
    return None


def _formula(arg: str) -> str | None:
    """The formula of an argument written "J" or {`J`}; None for a position or anything else."""
    arg = arg.strip()
    if len(arg) >= 2 and arg[0] == '"' and arg[-1] == '"':
        return arg[1:-1].replace('\\"', '"')
    if arg.startswith("{`") and arg.endswith("`}"):
        return arg[2:-2]
    return None


__all__ = ["Hint", "tactic_hints"]
