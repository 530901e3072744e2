"""`certiloop gate`: every model against the verdict its author expects (for CI)."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

from certiloop.cli import options
from certiloop.cli.errors import EXIT_FAILED, EXIT_INCONSISTENT, EXIT_OK, BadInput


def add_parser(sub) -> None:
    gate = sub.add_parser(
        "gate", help="check every model against its expected verdict (for CI)",
        description="Prove each MODEL (default: the whole library) and compare with the verdict "
        "its author expects. Exit 0 only if every model met its expectation; a proof that "
        "became 'unknown' fails the gate.")
    gate.add_argument("models", nargs="*", metavar="MODEL",
                      help="library names or path/to/file.py:theorem (default: the library)")
    gate.add_argument("--json", metavar="F", help="write the gate report as JSON to F")
    gate.add_argument("--junit", metavar="F",
                      help="write JUnit XML to F (a test case per model and obligation)")
    gate.add_argument("--markdown", metavar="F",
                      help="append a Markdown summary to F (e.g. $GITHUB_STEP_SUMMARY)")
    gate.add_argument("--html", metavar="F",
                      help="write a self-contained HTML report to F (obligation trees, counterexample "
                      "plots, a search box; no network needed to open it)")
    options.budget_flags(gate)
    options.cross_check_flag(gate)
    gate.add_argument("--jobs", metavar="N", type=int, default=None,
                      help="worker processes (default: number of cores)")
    gate.add_argument("--executor", metavar="URL", help="discharge obligations on a Dask scheduler "
                      "(tcp://host:8786; needs certiloop[distributed])")
    gate.add_argument("--falsify-examples", metavar="N", type=int, default=300,
                      help="falsifier runs per model (default 300; a model expected "
                      "refuted may take 10x as many: the search stops at its first violating run)")
    gate.add_argument("--cache", metavar="DIR", help="proof cache folder (default .certiloop/cache, "
                      "or $CERTILOOP_CACHE)")
    gate.add_argument("--no-cache", action="store_true", help="prove everything afresh")
    options.verbosity_flags(gate, "every model's checks and its obligations not proved")


def run(args: argparse.Namespace) -> int:
    options.check_common(args)
    if args.falsify_examples < 1:
        raise BadInput(f"--falsify-examples must be at least 1, got {args.falsify_examples}")
    options.check_outputs(("--json", args.json, "file"), ("--junit", args.junit, "file"),
                           ("--markdown", args.markdown, "file"), ("--html", args.html, "file"),
                           ("--cache", args.cache, "folder"))
    from certiloop.api.gate_run import GateOptions, run_gate
    from certiloop.api.loading import load_all, project_models
    from certiloop.cli import ui
    from certiloop.cli.gate_view import show_gate
    from certiloop.proofs.engine.cache import Cache

    theorems = load_all(args.models or project_models(), keep_unsupported=True)
    cache = None if args.no_cache else Cache(Path(args.cache) if args.cache else None)
    opts = GateOptions(falsify_examples=args.falsify_examples, cross_check=args.cross_check)
    level = ui.verbosity(args)
    start = time.perf_counter()
    entries: list = []
    budget = options.budget(args)

    def start_prover(stack: contextlib.ExitStack):
        from certiloop.proofs.engine.prover import Prover

        return stack.enter_context(Prover(jobs=args.jobs, budget=budget, executor=args.executor))

    try:
        with contextlib.ExitStack() as stack, \
                ui.ModelProgress("gate:", len(theorems), level > ui.QUIET) as progress:
            run_gate(theorems, lambda: start_prover(stack), budget.rlimit, opts, cache,
                     on_start=progress.model, into=entries)
    except KeyboardInterrupt:
        gate_reports(args, entries, len(theorems))
        raise
    cached = f", {cache.hits} from the cache" if cache and cache.hits else ""
    seconds = time.perf_counter() - start
    show_gate(options.console(), entries, opts.cross_check, level, f"{cached} ({seconds:.1f} s)")
    gate_reports(args, entries, len(theorems))
    if any(e.alarm for e in entries):
        print("certiloop: SOUNDNESS ALARM: an internal inconsistency (see FAIL above); "
              "please report this certiloop bug", file=sys.stderr)
        return EXIT_INCONSISTENT
    return EXIT_OK if all(e.passed for e in entries) else EXIT_FAILED


def gate_reports(args: argparse.Namespace, entries: list, selected: int) -> None:
    """--json, --junit, --markdown and --html; after Ctrl-C, for the models finished, marked partial."""
    from certiloop.cli.gate_html import html_report
    from certiloop.cli.gate_report import junit, markdown

    partial = len(entries) < selected
    if args.json:
        data = [e.to_json() for e in entries]
        options.write_json(args.json, options.json_payload(data, selected, single=False) if partial else data)
    if args.junit:
        Path(args.junit).write_text(junit(entries, selected))
    if args.markdown:
        with open(args.markdown, "a") as fh:  # CI summary files are appended to
            fh.write(markdown(entries, selected))
    if args.html:
        Path(args.html).write_text(html_report(entries, selected), encoding="utf-8")

