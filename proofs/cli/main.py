"""The `certiloop` command line. Exit codes: 0 claims hold, 1 a claim failed, 2 bad input."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from pathlib import Path

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INCONSISTENT, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


class BadInput(Exception):
    """A user error: reported on one line, exit 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse prints usage + exits 2; keep it one line
        raise BadInput(f"{message} (see `{self.prog} --help`)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="certiloop",
        description="Prove hybrid-program models of robot controllers safe, or show why they are not.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    listing = sub.add_parser("list", help="models in the library and their expected verdicts",
                             description="List the library's models with their expected verdicts.")
    listing.add_argument("models", nargs="*", metavar="MODEL",
                         help="list only these (a family, path/to/file.py:theorem, FILE.kyx[:\"Entry\"])")
    listing.add_argument("--json", action="store_true",
                         help="print [{\"model\", \"expected\", \"description\"}] instead of a table")

    prove = sub.add_parser(
        "prove", help="generate and discharge proof obligations",
        description="Prove MODEL(s): split each into proof obligations, discharge them with z3, "
        "and, if any is not proved, search for a run that violates the guarantee. "
        "Exit 0 if every obligation of every model is proved, 1 otherwise.")
    prove.add_argument("models", nargs="+", metavar="MODEL",
                       help="library name (sbs.ctrl1) or path/to/file.py:theorem")
    prove.add_argument("--json", metavar="F", help="write results as JSON to F ('-' for stdout)")
    prove.add_argument("--smtlib", metavar="DIR", help="write every obligation as an SMT-LIB 2.6 file")
    _budget_flags(prove)
    _cross_check_flag(prove)
    prove.add_argument("--jobs", metavar="N", type=int, default=None,
                       help="worker processes (default: number of cores)")
    prove.add_argument("--executor", metavar="URL", help="discharge obligations on a Dask scheduler "
                       "(tcp://host:8786; needs certiloop[distributed])")
    _verbosity_flags(prove, "every obligation with its backend or reason")

    falsify = sub.add_parser(
        "falsify", help="search for a run that violates the guarantee (hypothesis)",
        description="Run MODEL(s) in the interpreter on initial states, choices and durations that "
        "hypothesis draws and steers towards small safety margins, until a run violates the "
        "guarantee; the run is shrunk, re-checked, printed and optionally plotted. Exit 0 if no "
        "counterexample was found, 1 if one was. The kernel scenarios rcm.push_euler, "
        "rcm.push_guarded, rcm.push_semi_implicit, rcm.push_capsule and rcm.push_capsule_guarded "
        "instead search a surgeon's push on seed 001's 7-DOF controller for one that enters the "
        "forbidden region, confirmed by a brute-force replay.")
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
    _verbosity_flags(falsify, "every safety margin at the end of a violating run")

    extract = sub.add_parser(
        "extract", help="generate runtime code from a verified model's controller",
        description="Generate a numpy module computing the controller of MODEL (vectorised over "
        "its family of boundaries) from the model's syntax tree, or with --lang c a C99 source and "
        "header. The code carries the model's content hash; the kernel refuses to run with a model "
        "that changed since.")
    extract.add_argument("model", metavar="MODEL", help="library name (sbs.ctrl2) or path/to/file.py:theorem")
    extract.add_argument("-o", "--output", metavar="FILE|DIR", help="write the module to FILE (default: "
                         "stdout); with --lang c, the folder DIR gets MODEL.c and MODEL.h")
    extract.add_argument("--lang", choices=("python", "c"), default="python",
                         help="python (default): a numpy module; c: C99 source and header, no allocation, "
                         "libm only")
    extract.add_argument("--cache", metavar="DIR", help="proof cache folder (default .certiloop/cache, "
                         "or $CERTILOOP_CACHE): a model proved there under this exact claim is not re-proved")
    extract.add_argument("--no-cache", action="store_true", help="prove the model afresh")
    extract.add_argument("--monitors", action="store_true",
                         help="write the model's ModelPlex-style monitors (controller_monitor, "
                         "plant_monitor) instead of its controller")
    _budget_flags(extract)
    extract.add_argument("--jobs", metavar="N", type=int, default=None,
                         help="worker processes for the proof (default: number of cores)")
    _verbosity_flags(extract, "the proof's obligations (on stderr)")

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
    _budget_flags(gate)
    _cross_check_flag(gate)
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
    _verbosity_flags(gate, "every model's checks and its obligations not proved")

    export = sub.add_parser(
        "export", help="write models as a KeYmaera X archive (.kyx)",
        description="Write MODEL(s) as one KeYmaera X archive with certiloop's invariants as "
        "@invariant annotations; what .kyx has no syntax for (branch labels, expected verdict) "
        "goes into a /*@certiloop ...*/ comment, so `certiloop prove F.kyx` reads back the same "
        "models. A model .kyx cannot express (arrays, families, integers) is bad input.")
    export.add_argument("models", nargs="+", metavar="MODEL", help="library name, family or file")
    export.add_argument("--kyx", action="store_true", required=True, help="the format (the only one)")
    export.add_argument("-o", "--output", metavar="FILE", help="write the archive to FILE (default: stdout)")

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

    plan = sub.add_parser(
        "plan", help="plan Raven-II motions with FMT* (OMPL) and certify every returned path",
        description="Run FMT* (OMPL's og.FMT; needs certiloop[plan]) R times on SCENARIO with N "
        "samples, seeds S, S+1, ...; every returned path is proved clear segment by segment with "
        "interval arithmetic and re-checked independently before it counts as a success. Exit 0 "
        "if some run returned a certified path, 1 if none did.")
    plan.add_argument("scenario", metavar="SCENARIO", help="raven.frs_box (the paper's FRS-dome scene)")
    plan.add_argument("--samples", metavar="N", type=int, required=True, help="FMT* samples per run")
    plan.add_argument("--runs", metavar="R", type=int, default=1, help="runs (default 1)")
    plan.add_argument("--eta", metavar="ETA1,ETA2", default="0.1,0.5",
                      help="eq 1's weights of path length and tip acceleration (default 0.1,0.5, Table 2's)")
    plan.add_argument("--seed", metavar="S", type=int, default=0, help="seed of run 0 (default 0)")
    plan.add_argument("--radius-multiplier", metavar="X", type=float,
                      help="FMT*'s radius multiplier on eq 2's r_n (default OMPL's 1.1)")
    plan.add_argument("--wall-cap", metavar="S", type=float, default=600.0,
                      help="wall-clock guard per run (default 600 s): reaching it is a failure that "
                      "says so; the verdict otherwise depends only on samples and seed")
    plan.add_argument("--json", metavar="F", help="write {\"runs\": [...], ...} to F ('-' for stdout)")
    plan.add_argument("-q", "--quiet", action="store_true", help="print only the summary line")

    check_path = sub.add_parser(
        "check-path", help="re-check the certificates of a `certiloop plan --json` file",
        description="Re-check every certified path in FILE independently (mpmath interval "
        "arithmetic over the Raven-II DH chain): exit 0 if every segment is proved clear of "
        "the scene, 1 naming the first bad segment.")
    check_path.add_argument("file", metavar="FILE", help="a `certiloop plan --json` output")
    return parser


