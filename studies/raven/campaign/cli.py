"""`certiloop campaign SCENARIO`: fault-injection campaigns of the Raven-II deviation monitor."""

from __future__ import annotations

import argparse
import contextlib
import time
from pathlib import Path
from types import SimpleNamespace

from certiloop.cli import options
from certiloop.cli.errors import EXIT_FAILED, EXIT_OK, BadInput


def add_parser(sub) -> None:
    campaign = sub.add_parser(
        "campaign", help="inject faults into a simulated closed loop and measure the monitor",
        description="Run SCENARIO (raven.stop_margin, raven.haptic_only, raven.no_margin, and "
        "raven.stop_margin_arm, raven.haptic_only_arm with the Raven arm as the plant: one fault per "
        "run, a share of runs without one, drawn from the run's seed; raven.paper: the paper's fixed "
        "4-window experiment, a shoulder DAC override on the arm) and report per fault kind "
        "TP/FP/FN/TN, TPR and FPR with Wilson "
        "95% intervals, F1, detection latency (median, p95) and boundary crossings. Exit 0 if "
        "the scenario's claim holds (stop_margin, haptic_only: no crossing; paper: every window "
        "alarmed, no other alarm), 1 if not (the first crossing run is printed for replay).")
    campaign.add_argument("scenario", metavar="SCENARIO",
                          help="raven.stop_margin, raven.haptic_only, raven.no_margin, "
                          "raven.stop_margin_arm, raven.haptic_only_arm or raven.paper")
    campaign.add_argument("--faults", metavar="KIND,...",
                          help="fault kinds among stuck, delay, drop, jump, noise, drift (default all)")
    campaign.add_argument("--runs", metavar="N", type=int, help="runs (default 1000)")
    campaign.add_argument("--seed", metavar="S", type=int, default=0, help="random seed (default 0)")
    campaign.add_argument("--ticks", metavar="T", type=int,
                          help="1 kHz ticks per run (default 2000, at least 400)")
    campaign.add_argument("--search", action="store_true", help="instead of random runs, let hypothesis "
                          "search the faults for a boundary crossing and shrink the one it finds")
    campaign.add_argument("--max-examples", metavar="N", type=int,
                          help="faults the --search tries (default 500)")
    campaign.add_argument("--jobs", metavar="N", type=int, default=1,
                          help="worker processes for the batches (default 1; results do not change)")
    campaign.add_argument("--executor", metavar="URL", help="run the batches on a Dask scheduler at "
                          "URL (e.g. tcp://host:8786; results do not change)")
    campaign.add_argument("--plot", metavar="F.png", help="write ROC and detection-latency plots to F.png "
                          "(needs matplotlib: pip install 'certiloop[plot]')")
    campaign.add_argument("--csv", metavar="F", help="write one row per run to F (same seed, same bytes)")
    campaign.add_argument("--json", metavar="F", help="write the summary as JSON to F ('-' for stdout)")
    campaign.add_argument("-q", "--quiet", action="store_true", help="print only the summary line")


def fault_kinds(text: str) -> tuple:
    from certiloop.studies.raven.campaign.run import FAULT_KINDS

    if text.strip() == "all":
        return FAULT_KINDS
    kinds = tuple(k.strip() for k in text.split(",") if k.strip())
    bad = [k for k in kinds if k not in FAULT_KINDS]
    if bad or not kinds:
        raise BadInput(f"--faults: unknown fault kind {bad[0] if bad else text!r}; choose among "
                       f"{', '.join(FAULT_KINDS)} or all")
    return tuple(dict.fromkeys(kinds))


