"""`certiloop check-proof`: re-check proof certificates with the separate checker (proofs/checker)."""

from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

from certiloop.cli import options


def add_parser(sub) -> None:
    check = sub.add_parser(
        "check-proof", help="re-check proof certificates written by `prove --certificate`",
        description="Re-derive each certificate's proof from its theorem with the small separate "
        "checker and re-decide every arithmetic leaf. Exit 0 if every certificate is accepted, "
        "1 if one is rejected (the first failing step is named), 2 if one is malformed.")
    check.add_argument("files", nargs="+", metavar="FILE", help="certificate JSON file(s)")
    check.add_argument("--smtlib", metavar="DIR", help="also write each re-derived arithmetic leaf as an "
                       "SMT-LIB 2.6 file (assert the negation: `unsat` proves it)")


def run(args: argparse.Namespace) -> int:
    options.check_outputs(("--smtlib", args.smtlib, "folder"))
    from certiloop.proofs.checker import check_file

    worst = 0
    for name in args.files:
        start = time.perf_counter()
        outcome = check_file(name)
        print(f"{name}: {outcome.message} ({time.perf_counter() - start:.2f} s)")
        worst = max(worst, outcome.exit_code)
        if args.smtlib and outcome.leaves:
            folder = Path(args.smtlib)
            folder.mkdir(parents=True, exist_ok=True)
            stem = re.sub(r"[^\w.+=-]+", "_", Path(name).name.removesuffix(".json")).strip("_")
            for leaf, text in outcome.leaves:
                (folder / f"{stem}.{leaf}.smt2").write_text(text)
    return worst
