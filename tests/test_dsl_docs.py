"""Every public DSL construct and every Theorem argument is documented: a docstring, and a
row in the DSL reference page (docs/reference/dsl.md)."""

import dataclasses
import inspect
import re
from pathlib import Path

import certiloop.models as dsl
from certiloop.models import Theorem

PAGE = (Path(__file__).resolve().parent.parent / "docs" / "reference" / "dsl.md").read_text()
REFERENCE = PAGE.split("\n## ", 1)[0]  # the tables before the rendered docstrings
PUBLIC = {name: getattr(dsl, name) for name in dsl.__all__ if name != "lang"}


def test_every_construct_has_its_own_docstring():
    def undocumented(name: str, obj) -> bool:
        doc = (obj.__doc__ or "").strip()
        generated = dataclasses.is_dataclass(obj) and doc.startswith(name + "(")  # the field list
        return not doc or generated

    missing = [name for name, obj in PUBLIC.items()
               if (inspect.isfunction(obj) or inspect.isclass(obj)) and undocumented(name, obj)]
    assert missing == []


def test_every_theorem_argument_is_in_its_docstring_and_the_reference():
    fields = [f.name for f in dataclasses.fields(Theorem)]
    assert fields[:4] == ["name", "assumptions", "program", "guarantee"]
    for name in fields:
        assert re.search(rf"^    {name}: \S", Theorem.__doc__, re.M), name
        assert f"| `{name}` |" in REFERENCE, name


def test_every_public_name_is_in_the_reference_page():
    missing = [name for name in PUBLIC if f"`{name}`" not in REFERENCE]
    assert missing == []
