"""`certiloop list`: the models and their expected verdicts."""

from __future__ import annotations

import argparse
import json

from certiloop.cli import options
from certiloop.cli.errors import EXIT_OK


def add_parser(sub) -> None:
    listing = sub.add_parser("list", help="models in the library and their expected verdicts",
                             description="List models with their expected verdicts: the MODELs named, else "
                             "[tool.certiloop] models in ./pyproject.toml, else the whole library.")
    listing.add_argument("models", nargs="*", metavar="MODEL",
                         help="list only these (a family, path/to/file.py:theorem, FILE.kyx[:\"Entry\"])")
    listing.add_argument("--json", action="store_true",
                         help="print [{\"model\", \"expected\", \"description\"}] instead of a table")


def run(args: argparse.Namespace) -> int:
    return list_models(args.json, args.models)


def list_models(as_json: bool = False, models: list[str] | None = None) -> int:
    from rich.markup import escape

    from certiloop.api.loading import Unsupported, load_all, project_models
    from certiloop.cli import ui

    # the same default as `certiloop gate`: the project's models, else the library
    found = load_all(models or project_models(), keep_unsupported=True)
    # an archive entry certiloop cannot read is listed, its reason where the description goes
    rows = [(t.name, "not supported", t.reason) if isinstance(t, Unsupported) else
            (t.name, t.expected, t.description) for t in found]
    if as_json:
        print(json.dumps([{"model": name, "expected": expected, "description": what}
                          for name, expected, what in rows], indent=2))
        return EXIT_OK
    out = ui.console()
    table = ui.table(out)
    table.add_column("model", no_wrap=True)
    table.add_column("expected", no_wrap=True)
    table.add_column("what it is", min_width=20)
    for name, expected, what in rows:
        table.add_row(escape(name), expected, escape(what))
    if options.narrowest(out, table) <= out.width:
        out.print(table)
    else:  # names too long for a table at this width: a paragraph per model
        for name, expected, what in rows:
            ui.say(out, f"{name} ({expected}): {what}")
    return EXIT_OK

