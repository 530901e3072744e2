"""The `certiloop` command line. Exit codes: 0 claims hold, 1 a claim failed, 2 bad input."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INCONSISTENT = 0, 1, 2, 3


class BadInput(Exception):
    """A user error: reported on one line, exit 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse prints usage + exits 2; keep it one line
        raise BadInput(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="certiloop",
        description="Prove hybrid-program models of robot controllers safe, or show why they are not.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    listing = sub.add_parser("list", help="models in the library and their expected verdicts",
                             description="List the library's models with their expected verdicts.")
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
    prove.add_argument("-v", "--verbose", action="store_true", help="list every obligation")

    falsify = sub.add_parser(
        "falsify", help="search for a run that violates the guarantee (hypothesis)",
        description="Run MODEL(s) in the interpreter on initial states, choices and durations that "
        "hypothesis draws and steers towards small safety margins, until a run violates the "
        "guarantee; the run is shrunk, re-checked, printed and optionally plotted. Exit 0 if no "
        "counterexample was found, 1 if one was.")
    falsify.add_argument("models", nargs="+", metavar="MODEL",
                         help="library name (sbs.eqn12) or path/to/file.py:theorem")
    falsify.add_argument("--max-examples", metavar="N", type=int, default=2000,
                         help="runs to try per model (default 2000)")
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

    extract = sub.add_parser(
        "extract", help="generate runtime code from a verified model's controller",
        description="Generate a numpy module computing the controller of MODEL (vectorised over "
        "its family of boundaries) from the model's syntax tree. The module carries the model's "
        "content hash; the kernel refuses to run with a model that changed since.")
    extract.add_argument("model", metavar="MODEL", help="library name (sbs.ctrl2) or path/to/file.py:theorem")
    extract.add_argument("-o", "--output", metavar="FILE", help="write the module to FILE (default: stdout)")
    extract.add_argument("--cache", metavar="DIR", help="proof cache folder (default .certiloop/cache, "
                         "or $CERTILOOP_CACHE): a model proved there under this exact claim is not re-proved")
    extract.add_argument("--no-cache", action="store_true", help="prove the model afresh")
    _budget_flags(extract)
    extract.add_argument("--jobs", metavar="N", type=int, default=None,
                         help="worker processes for the proof (default: number of cores)")

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
    return parser


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


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except BadInput as exc:
        print(f"certiloop: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("certiloop: interrupted", file=sys.stderr)
        return 130
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


def _main(argv: list[str] | None) -> int:
    args = build_parser().parse_args(argv)
    if args.command is None:
        build_parser().print_help()
        return EXIT_BAD_INPUT
    if args.command == "list":
        return cmd_list(args.json)
    if args.command == "prove":
        return cmd_prove(args)
    if args.command == "gate":
        return cmd_gate(args)
    if args.command == "falsify":
        return cmd_falsify(args)
    if args.command == "extract":
        return cmd_extract(args)
    raise BadInput(f"unknown command {args.command}")  # pragma: no cover


def console(stderr: bool = False):
    """A rich console; when piped, wide enough that tables do not fold model names."""
    from rich.console import Console

    probe = Console(stderr=stderr)
    return probe if probe.is_terminal else Console(stderr=stderr, width=140)


def cmd_list(as_json: bool = False) -> int:
    from rich.table import Table

    from certiloop.models import library

    if as_json:
        print(json.dumps([{"model": n, "expected": library.get(n).expected,
                           "description": library.get(n).description} for n in library.names()], indent=2))
        return EXIT_OK
    table = Table()
    table.add_column("model", no_wrap=True)
    table.add_column("expected", no_wrap=True)
    table.add_column("what it is")
    for name in library.names():
        t = library.get(name)
        table.add_row(name, t.expected, t.description)
    console().print(table)
    return EXIT_OK


def _check_common(args: argparse.Namespace) -> None:
    if args.timeout <= 0:
        raise BadInput(f"--timeout must be positive, got {args.timeout:g}")
    if args.rlimit < 1:
        raise BadInput(f"--rlimit must be at least 1, got {args.rlimit}")
    if args.jobs is not None and args.jobs < 1:
        raise BadInput(f"--jobs must be at least 1, got {args.jobs}")
    _need_cvc5(args)


def cmd_gate(args: argparse.Namespace) -> int:
    _check_common(args)
    if args.falsify_examples < 1:
        raise BadInput(f"--falsify-examples must be at least 1, got {args.falsify_examples}")
    from rich.console import Console
    from rich.table import Table

    from certiloop.proofs.cli.gate import GateOptions, run_gate
    from certiloop.proofs.cli.gate_report import junit, markdown
    from certiloop.proofs.cli.loading import load_all, project_models
    from certiloop.proofs.cli.report import verdict_text
    from certiloop.proofs.engine.cache import Cache
    from certiloop.proofs.engine.prover import Prover

    theorems = load_all(args.models or project_models())
    cache = None if args.no_cache else Cache(Path(args.cache) if args.cache else None)
    opts = GateOptions(falsify_examples=args.falsify_examples, cross_check=args.cross_check)
    out, err = console(), Console(stderr=True)
    start = time.perf_counter()
    with Prover(jobs=args.jobs, budget=_budget(args), executor=args.executor) as prover:
        if err.is_terminal:
            with err.status("gate") as status:
                entries = run_gate(theorems, prover, opts, cache,
                                   on_model=lambda e: status.update(f"gate: {e.model} done"))
        else:
            entries = run_gate(theorems, prover, opts, cache)
    table = Table(title="certiloop gate")
    columns = ("model", "expected", "verdict", "obligations", "step runs", "falsifier", "replay", "kernel",
               *(("cvc5",) if opts.cross_check else ()), "s", "gate")
    for col in columns:
        table.add_column(col, no_wrap=col != "model", overflow="fold")
    for e in entries:
        proved = sum(o["verdict"] == "proved" for o in e.obligations)
        replay = "-" if e.replay is None else ("violates" if e.replay["violated"] else "FAILS")
        kernel = "-" if e.kernel is None else ("matches" if not e.kernel else "DRIFTED")
        runs = "-" if e.nonblocking is None else verdict_text(e.nonblocking["verdict"])
        cvc5 = (() if not opts.cross_check else
                (f"{e.cross_check['confirmed']}/{e.cross_check['checked']}"
                 + (" DISAGREES" if e.cross_check["disagreements"] else ""),) if e.cross_check else ("-",))
        table.add_row(e.model, e.expected, verdict_text(e.verdict), f"{proved}/{len(e.obligations)}", runs,
                      e.falsify.get("verdict", "-"), replay, kernel, *cvc5,
                      f"{e.seconds:.2f}" + (" (cached)" if e.cached else ""),
                      "[green]PASS[/]" if e.passed else "[bold red]FAIL[/]")
    out.print(table)
    failed = [e for e in entries if not e.passed]
    for e in failed:
        out.print(f"FAIL {e.model}: {e.message}", highlight=False, markup=False)
    cached = f", {cache.hits} from the cache" if cache and cache.hits else ""
    out.print(f"{len(entries) - len(failed)} passed, {len(failed)} failed{cached} "
              f"({time.perf_counter() - start:.1f} s)", highlight=False)
    if args.json:
        Path(args.json).write_text(json.dumps([e.to_json() for e in entries], indent=2) + "\n")
    if args.junit:
        Path(args.junit).write_text(junit(entries))
    if args.markdown:
        with open(args.markdown, "a") as fh:  # CI summary files are appended to
            fh.write(markdown(entries))
    if any(e.alarm for e in entries):
        print("certiloop: SOUNDNESS ALARM: an internal inconsistency (see FAIL above); "
              "please report this certiloop bug", file=sys.stderr)
        return EXIT_INCONSISTENT
    return EXIT_OK if not failed else EXIT_FAILED


def _budget(args: argparse.Namespace):
    from certiloop.proofs.engine.budget import Budget

    return Budget(rlimit=args.rlimit, wall_s=args.timeout)


def cmd_prove(args: argparse.Namespace) -> int:
    _check_common(args)
    from certiloop.proofs.cli.loading import load_all

    theorems = load_all(args.models)  # all bad names fail before any work

    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from certiloop.proofs.cli.report import show_result
    from certiloop.proofs.engine.prover import Prover

    out = console(stderr=args.json == "-")
    err = Console(stderr=True)
    results = []
    with Prover(jobs=args.jobs, budget=_budget(args), executor=args.executor) as prover:
        for theorem in theorems:
            smt_dir = Path(args.smtlib) if args.smtlib else None
            if err.is_terminal:
                with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                              TimeElapsedColumn(), console=err, transient=True) as bar:
                    task = bar.add_task(f"proving {theorem.name}", total=None)
                    result = prover.prove(theorem,
                                          on_start=lambda n, t=task: bar.update(t, total=n),
                                          on_result=lambda r, t=task: bar.advance(t), smtlib_dir=smt_dir)
            else:
                result = prover.prove(theorem, smtlib_dir=smt_dir)
            if args.cross_check:
                _cross_check(result, err)
            show_result(out, result, verbose=args.verbose)
            results.append(result)
    if args.json:
        payload = results[0].to_json() if len(results) == 1 else [r.to_json() for r in results]
        text = json.dumps(payload, indent=2)
        if args.json == "-":
            print(text)
        else:
            Path(args.json).write_text(text + "\n")
    alarms = [r for r in results if r.extra.get("cross_check", {}).get("disagreements")]
    for r in alarms:
        print(f"certiloop: SOUNDNESS ALARM: cvc5 disagrees with z3 on {r.model}: "
              f"{r.extra['cross_check']['summary']}; please report this certiloop bug", file=sys.stderr)
    if alarms or any(r.inconsistent for r in results):
        return EXIT_INCONSISTENT
    for r in results:
        if r.ill_defined:
            print(f"certiloop: error: {r.model} is {r.reason}", file=sys.stderr)
    if any(r.ill_defined for r in results):
        return EXIT_BAD_INPUT
    all_proved = all(r.verdict == "proved" and r.nonblocking_verdict in (None, "proved") for r in results)
    return EXIT_OK if all_proved else EXIT_FAILED


