"""The registry of case studies: what each one adds to certiloop, found without importing it.

A case study is a package (certiloop's own live in `studies/`; a user's may live anywhere) that
declares one `Study` and names it in the entry-point group `certiloop.studies` of its
distribution. Everything a study adds is named by "module:attribute" strings, resolved only when
used, so `certiloop list` does not import a study's numpy simulators and the generic packages
never import a study by name.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from functools import cache
from importlib.metadata import entry_points

GROUP = "certiloop.studies"


@dataclass(frozen=True)
class Study:
    """One case study's contributions.

    name       the package's short name (`sbs`)
    title      the paper it comes from, as the docs name it
    order      where its models come in `certiloop list` (smaller first)
    models     model name -> "module:builder" (a function returning the Theorem)
    commands   CLI command -> "module:attribute" of an object with `add_parser(subparsers)` and
               `run(args) -> exit code` (the study's scenarios: campaigns, plans)
    falsify    scenario name prefix -> "module:run" for `certiloop falsify SCENARIO` on a
               kernel scenario instead of a model (`rcm.push_`)
    generated  model name -> (path of the generated Python module relative to the study's folder,
               path of the folder holding its generated C or "")
    """

    name: str
    title: str
    order: int
    models: dict[str, str] = field(default_factory=dict)
    commands: dict[str, str] = field(default_factory=dict)
    falsify: dict[str, str] = field(default_factory=dict)
    generated: dict[str, tuple[str, str]] = field(default_factory=dict)
    package: str = ""


def resolve(target: str):
    """The object a "module:attribute" string names."""
    module, _, attribute = target.partition(":")
    return getattr(importlib.import_module(module), attribute)


@cache
def studies() -> tuple[Study, ...]:
    """Every installed study, in `order`."""
    found = []
    for point in entry_points(group=GROUP):
        study = point.load()
        if not isinstance(study, Study):
            raise TypeError(f"entry point {point.name} of {GROUP} is not a certiloop Study: {point.value}")
        found.append(study)
    return tuple(sorted(found, key=lambda s: (s.order, s.name)))
