"""What several commands share: their common flags, the checks made before any work, and the
JSON and console output."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path

from certiloop.cli.errors import BadInput


def verbosity_flags(parser: argparse.ArgumentParser, verbose_shows: str) -> None:
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true",
                       help="print only what failed and the final summary line")
    group.add_argument("-v", "--verbose", action="store_true", help=f"also print {verbose_shows}")


def budget_flags(parser: argparse.ArgumentParser) -> None:
    from certiloop.proofs.engine.budget import DEFAULT_RLIMIT, DEFAULT_WALL_S

    parser.add_argument("--rlimit", metavar="N", type=int, default=DEFAULT_RLIMIT,
                        help=f"z3 resource units per obligation before it is 'unknown' (default "
                        f"{DEFAULT_RLIMIT:,}); verdicts depend on this, never on the clock")
    parser.add_argument("--timeout", metavar="S", type=float, default=DEFAULT_WALL_S,
                        help=f"wall-clock safety net per solver call (default {DEFAULT_WALL_S:g} s; "
                        "run searches 5x): reaching it gives 'unknown' and says so. Only a guard "
                        "against a stalled solver; --rlimit is the budget")


def cross_check_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cross-check", action="store_true",
                        help="re-check every proved obligation with cvc5 (needs certiloop[crosscheck]); "
                        "a disagreement is a soundness alarm and fails the run (exit 3)")


def need_cvc5(args: argparse.Namespace) -> None:
    if getattr(args, "cross_check", False):
        try:
            import cvc5  # noqa: F401
        except ImportError:
            from certiloop.proofs.arith.crosscheck import MISSING

            raise BadInput(MISSING) from None


def console(stderr: bool = False):
    """A rich console as wide as the terminal; when piped, $COLUMNS or 80 columns, no colour."""
    from certiloop.cli import ui

    return ui.console(stderr)


def narrowest(out, table) -> int:
    """The width `table` needs with its wrapping columns squeezed to their minimum."""
    from rich.measure import Measurement

    return Measurement.get(out, out.options, table).minimum


MAX_TIMEOUT_S = 10**6  # a wall-clock safety net beyond this is none (and overflows as milliseconds)
MAX_JOBS = 256  # worker processes: more would only exhaust the machine


def check_common(args: argparse.Namespace) -> None:
    if not 0 < args.timeout <= MAX_TIMEOUT_S:  # NaN fails this too
        raise BadInput(f"--timeout must be a positive number of seconds up to {MAX_TIMEOUT_S:,}, "
                       f"got {args.timeout:g}")
    if args.rlimit < 1:
        raise BadInput(f"--rlimit must be at least 1, got {args.rlimit}")
    check_jobs(args.jobs)
    need_cvc5(args)


def check_jobs(jobs: int | None) -> None:
    if jobs is not None and jobs < 1:
        raise BadInput(f"--jobs must be at least 1, got {jobs}")
    if jobs is not None and jobs > MAX_JOBS:
        raise BadInput(f"--jobs must be at most {MAX_JOBS} (one process each), got {jobs}")


def check_outputs(*outputs: tuple[str, str | None, str]) -> None:
    """(flag, path, what) for every output: 'file', 'file or -' (stdout) or 'folder'. All are
    checked before any work, so a typo does not cost a whole run."""
    from certiloop.cli import guards

    for flag, name, what in outputs:
        guards.check_output(flag, name, folder=what == "folder", stdout_ok=what == "file or -")


def json_payload(done: list[dict], selected: int, single: bool = True):
    """The --json document: one object for one model (when `single`), else a list; an
    interrupted run's is an object marked partial with the models finished so far."""
    if len(done) < selected:
        return {"partial": True, "finished": len(done), "selected": selected, "results": done}
    return done[0] if single and len(done) == 1 else done


def need_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise BadInput("--plot needs matplotlib: pip install 'certiloop[plot]'") from None


def write_json(target: str | None, payload) -> None:
    if not target:
        return
    text = json.dumps(payload, indent=2)
    if target == "-":
        print(text)
    else:
        Path(target).write_text(text + "\n")


def budget(args: argparse.Namespace):
    from certiloop.proofs.engine.budget import Budget

    return Budget(rlimit=args.rlimit, wall_s=args.timeout)


@contextlib.contextmanager
def naming(model: str):
    """A model the engine cannot handle (a rule it lacks) is bad input: say which model."""
    from certiloop.models.lang.terms import ModelError

    try:
        yield
    except ModelError as exc:
        if model in str(exc):
            raise
        raise ModelError(f"{model}: {exc}") from None


def name_unsupported(unsupported: list) -> None:
    """Models certiloop cannot read or handle are bad input (exit 2): the first, on stderr."""
    if unsupported:
        more = f" (and {len(unsupported) - 1} more)" if len(unsupported) > 1 else ""
        print(f"certiloop: error: {unsupported[0].name} is not supported{more}: {unsupported[0].reason}",
              file=sys.stderr)



def own_row(exc: Exception) -> bool:
    """A model's error that becomes its own row among several: a model certiloop cannot
    handle, or an internal error in it (unless CERTILOOP_DEBUG asks for the traceback)."""
    import os

    from certiloop.models.lang.terms import ModelError

    return isinstance(exc, ModelError) or not os.environ.get("CERTILOOP_DEBUG")


def row_reason(model: str, exc: Exception) -> str:
    from certiloop.models.lang.terms import ModelError

    if isinstance(exc, ModelError):
        return str(exc).removeprefix(f"{model}: ")
    return f"internal error: {type(exc).__name__}: {exc} (set CERTILOOP_DEBUG=1 for the traceback)"