def _cross_check(result, err) -> None:
    """cvc5's opinion on every form z3 proved, kept in the result (shown, and in --json)."""
    from certiloop.proofs.engine.second_opinion import second_opinion

    obligations = result.obligations + (result.nonblocking or [])
    if err.is_terminal:
        with err.status(f"cross-checking {result.model} with cvc5"):
            opinion = second_opinion(obligations)
    else:
        opinion = second_opinion(obligations)
    result.extra["cross_check"] = {**opinion.to_json(), "summary": opinion.summary}


def cmd_extract(args: argparse.Namespace) -> int:
    """Extract only what is proved: the model must prove now, or have a cache entry for its
    exact claim (canonical text, certiloop source, z3 and sympy versions)."""
    _check_common(args)
    from certiloop.kernel.extract import extract
    from certiloop.proofs.cli.loading import load
    from certiloop.proofs.engine.cache import Cache
    from certiloop.proofs.engine.prover import Prover

    theorem = load(args.model)
    out_path = _writable(args.output) if args.output else None
    cache = None if args.no_cache else Cache(Path(args.cache) if args.cache else None)
    key = cache.key("proof", theorem.canonical) if cache else None
    cached = cache.get(key) if cache else None
    if cached is not None and cached.get("verdict") == "proved":
        verdict, reason = "proved", ""
    else:
        with Prover(jobs=args.jobs, budget=_budget(args)) as prover:
            result = prover.prove(theorem)
        verdict, reason = result.verdict, result.reason
        if cache and verdict == "proved":
            cache.put(key, {"model": theorem.name, "verdict": verdict})
    if verdict != "proved":
        why = f": {reason}" if reason else ""
        print(f"certiloop: error: refusing to extract {theorem.name}: it is {verdict}, not proved{why}",
              file=sys.stderr)
        return EXIT_FAILED
    source = extract(theorem)
    if out_path is not None:
        out_path.write_text(source)
        console(stderr=True).print(f"wrote {args.output} (from the proved model {theorem.name})",
                                   highlight=False, markup=False)
    else:
        sys.stdout.write(source)
    return EXIT_OK


