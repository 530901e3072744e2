"""`certiloop list`: the models and their expected verdicts."""

from __future__ import annotations

import argparse
import json
import sys

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
    from certiloop.cli import list_cache

    key = list_cache.key(as_json, models)
    text = list_cache.read(key)
    if text is None:
        text, library_only = _listing(as_json, models)
        if library_only:
            list_cache.write(key, text)
    sys.stdout.write(text)
    sys.stdout.flush()
    return EXIT_OK


def _library_only(specs: list[str]) -> bool:
    """Whether every MODEL names library models (a name or a family), so the listing depends only
    on certiloop's and the studies' sources."""
    from certiloop.models import library

    names = set(library.names())
    return all(s in names or ("." not in s and any(n.startswith(f"{s}.") for n in names)) for s in specs)


def _listing(as_json: bool, models: list[str] | None) -> tuple[str, bool]:
    """What `certiloop list` prints, and whether it may be stored."""
    from rich.markup import escape

    from certiloop.api.loading import Unsupported, load_all, project_models
    from certiloop.cli import ui

    # the same default as `certiloop gate`: the project's models, else the library
    specs = models or project_models()
    found = load_all(specs, keep_unsupported=True)
    # an archive entry certiloop cannot read is listed, its reason where the description goes
    rows = [(t.name, "not supported", t.reason) if isinstance(t, Unsupported) else
            (t.name, t.expected, t.description) for t in found]
    if as_json:
        return json.dumps([{"model": name, "expected": expected, "description": what}
                           for name, expected, what in rows], indent=2) + "\n", _library_only(specs)
    out = ui.console()
    table = ui.table(out)
    table.add_column("model", no_wrap=True)
    table.add_column("expected", no_wrap=True)
    table.add_column("what it is", min_width=20)
    for name, expected, what in rows:
        table.add_row(escape(name), expected, escape(what))
    out.begin_capture()
    try:
        if options.narrowest(out, table) <= out.width:
            out.print(table)
        else:  # names too long for a table at this width: a paragraph per model
            for name, expected, what in rows:
                ui.say(out, f"{name} ({expected}): {what}")
    finally:
        text = out.end_capture()
    return text, _library_only(specs)
