"""certiloop.models: the modelling language (terms, formulas, hybrid programs, theorems).

Its names load on first use (PEP 562): `certiloop list` and `--help` reach the model registry
(`certiloop.models.library.registry`) through this package without building the language."""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the same names for type checkers, IDEs and the documentation (read statically)
    from certiloop.models.lang.conveniences import Ite, assign_min, dot, for_range, foreach, if_
    from certiloop.models.lang.programs import (
        ODE,
        Assign,
        Choice,
        Havoc,
        Loop,
        Program,
        Seq,
        Test,
        assign,
        branch,
        choice,
        havoc,
        loop,
        ode,
        seq,
        skip,
        test,
    )
    from certiloop.models.lang.roles import Roles
    from certiloop.models.lang.terms import (
        BOOL,
        FALSE,
        INT,
        REAL,
        TRUE,
        And,
        Array,
        Bool,
        Box,
        Diamond,
        Exists,
        Family,
        ForAll,
        Iff,
        Implies,
        IndexSort,
        Int,
        Ints,
        ModelError,
        Node,
        Not,
        Or,
        Real,
        Reals,
        Var,
    )
    from certiloop.models.lang.theorem import Theorem

_HOME = {
    **dict.fromkeys((
        "ODE", "Assign", "Choice", "Havoc", "Loop", "Program", "Seq", "Test", "assign", "branch",
        "choice", "havoc", "loop", "ode", "seq", "skip", "test",
    ), "certiloop.models.lang.programs"),
    **dict.fromkeys(("Ite", "assign_min", "dot", "for_range", "foreach", "if_"),
                    "certiloop.models.lang.conveniences"),
    **dict.fromkeys((
        "BOOL", "FALSE", "INT", "REAL", "TRUE", "And", "Array", "Bool", "Box", "Diamond", "Exists",
        "Family", "ForAll", "Iff", "Implies", "IndexSort", "Int", "Ints", "ModelError",
        "Node", "Not", "Or", "Real", "Reals", "Var",
    ), "certiloop.models.lang.terms"),
    **dict.fromkeys((
        "Roles",
    ), "certiloop.models.lang.roles"),
    **dict.fromkeys((
        "Theorem",
    ), "certiloop.models.lang.theorem"),
}

__all__ = sorted(_HOME)


def __getattr__(name: str):
    if name in _HOME:
        value = getattr(import_module(_HOME[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOME))