def _writable(name: str) -> Path:
    """An output path whose folder exists (checked before any work is done)."""
    path = Path(name)
    if not path.parent.is_dir():
        raise BadInput(f"cannot write {name}: the folder {path.parent} does not exist")
    if path.is_dir():
        raise BadInput(f"cannot write {name}: it is a folder")
    return path


def cmd_falsify(args: argparse.Namespace) -> int:
    if args.max_examples < 1:
        raise BadInput(f"--max-examples must be at least 1, got {args.max_examples}")
    if args.max_family < 1:
        raise BadInput(f"--max-family must be at least 1, got {args.max_family}")
    if args.steps < 1:
        raise BadInput(f"--steps must be at least 1, got {args.steps}")
    if args.plot and not args.plot.lower().endswith(".png"):
        raise BadInput(f"--plot writes a PNG file; give a name ending in .png, not {args.plot!r}")
    if args.plot:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            raise BadInput("--plot needs matplotlib: pip install 'certiloop[plot]'") from None
    from certiloop.proofs.cli.loading import load_all

    theorems = load_all(args.models)

    from rich.console import Console

    from certiloop.falsify.report import show_falsification
    from certiloop.falsify.search import Options, falsify

    database = None if args.database.lower() == "none" else Path(args.database)
    opts = Options(max_examples=args.max_examples, seed=args.seed, families=(1, args.max_family),
                   max_steps=args.steps, database=database)
    out, err = console(stderr=args.json == "-"), Console(stderr=True)
    results = []
    for theorem in theorems:
        if err.is_terminal:
            with err.status(f"falsifying {theorem.name} (up to {args.max_examples} examples)"):
                result = falsify(theorem, opts)
        else:
            result = falsify(theorem, opts)
        show_falsification(out, result)
        if args.plot and result.run is not None:
            from certiloop.falsify.plots import plot_run

            target = Path(args.plot)
            if len(theorems) > 1:
                target = target.with_name(f"{target.stem}-{theorem.name}{target.suffix}")
            plot_run(result.run, theorem.name, target)
            out.print(f"  plot: {target}", highlight=False, markup=False)
        results.append(result)
    if args.json:
        payload = results[0].to_json() if len(results) == 1 else [r.to_json() for r in results]
        text = json.dumps(payload, indent=2)
        if args.json == "-":
            print(text)
        else:
            Path(args.json).write_text(text + "\n")
    return EXIT_FAILED if any(r.found for r in results) else EXIT_OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