def _verbosity_flags(parser: argparse.ArgumentParser, verbose_shows: str) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true",
                       help="print only what failed and the final summary line")
    group.add_argument("-v", "--verbose", action="store_true", help=f"also print {verbose_shows}")


def _budget_flags(parser: argparse.ArgumentParser) -> None:
    from certiloop.proofs.engine.budget import DEFAULT_RLIMIT, DEFAULT_WALL_S

    parser.add_argument("--rlimit", metavar="N", type=int, default=DEFAULT_RLIMIT,
                        help=f"z3 resource units per obligation before it is 'unknown' (default "
                        f"{DEFAULT_RLIMIT:,}); verdicts depend on this, never on the clock")
    parser.add_argument("--timeout", metavar="S", type=float, default=DEFAULT_WALL_S,
                        help=f"wall-clock safety net per solver call (default {DEFAULT_WALL_S:g} s; "
                        "run searches 5x): reaching it gives 'unknown' and says so. Only a guard "
                        "against a stalled solver; --rlimit is the budget")


def _cross_check_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cross-check", action="store_true",
                        help="re-check every proved obligation with cvc5 (needs certiloop[crosscheck]); "
                        "a disagreement is a soundness alarm and fails the run (exit 3)")


def _need_cvc5(args: argparse.Namespace) -> None:
    if getattr(args, "cross_check", False):
        try:
            import cvc5  # noqa: F401
        except ImportError:
            from certiloop.proofs.arith.crosscheck import MISSING

            raise BadInput(MISSING) from None