def run(args: argparse.Namespace) -> int:
    from certiloop.studies.raven.campaign.run import MAX_RUNS, MAX_SEED, SETUPS

    setup = SETUPS.get(args.scenario)
    if setup is None:
        raise BadInput(f"unknown scenario {args.scenario!r}; choose among {', '.join(SETUPS)}")
    if setup.schedule == "paper":
        flags = (("--faults", args.faults), ("--runs", args.runs), ("--ticks", args.ticks))
        given = [flag for flag, value in flags if value is not None]
        if given:
            raise BadInput(f"{setup.name} is a fixed experiment; {', '.join(given)} does not apply")
    kinds = fault_kinds(args.faults or "all")
    if args.search or args.max_examples is not None:
        return search(args, setup, kinds)
    args.runs = 1000 if args.runs is None else args.runs
    args.ticks = setup.ticks if args.ticks is None else args.ticks
    if not 1 <= args.runs <= MAX_RUNS:
        raise BadInput(f"--runs must be between 1 and {MAX_RUNS:,}, got {args.runs}")
    if not 0 <= args.seed <= MAX_SEED:
        raise BadInput(f"--seed must be between 0 and {MAX_SEED}, got {args.seed}")
    if args.ticks < 400:
        raise BadInput(f"--ticks must be at least 400, got {args.ticks}")
    if args.jobs < 1:
        raise BadInput(f"--jobs must be at least 1, got {args.jobs}")
    if args.jobs > 1 and args.executor:
        raise BadInput("--jobs and --executor exclude each other (the executor has its own workers)")
    options.check_outputs(("--csv", args.csv, "file"), ("--json", args.json, "file or -"),
                   ("--plot", args.plot, "file"))
    if args.plot:
        options.need_matplotlib()
    from certiloop.cli import ui
    from certiloop.studies.raven.campaign.outputs import show_campaign, summary, write_campaign_csv
    from certiloop.studies.raven.campaign.run import run_setup

    out = options.console(stderr=args.json == "-")
    start, batch = time.perf_counter(), 500
    with executor_for(args) as executor, ui.ModelProgress("campaign", 1, not args.quiet) as progress:
        progress.model(setup.name)
        progress.steps(-(-args.runs // batch))
        rows = run_setup(setup, kinds, args.runs, args.seed, args.ticks, batch, on_batch=progress.step,
                         executor=executor)
    doc = summary(setup, rows, kinds, args.seed, args.ticks)
    if args.csv:
        write_campaign_csv(rows, Path(args.csv))
    if args.plot:
        from certiloop.studies.raven.campaign.plots import plot_campaign

        plot_campaign(rows, doc, Path(args.plot))
    options.write_json(args.json, doc)
    show_campaign(out, doc, quiet=args.quiet, seconds=time.perf_counter() - start)
    return EXIT_OK if doc["holds"] else EXIT_FAILED


def search(args: argparse.Namespace, setup, kinds: tuple) -> int:
    """`campaign SCENARIO --search`: hypothesis looks for a crossing fault (exit 1 if found)."""
    from certiloop.studies.raven.campaign.run import MAX_SEED

    if not args.search:
        raise BadInput("--max-examples applies to --search only")
    if setup.schedule == "paper":
        raise BadInput(f"{setup.name} is a fixed experiment; --search does not apply")
    flags = (("--runs", args.runs), ("--csv", args.csv), ("--plot", args.plot), ("--executor", args.executor),
             ("--jobs", args.jobs if args.jobs != 1 else None))
    given = [flag for flag, value in flags if value is not None]
    if given:
        raise BadInput(f"{', '.join(given)} does not apply to --search (one run per fault tried)")
    examples = 500 if args.max_examples is None else args.max_examples
    ticks = setup.ticks if args.ticks is None else args.ticks
    if not 1 <= examples <= 100_000:
        raise BadInput(f"--max-examples must be between 1 and 100,000, got {examples}")
    if not 0 <= args.seed <= MAX_SEED:
        raise BadInput(f"--seed must be between 0 and {MAX_SEED}, got {args.seed}")
    if ticks < 400:
        raise BadInput(f"--ticks must be at least 400, got {ticks}")
    options.check_outputs(("--json", args.json, "file or -"))
    from certiloop.cli import ui
    from certiloop.studies.raven.campaign.fault_search import worst_case
    from certiloop.studies.raven.campaign.outputs import search_summary, show_search

    out = options.console(stderr=args.json == "-")
    start = time.perf_counter()
    with ui.ModelProgress("campaign --search", 1, not args.quiet) as progress:
        progress.model(setup.name)
        result = worst_case(setup, kinds, examples, args.seed, ticks)
    doc = search_summary(setup, result, kinds, args.seed, ticks, examples)
    options.write_json(args.json, doc)
    show_search(out, doc, seconds=time.perf_counter() - start)
    return EXIT_OK if doc["holds"] else EXIT_FAILED


@contextlib.contextmanager
def executor_for(args: argparse.Namespace):
    """The campaign's batches run here: None (this process), a local process pool (--jobs) or a
    Dask cluster (--executor, which the campaign leaves running)."""
    if args.executor:
        from certiloop.proofs.engine.prover import dask_executor

        try:
            executor = dask_executor(args.executor)
        except ImportError as exc:
            raise BadInput(str(exc)) from None
        try:
            yield executor
        finally:
            executor.shutdown(wait=False)
            executor._certiloop_client.close()
    elif args.jobs > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("fork")) as pool:
            yield pool
    else:
        yield None



COMMAND = SimpleNamespace(add_parser=add_parser, run=run)
