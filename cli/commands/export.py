"""`certiloop export --kyx`: models as a KeYmaera X archive."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from certiloop.cli import options
from certiloop.cli.errors import EXIT_OK


def add_parser(sub) -> None:
    export = sub.add_parser(
        "export", help="write models as a KeYmaera X archive (.kyx)",
        description="Write MODEL(s) as one KeYmaera X archive with certiloop's invariants as "
        "@invariant annotations; what .kyx has no syntax for (branch labels, expected verdict) "
        "goes into a /*@certiloop ...*/ comment, so `certiloop prove F.kyx` reads back the same "
        "models. A model .kyx cannot express (arrays, families, integers) is bad input.")
    export.add_argument("models", nargs="+", metavar="MODEL", help="library name, family or file")
    export.add_argument("--kyx", action="store_true", required=True, help="the format (the only one)")
    export.add_argument("-o", "--output", metavar="FILE", help="write the archive to FILE (default: stdout)")


def run(args: argparse.Namespace) -> int:
    from certiloop.api.loading import load_all
    from certiloop.models.kyx import write_archive

    options.check_outputs(("-o", args.output, "file"))
    text = write_archive(load_all(args.models))  # NotExpressible is a ModelError: exit 2
    if args.output:
        Path(args.output).write_text(text)
    else:
        sys.stdout.write(text)
    return EXIT_OK