def run() -> None:
    """The `certiloop` command: main(), and after Ctrl-C an exit at once. The reports are
    written by then, and the interpreter's exit would only wait for the worker pool's thread,
    sometimes printing "Exception ignored ... Bad file descriptor" after "interrupted"."""
    code = main()
    if code == EXIT_INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


def main(argv: list[str] | None = None) -> int:
    from certiloop.proofs.cli import guards

    restore = guards.on_interrupt_exit_quietly()
    restore_gc = guards.collect_garbage_less_often()
    try:
        return _main(argv)
    except (BadInput, guards.OutputPathError) as exc:
        print(f"certiloop: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("certiloop: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return EXIT_FAILED
    except ImportError as exc:
        print(f"certiloop: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as exc:  # never a traceback for users; CERTILOOP_DEBUG=1 shows it
        if os.environ.get("CERTILOOP_DEBUG"):
            raise
        from certiloop.models.lang.terms import ModelError

        if isinstance(exc, ModelError):
            print(f"certiloop: error: {exc}", file=sys.stderr)
            return EXIT_BAD_INPUT
        print(f"certiloop: internal error: {type(exc).__name__}: {exc} "
              "(set CERTILOOP_DEBUG=1 for the traceback)", file=sys.stderr)
        return EXIT_BAD_INPUT
    finally:
        restore_gc()
        restore()


def _main(argv: list[str] | None) -> int:
    args = build_parser().parse_args(argv)
    if args.command is None:
        build_parser().print_help()
        return EXIT_BAD_INPUT
    if args.command == "list":
        return cmd_list(args.json, args.models)
    if args.command == "export":
        return cmd_export(args)
    if args.command == "prove":
        return cmd_prove(args)
    if args.command == "gate":
        return cmd_gate(args)
    if args.command == "falsify":
        return cmd_falsify(args)
    if args.command == "extract":
        return cmd_extract(args)
    if args.command == "campaign":
        return cmd_campaign(args)
    if args.command in ("plan", "check-path"):
        return cmd_plan_or_check(args)
    raise BadInput(f"unknown command {args.command}")  # pragma: no cover


def console(stderr: bool = False):
    """A rich console as wide as the terminal; when piped, $COLUMNS or 80 columns, no colour."""
    from certiloop.proofs.cli import ui

    return ui.console(stderr)


def cmd_list(as_json: bool = False, models: list[str] | None = None) -> int:
    from rich.markup import escape

    from certiloop.models import library
    from certiloop.proofs.cli import ui
    from certiloop.proofs.cli.loading import Unsupported, load_all

    found = load_all(models, keep_unsupported=True) if models else [library.get(n) for n in library.names()]
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
    if _narrowest(out, table) <= out.width:
        out.print(table)
    else:  # names too long for a table at this width: a paragraph per model
        for name, expected, what in rows:
            ui.say(out, f"{name} ({expected}): {what}")
    return EXIT_OK


def cmd_export(args: argparse.Namespace) -> int:
    from certiloop.models.kyx import write_archive
    from certiloop.proofs.cli.loading import load_all

    _check_outputs(("-o", args.output, "file"))
    text = write_archive(load_all(args.models))  # NotExpressible is a ModelError: exit 2
    if args.output:
        Path(args.output).write_text(text)
    else:
        sys.stdout.write(text)
    return EXIT_OK


def _narrowest(out, table) -> int:
    """The width `table` needs with its wrapping columns squeezed to their minimum."""
    from rich.measure import Measurement

    return Measurement.get(out, out.options, table).minimum


def _check_common(args: argparse.Namespace) -> None:
    if args.timeout <= 0:
        raise BadInput(f"--timeout must be positive, got {args.timeout:g}")
    if args.rlimit < 1:
        raise BadInput(f"--rlimit must be at least 1, got {args.rlimit}")
    if args.jobs is not None and args.jobs < 1:
        raise BadInput(f"--jobs must be at least 1, got {args.jobs}")
    _need_cvc5(args)


def _check_outputs(*outputs: tuple[str, str | None, str]) -> None:
    """(flag, path, what) for every output: 'file', 'file or -' (stdout) or 'folder'. All are
    checked before any work, so a typo does not cost a whole run."""
    from certiloop.proofs.cli import guards

    for flag, name, what in outputs:
        guards.check_output(flag, name, folder=what == "folder", stdout_ok=what == "file or -")


def _json_payload(done: list[dict], selected: int, single: bool = True):
    """The --json document: one object for one model (when `single`), else a list; an
    interrupted run's is an object marked partial with the models finished so far."""
    if len(done) < selected:
        return {"partial": True, "finished": len(done), "selected": selected, "results": done}
    return done[0] if single and len(done) == 1 else done


def _need_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise BadInput("--plot needs matplotlib: pip install 'certiloop[plot]'") from None


def _write_json(target: str | None, payload) -> None:
    if not target:
        return
    text = json.dumps(payload, indent=2)
    if target == "-":
        print(text)
    else:
        Path(target).write_text(text + "\n")


def cmd_gate(args: argparse.Namespace) -> int:
    _check_common(args)
    if args.falsify_examples < 1:
        raise BadInput(f"--falsify-examples must be at least 1, got {args.falsify_examples}")
    _check_outputs(("--json", args.json, "file"), ("--junit", args.junit, "file"),
                   ("--markdown", args.markdown, "file"), ("--cache", args.cache, "folder"))
    from certiloop.proofs.cli import ui
    from certiloop.proofs.cli.gate import GateOptions, run_gate
    from certiloop.proofs.cli.gate_view import show_gate
    from certiloop.proofs.cli.loading import load_all, project_models
    from certiloop.proofs.engine.cache import Cache

    theorems = load_all(args.models or project_models(), keep_unsupported=True)
    cache = None if args.no_cache else Cache(Path(args.cache) if args.cache else None)
    opts = GateOptions(falsify_examples=args.falsify_examples, cross_check=args.cross_check)
    level = ui.verbosity(args)
    start = time.perf_counter()
    entries: list = []
    budget = _budget(args)

    def start_prover(stack: contextlib.ExitStack):
        from certiloop.proofs.engine.prover import Prover

        return stack.enter_context(Prover(jobs=args.jobs, budget=budget, executor=args.executor))

    try:
        with contextlib.ExitStack() as stack, \
                ui.ModelProgress("gate:", len(theorems), level > ui.QUIET) as progress:
            run_gate(theorems, lambda: start_prover(stack), budget.rlimit, opts, cache,
                     on_start=progress.model, into=entries)
    except KeyboardInterrupt:
        _gate_reports(args, entries, len(theorems))
        raise
    cached = f", {cache.hits} from the cache" if cache and cache.hits else ""
    show_gate(console(), entries, opts.cross_check, level, f"{cached} ({time.perf_counter() - start:.1f} s)")
    _gate_reports(args, entries, len(theorems))
    if any(e.alarm for e in entries):
        print("certiloop: SOUNDNESS ALARM: an internal inconsistency (see FAIL above); "
              "please report this certiloop bug", file=sys.stderr)
        return EXIT_INCONSISTENT
    return EXIT_OK if all(e.passed for e in entries) else EXIT_FAILED


def _gate_reports(args: argparse.Namespace, entries: list, selected: int) -> None:
    """--json, --junit and --markdown; after Ctrl-C, for the models finished, marked partial."""
    from certiloop.proofs.cli.gate_report import junit, markdown

    partial = len(entries) < selected
    if args.json:
        data = [e.to_json() for e in entries]
        _write_json(args.json, _json_payload(data, selected, single=False) if partial else data)
    if args.junit:
        Path(args.junit).write_text(junit(entries, selected))
    if args.markdown:
        with open(args.markdown, "a") as fh:  # CI summary files are appended to
            fh.write(markdown(entries, selected))


def _budget(args: argparse.Namespace):
    from certiloop.proofs.engine.budget import Budget

    return Budget(rlimit=args.rlimit, wall_s=args.timeout)


def cmd_prove(args: argparse.Namespace) -> int:
    _check_common(args)
    _check_outputs(("--json", args.json, "file or -"), ("--smtlib", args.smtlib, "folder"))
    from certiloop.proofs.cli.loading import Unsupported, load_all

    theorems = load_all(args.models, keep_unsupported=True)  # all bad names fail before any work

    from certiloop.models.lang.terms import ModelError
    from certiloop.proofs.cli import ui
    from certiloop.proofs.cli.report import show_result, show_unsupported
    from certiloop.proofs.engine.prover import Prover

    out, level = console(stderr=args.json == "-"), ui.verbosity(args)
    smt_dir = Path(args.smtlib) if args.smtlib else None
    start, results, docs, unsupported = time.perf_counter(), [], [], []
    try:
        with Prover(jobs=args.jobs, budget=_budget(args), executor=args.executor) as prover, \
                ui.ModelProgress("proving", len(theorems), level > ui.QUIET) as progress:
            for theorem in theorems:
                progress.model(theorem.name)
                try:
                    with _naming(theorem.name):
                        if isinstance(theorem, Unsupported):
                            raise ModelError(theorem.reason)
                        result = prover.prove(theorem, on_start=progress.steps, on_result=progress.step,
                                              smtlib_dir=smt_dir)
                except ModelError as exc:  # one of several models: its row, and the others run
                    if len(theorems) == 1:
                        raise
                    unsupported.append(Unsupported(theorem.name, str(exc).removeprefix(f"{theorem.name}: ")))
                    show_unsupported(out, theorem.name, unsupported[-1].reason)
                    docs.append(unsupported[-1].to_json())
                    continue
                if args.cross_check:
                    _cross_check(result)
                show_result(out, result, level)
                results.append(result)
                docs.append(result.to_json())
    except KeyboardInterrupt:
        _write_json(args.json, _json_payload(docs, len(theorems)))
        raise
    proved = sum(r.verdict == "proved" for r in results)
    missing = f", {len(unsupported)} not supported" if unsupported else ""
    ui.say(out, f"{proved} of {len(theorems)} model{'s' * (len(theorems) != 1)} proved{missing} "
                f"({time.perf_counter() - start:.1f} s)")
    _write_json(args.json, _json_payload(docs, len(theorems)))
    return _prove_exit(results, unsupported)


@contextlib.contextmanager
def _naming(model: str):
    """A model the engine cannot handle (a rule it lacks) is bad input: say which model."""
    from certiloop.models.lang.terms import ModelError

    try:
        yield
    except ModelError as exc:
        if model in str(exc):
            raise
        raise ModelError(f"{model}: {exc}") from None


def _prove_exit(results: list, unsupported: list = ()) -> int:
    alarms = [r for r in results if r.extra.get("cross_check", {}).get("disagreements")]
    for r in alarms:
        print(f"certiloop: SOUNDNESS ALARM: cvc5 disagrees with z3 on {r.model}: "
              f"{r.extra['cross_check']['summary']}; please report this certiloop bug", file=sys.stderr)
    if alarms or any(r.inconsistent for r in results):
        return EXIT_INCONSISTENT
    for r in results:
        if r.ill_defined:
            print(f"certiloop: error: {r.model} is {r.reason}", file=sys.stderr)
    _name_unsupported(unsupported)
    if any(r.ill_defined for r in results) or unsupported:
        return EXIT_BAD_INPUT
    all_proved = all(r.verdict == "proved" and r.nonblocking_verdict in (None, "proved") for r in results)
    return EXIT_OK if all_proved else EXIT_FAILED


def _name_unsupported(unsupported: list) -> None:
    """Models certiloop cannot read or handle are bad input (exit 2): the first, on stderr."""
    if unsupported:
        more = f" (and {len(unsupported) - 1} more)" if len(unsupported) > 1 else ""
        print(f"certiloop: error: {unsupported[0].name} is not supported{more}: {unsupported[0].reason}",
              file=sys.stderr)


def _cross_check(result) -> None:
    """cvc5's opinion on every form z3 proved, kept in the result (shown, and in --json)."""
    from certiloop.proofs.engine.second_opinion import second_opinion

    opinion = second_opinion(result.obligations + (result.nonblocking or []))
    result.extra["cross_check"] = {**opinion.to_json(), "summary": opinion.summary}


def cmd_extract(args: argparse.Namespace) -> int:
    """Extract only what is proved: the model must prove now, or have a cache entry for its
    exact claim (canonical text, certiloop source, z3 and sympy versions)."""
    _check_common(args)
    if args.lang == "c" and args.monitors:
        raise BadInput("--monitors writes the Python monitors; leave out --lang c")
    if args.lang == "c" and not args.output:
        raise BadInput("--lang c writes two files (MODEL.c and MODEL.h); give the folder with -o DIR")
    _check_outputs(("--output", args.output, "folder" if args.lang == "c" else "file"),
                   ("--cache", args.cache, "folder"))
    from certiloop.kernel.extract import extract
    from certiloop.kernel.extract.c import extract_c
    from certiloop.proofs.cli import ui
    from certiloop.proofs.cli.loading import load
    from certiloop.proofs.cli.report import show_result
    from certiloop.proofs.engine.cache import Cache
    from certiloop.proofs.engine.prover import Prover

    theorem = load(args.model)
    level, err = ui.verbosity(args), console(stderr=True)
    cache = None if args.no_cache else Cache(Path(args.cache) if args.cache else None)
    key = cache.key("proof", theorem.canonical) if cache else None
    cached = cache.get(key) if cache else None
    if cached is not None and cached.get("verdict") == "proved":
        verdict, reason = "proved", ""
        if level == ui.VERBOSE:
            ui.say(err, f"{theorem.name}: proved (from the proof cache)")
    else:
        with Prover(jobs=args.jobs, budget=_budget(args)) as prover:
            result = prover.prove(theorem)
        if level == ui.VERBOSE:
            show_result(err, result, level)
        verdict, reason = result.verdict, result.reason
        if cache and verdict == "proved":
            cache.put(key, {"model": theorem.name, "verdict": verdict})
    if verdict != "proved":
        why = f": {reason}" if reason else ""
        print(f"certiloop: error: refusing to extract {theorem.name}: it is {verdict}, not proved{why}",
              file=sys.stderr)
        return EXIT_FAILED
    if args.lang == "c":
        from certiloop.kernel.extract.c import compile_error

        files = extract_c(theorem)
        problem = compile_error(files)
        if problem is not None:
            print(f"certiloop: error: the C generated for {theorem.name} does not compile ({problem}); "
                  "nothing was written: please report it with the model", file=sys.stderr)
            return EXIT_FAILED
        folder = Path(args.output)
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in files.items():
            (folder / name).write_text(text)
        if level > ui.QUIET:
            ui.say(err, f"wrote {', '.join(str(folder / n) for n in files)} (from the proved model "
                   f"{theorem.name})")
        return EXIT_OK
    if args.monitors:
        from certiloop.kernel.extract.modelplex import monitors

        source = monitors(theorem)
    else:
        source = extract(theorem)
    if args.output:
        Path(args.output).write_text(source)
        if level > ui.QUIET:
            ui.say(err, f"wrote {args.output} (from the proved model {theorem.name})")
    else:
        sys.stdout.write(source)
    return EXIT_OK


def _check_falsify_args(args: argparse.Namespace) -> None:
    if args.max_examples is None:
        from certiloop.proofs.cli.push_cmd import is_push_scenario

        args.max_examples = 60 if any(is_push_scenario(n) for n in args.models) else 2000
    if args.max_examples < 1:
        raise BadInput(f"--max-examples must be at least 1, got {args.max_examples}")
    if args.max_family < 1:
        raise BadInput(f"--max-family must be at least 1, got {args.max_family}")
    if args.steps < 1:
        raise BadInput(f"--steps must be at least 1, got {args.steps}")
    if args.plot and not args.plot.lower().endswith(".png"):
        raise BadInput(f"--plot writes a PNG file; give a name ending in .png, not {args.plot!r}")
    database = None if args.database.lower() == "none" else args.database
    _check_outputs(("--json", args.json, "file or -"), ("--plot", args.plot, "file"),
                   ("--database", database, "folder"))
    if args.plot:
        _need_matplotlib()


def cmd_falsify(args: argparse.Namespace) -> int:
    _check_falsify_args(args)
    from certiloop.proofs.cli import push_cmd

    pushes = [push_cmd.is_push_scenario(n) for n in args.models]
    if any(pushes):
        if not all(pushes):
            raise BadInput("kernel scenarios (rcm.push_*) and models cannot be falsified in one call")
        from certiloop.proofs.cli import ui

        try:
            code, docs = push_cmd.run(args, console(stderr=args.json == "-"), ui.verbosity(args))
        except ValueError as exc:
            raise BadInput(str(exc)) from None
        _write_json(args.json, _json_payload(docs, len(docs)))
        return code
    from certiloop.proofs.cli.loading import Unsupported, load_all

    theorems = load_all(args.models, keep_unsupported=True)

    from certiloop.falsify.report import show_falsification
    from certiloop.falsify.search import Options, falsify
    from certiloop.models.lang.terms import ModelError
    from certiloop.proofs.cli import ui
    from certiloop.proofs.cli.report import show_unsupported

    database = None if args.database.lower() == "none" else Path(args.database)
    opts = Options(max_examples=args.max_examples, seed=args.seed, families=(1, args.max_family),
                   max_steps=args.steps, database=database)
    out, level = console(stderr=args.json == "-"), ui.verbosity(args)
    start, results, docs, unsupported = time.perf_counter(), [], [], []
    try:
        with ui.ModelProgress("falsifying", len(theorems), level > ui.QUIET) as progress:
            for theorem in theorems:
                progress.model(theorem.name)
                try:
                    with _naming(theorem.name):
                        if isinstance(theorem, Unsupported):
                            raise ModelError(theorem.reason)
                        result = falsify(theorem, opts)
                except ModelError as exc:  # one of several models: its row, and the others run
                    if len(theorems) == 1:
                        raise
                    unsupported.append(Unsupported(theorem.name, str(exc).removeprefix(f"{theorem.name}: ")))
                    show_unsupported(out, theorem.name, unsupported[-1].reason)
                    docs.append(unsupported[-1].to_json())
                    continue
                show_falsification(out, result, level)
                if args.plot and result.run is not None:
                    _plot(args.plot, result, theorem.name, len(theorems) > 1, out, level)
                results.append(result)
                docs.append(result.to_json())
    except KeyboardInterrupt:
        _write_json(args.json, _json_payload(docs, len(theorems)))
        raise
    found = sum(r.found for r in results)
    missing = f", {len(unsupported)} not supported" if unsupported else ""
    ui.say(out, f"{found} of {len(theorems)} model{'s' * (len(theorems) != 1)} with a violating run"
                f"{missing} ({time.perf_counter() - start:.1f} s)")
    _write_json(args.json, _json_payload(docs, len(theorems)))
    _name_unsupported(unsupported)
    return EXIT_BAD_INPUT if unsupported else EXIT_FAILED if found else EXIT_OK


def _plot(name: str, result, model: str, several: bool, out, level: int) -> None:
    from certiloop.falsify.plots import plot_run
    from certiloop.proofs.cli import ui

    target = Path(name)
    if several:
        target = target.with_name(f"{target.stem}-{model}{target.suffix}")
    plot_run(result.run, model, target)
    if level > ui.QUIET:
        ui.say(out, f"  plot: {target}")


def _campaign_kinds(text: str) -> tuple:
    from certiloop.falsify.campaign import FAULT_KINDS

    if text.strip() == "all":
        return FAULT_KINDS
    kinds = tuple(k.strip() for k in text.split(",") if k.strip())
    bad = [k for k in kinds if k not in FAULT_KINDS]
    if bad or not kinds:
        raise BadInput(f"--faults: unknown fault kind {bad[0] if bad else text!r}; choose among "
                       f"{', '.join(FAULT_KINDS)} or all")
    return tuple(dict.fromkeys(kinds))


def cmd_campaign(args: argparse.Namespace) -> int:
    from certiloop.falsify.campaign import MAX_RUNS, MAX_SEED, SETUPS

    setup = SETUPS.get(args.scenario)
    if setup is None:
        raise BadInput(f"unknown scenario {args.scenario!r}; choose among {', '.join(SETUPS)}")
    if setup.schedule == "paper":
        flags = (("--faults", args.faults), ("--runs", args.runs), ("--ticks", args.ticks))
        given = [flag for flag, value in flags if value is not None]
        if given:
            raise BadInput(f"{setup.name} is a fixed experiment; {', '.join(given)} does not apply")
    kinds = _campaign_kinds(args.faults or "all")
    if args.search or args.max_examples is not None:
        return _campaign_search(args, setup, kinds)
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
    _check_outputs(("--csv", args.csv, "file"), ("--json", args.json, "file or -"),
                   ("--plot", args.plot, "file"))
    if args.plot:
        _need_matplotlib()
    from certiloop.falsify.campaign import run_setup
    from certiloop.falsify.campaign_report import show_campaign, summary, write_campaign_csv
    from certiloop.proofs.cli import ui

    out = console(stderr=args.json == "-")
    start, batch = time.perf_counter(), 500
    with _campaign_executor(args) as executor, ui.ModelProgress("campaign", 1, not args.quiet) as progress:
        progress.model(setup.name)
        progress.steps(-(-args.runs // batch))
        rows = run_setup(setup, kinds, args.runs, args.seed, args.ticks, batch, on_batch=progress.step,
                         executor=executor)
    doc = summary(setup, rows, kinds, args.seed, args.ticks)
    if args.csv:
        write_campaign_csv(rows, Path(args.csv))
    if args.plot:
        from certiloop.falsify.campaign_plots import plot_campaign

        plot_campaign(rows, doc, Path(args.plot))
    _write_json(args.json, doc)
    show_campaign(out, doc, quiet=args.quiet, seconds=time.perf_counter() - start)
    return EXIT_OK if doc["holds"] else EXIT_FAILED


def _campaign_search(args: argparse.Namespace, setup, kinds: tuple) -> int:
    """`campaign SCENARIO --search`: hypothesis looks for a crossing fault (exit 1 if found)."""
    from certiloop.falsify.campaign import MAX_SEED

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
    _check_outputs(("--json", args.json, "file or -"))
    from certiloop.falsify.campaign_report import search_summary, show_search
    from certiloop.falsify.campaign_search import worst_case
    from certiloop.proofs.cli import ui

    out = console(stderr=args.json == "-")
    start = time.perf_counter()
    with ui.ModelProgress("campaign --search", 1, not args.quiet) as progress:
        progress.model(setup.name)
        result = worst_case(setup, kinds, examples, args.seed, ticks)
    doc = search_summary(setup, result, kinds, args.seed, ticks, examples)
    _write_json(args.json, doc)
    show_search(out, doc, seconds=time.perf_counter() - start)
    return EXIT_OK if doc["holds"] else EXIT_FAILED


@contextlib.contextmanager
def _campaign_executor(args: argparse.Namespace):
    """The campaign's batches run here: None (this process), a local process pool (--jobs) or a
    Dask cluster (--executor, which the campaign leaves running)."""
    if args.executor:
        from certiloop.proofs.engine.prover import _dask_executor

        try:
            executor = _dask_executor(args.executor)
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


def cmd_plan_or_check(args: argparse.Namespace) -> int:
    from certiloop.proofs.cli import plan_cmd, ui

    try:
        if args.command == "check-path":
            return plan_cmd.cmd_check_path(args, console())
        _check_outputs(("--json", args.json, "file or -"))
        with ui.ModelProgress("planning", 1, not args.quiet) as progress:
            return plan_cmd.cmd_plan(args, console(stderr=args.json == "-"), progress)
    except plan_cmd.PlanInputError as exc:
        raise BadInput(str(exc)) from None


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
