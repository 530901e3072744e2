"""`certiloop falsify`: search for a run that violates the guarantee."""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from certiloop.cli import options
from certiloop.cli.errors import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, BadInput


def add_parser(sub) -> None:
    falsify = sub.add_parser(
        "falsify", help="search for a run that violates the guarantee (hypothesis)",
        description="Run MODEL(s) in the interpreter on initial states, choices and durations that "
        "hypothesis draws and steers towards small safety margins, until a run violates the "
        "guarantee; the run is shrunk, re-checked, printed and optionally plotted. Exit 0 if no "
        "counterexample was found, 1 if one was. A case study's kernel scenario (such as the RCM "
        "controller's rcm.push_*, see `certiloop list` and the study's docs) instead searches the "
        "study's own simulator, confirmed by its brute-force replay.")
    falsify.add_argument("models", nargs="+", metavar="MODEL",  # or kernel scenarios rcm.push_*
                         help="library name (sbs.eqn12) or path/to/file.py:theorem")
    falsify.add_argument("--max-examples", metavar="N", type=int,
                         help="runs to try per model (default 2000; for rcm.push_* scenarios: human-force "
                         "profiles per search round, default 60)")
    falsify.add_argument("--seed", metavar="S", type=int, default=0, help="random seed (default 0)")
    falsify.add_argument("--json", metavar="F", help="write the result with the full trace as JSON to F "
                         "('-' for stdout)")
    falsify.add_argument("--plot", metavar="F.png", help="plot the run: margins over time and the tool path")
    falsify.add_argument("--max-family", metavar="N", type=int, default=8,
                         help="largest family of boundaries to try (default 8)")
    falsify.add_argument("--steps", metavar="N", type=int, default=3,
                         help="most control-loop iterations per run (default 3)")
    falsify.add_argument("--database", metavar="DIR", default=".certiloop/hypothesis",
                         help="hypothesis example database, so failures are found again first "
                         "(default .certiloop/hypothesis; 'none' to disable)")
    falsify.add_argument("--jobs", metavar="N", type=int, default=None,
                         help="processes (default: 2 on a machine with 2 cores or more): hypothesis searches "
                         "beside the batch phase, with the same result as one after the other")
    options.verbosity_flags(falsify, "every safety margin at the end of a violating run")


def kernel_scenario(name: str) -> str:
    """The "module:run" of the case study whose kernel scenarios `name` names, else ""."""
    from certiloop.models.library.registry import studies

    for study in studies():
        for prefix, target in study.falsify.items():
            if name.startswith(prefix):
                return target
    return ""


def check_falsify_args(args: argparse.Namespace) -> None:
    if args.max_examples is None:
        args.max_examples = 60 if any(kernel_scenario(n) for n in args.models) else 2000
    if args.max_examples < 1:
        raise BadInput(f"--max-examples must be at least 1, got {args.max_examples}")
    if args.max_family < 1:
        raise BadInput(f"--max-family must be at least 1, got {args.max_family}")
    if args.steps < 1:
        raise BadInput(f"--steps must be at least 1, got {args.steps}")
    options.check_jobs(args.jobs)
    if args.seed < 0:
        raise BadInput(f"--seed must be a non-negative integer, got {args.seed}")
    if args.plot and not args.plot.lower().endswith(".png"):
        raise BadInput(f"--plot writes a PNG file; give a name ending in .png, not {args.plot!r}")
    database = None if args.database.lower() == "none" else args.database
    options.check_outputs(("--json", args.json, "file or -"), ("--plot", args.plot, "file"),
                   ("--database", database, "folder"))
    if args.plot:
        options.need_matplotlib()


def run(args: argparse.Namespace) -> int:
    check_falsify_args(args)
    searches = [kernel_scenario(n) for n in args.models]
    if any(searches):
        if not all(searches) or len(set(searches)) > 1:
            raise BadInput("a kernel scenario cannot be falsified in one call with models or other studies' "
                           "scenarios; give them separately")
        from certiloop.cli import ui
        from certiloop.models.library.registry import resolve

        try:
            out = options.console(stderr=args.json == "-")
            code, docs = resolve(searches[0])(args, out, ui.verbosity(args))
        except ValueError as exc:
            raise BadInput(str(exc)) from None
        options.write_json(args.json, options.json_payload(docs, len(docs)))
        return code
    from certiloop import api
    from certiloop.api.loading import Unsupported, load_all

    theorems = load_all(args.models, keep_unsupported=True)

    from certiloop.cli import ui
    from certiloop.cli.proof_table import show_unsupported
    from certiloop.falsify.report import show_falsification
    from certiloop.models.lang.terms import ModelError

    database = None if args.database.lower() == "none" else Path(args.database)
    search = {"max_examples": args.max_examples, "seed": args.seed, "families": (1, args.max_family),
              "max_steps": args.steps, "database": database,
              "jobs": args.jobs if args.jobs is not None else min(2, os.cpu_count() or 1)}
    out, level = options.console(stderr=args.json == "-"), ui.verbosity(args)
    start, results, docs, unsupported = time.perf_counter(), [], [], []
    try:
        with ui.ModelProgress("falsifying", len(theorems), level > ui.QUIET) as progress:
            for theorem in theorems:
                progress.model(theorem.name)
                try:
                    with options.naming(theorem.name):
                        if isinstance(theorem, Unsupported):
                            raise ModelError(theorem.reason)
                        result = api.falsify(theorem, **search)
                except Exception as exc:  # one of several models: its row, and the others run
                    if len(theorems) == 1 or not options.own_row(exc):
                        raise
                    unsupported.append(Unsupported(theorem.name, options.row_reason(theorem.name, exc)))
                    show_unsupported(out, theorem.name, unsupported[-1].reason)
                    docs.append(unsupported[-1].to_json())
                    continue
                show_falsification(out, result, level)
                if args.plot and result.run is not None:
                    plot(args.plot, result, theorem.name, len(theorems) > 1, out, level)
                results.append(result)
                docs.append(result.to_json())
    except KeyboardInterrupt:
        options.write_json(args.json, options.json_payload(docs, len(theorems)))
        raise
    found = sum(r.found for r in results)  # confirmed runs only: a float-only candidate is not one
    missing = f", {len(unsupported)} not supported" if unsupported else ""
    candidates = sum(r.candidate for r in results)
    unconfirmed = f", {candidates} with an unconfirmed candidate only" if candidates else ""
    ui.say(out, f"{found} of {len(theorems)} model{'s' * (len(theorems) != 1)} with a violating run"
                f"{unconfirmed}{missing} ({time.perf_counter() - start:.1f} s)")
    options.write_json(args.json, options.json_payload(docs, len(theorems)))
    options.name_unsupported(unsupported)
    return EXIT_BAD_INPUT if unsupported else EXIT_FAILED if found else EXIT_OK


def plot(name: str, result, model: str, several: bool, out, level: int) -> None:
    from certiloop.cli import ui
    from certiloop.falsify.plots import plot_run

    target = Path(name)
    if several:
        target = target.with_name(f"{target.stem}-{model}{target.suffix}")
    plot_run(result.run, model, target)
    if level > ui.QUIET:
        ui.say(out, f"  plot: {target}")

