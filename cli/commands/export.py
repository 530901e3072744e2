"""`certiloop export --kyx`: models as a KeYmaera X archive."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from certiloop.cli import options
from certiloop.cli.errors import EXIT_FAILED, EXIT_OK


def add_parser(sub) -> None:
    export = sub.add_parser(
        "export", help="write models as a KeYmaera X archive (.kyx)",
        description="Write MODEL(s) as one KeYmaera X archive with certiloop's invariants as "
        "@invariant annotations; what .kyx has no syntax for (branch labels, expected verdict) "
        "goes into a /*@certiloop ...*/ comment, so `certiloop prove F.kyx` reads back the same "
        "models. A model .kyx cannot express (arrays, families, integers) is bad input. "
        "With --with-proof, each model is proved first and the archive carries its proof's "
        "annotations instead: every loop's invariant and every ODE's differential-cut chain "
        "(@invariant(c1, c2, ...), cut in that order); a model that is not proved stops the "
        "export (exit 1, nothing written). --rlimit, --timeout and --jobs are the proof's budget.")
    export.add_argument("models", nargs="+", metavar="MODEL", help="library name, family or file")
    export.add_argument("--kyx", action="store_true", required=True, help="the format (the only one)")
    export.add_argument("-o", "--output", metavar="FILE", help="write the archive to FILE (default: stdout)")
    export.add_argument("--with-proof", action="store_true",
                        help="prove each model and annotate it with its proof's loop invariants and "
                        "differential cuts; what the proof used that has no annotation (the rule of each "
                        "cut, ODE solutions, ghosts, weakened arithmetic) is listed in the entry's "
                        "/*@certiloop ...*/ comment under \"proof\"")
    options.budget_flags(export)
    export.add_argument("--jobs", metavar="N", type=int, default=1,
                        help="worker processes for --with-proof (default 1)")


def run(args: argparse.Namespace) -> int:
    from certiloop.api.loading import load_all
    from certiloop.models.kyx import write_archive

    options.check_common(args)
    options.check_outputs(("-o", args.output, "file"))
    theorems = load_all(args.models)
    text = write_archive(theorems)  # NotExpressible is a ModelError: exit 2, before any proof
    if args.with_proof:
        annotated = _proved(theorems, args)
        failed = [a for a in annotated if isinstance(a, str)]
        for reason in failed:
            print(f"certiloop: error: {reason}; --with-proof exports proved models only", file=sys.stderr)
        if failed:
            return EXIT_FAILED
        text = write_archive([a.theorem for a in annotated], [a.notes for a in annotated])
    if args.output:
        Path(args.output).write_text(text)
    else:
        sys.stdout.write(text)
    return EXIT_OK


def _proved(theorems: list, args: argparse.Namespace) -> list:
    """Each theorem with its proof's annotations, or why it is not proved."""
    from certiloop.api.proof_annotations import prove_annotated
    from certiloop.proofs.engine.prover import Prover

    with Prover(jobs=args.jobs, budget=options.budget(args)) as prover:
        out = []
        for theorem in theorems:
            with options.naming(theorem.name):
                out.append(prove_annotated(theorem, prover))
        return out
