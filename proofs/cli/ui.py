"""What the command line shows around the results: consoles that fit the terminal (80 columns
when piped), tables that fit or fold, progress on a terminal only, verbosity, and the
checks and signals that must come before any work (output paths, Ctrl-C)."""

from __future__ import annotations

import io
import os
import signal
import sys
import textwrap
from pathlib import Path
from typing import Callable

from rich import box
from rich.console import Console
from rich.table import Table

QUIET, NORMAL, VERBOSE = -1, 0, 1
EXIT_INTERRUPTED = 130

# piped output: a header rule and nothing else (no box drawing, no colour, no spinner)
PLAIN = box.Box("    \n    \n -- \n    \n    \n    \n    \n    \n", ascii=True)


def console(stderr: bool = False) -> Console:
    """A console as wide as the terminal; when piped, $COLUMNS or 80 columns and no colour."""
    return Console(stderr=stderr, highlight=False)


def table(out: Console, title: str | None = None) -> Table:
    return Table(title=title, box=box.HEAVY_HEAD if out.is_terminal else PLAIN, expand=False,
                 show_edge=out.is_terminal)


def width_of(renderable) -> int:
    """The widest line of `renderable` printed with no width limit."""
    probe = Console(file=io.StringIO(), width=10_000, color_system=None)
    probe.print(renderable)
    return max((len(line.rstrip()) for line in probe.file.getvalue().splitlines()), default=0)


def fits(out: Console, renderable) -> bool:
    return width_of(renderable) <= out.width


def say(out: Console, text: str, indent: str = "  ") -> None:
    """Plain text wrapped at the console's width between words, continuation lines indented;
    a word (a model name, a verdict) is never split."""
    lead = len(text) - len(text.lstrip(" "))
    lines = textwrap.wrap(text, width=out.width, subsequent_indent=" " * lead + indent,
                          break_long_words=False, break_on_hyphens=False) or [""]
    for line in lines:
        out.print(line, markup=False, highlight=False, soft_wrap=True)


def verbosity(args) -> int:
    if getattr(args, "quiet", False):
        return QUIET
    return VERBOSE if getattr(args, "verbose", False) else NORMAL


class ModelProgress:
    """`proving 2/5 models: sbs.ctrl2` on stderr, only when stderr is a terminal (and not
    with --quiet); optionally a bar of the current model's obligations."""

    def __init__(self, verb: str, total: int, enabled: bool = True) -> None:
        self.verb, self.total, self.index = verb, total, 0
        err = Console(stderr=True)
        self.bar = None
        if enabled and err.is_terminal:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                                TimeElapsedColumn(), console=err, transient=True,
                                # results printed meanwhile go above the bar when stdout is this
                                # terminal too, and straight to stdout when it is not
                                redirect_stdout=sys.stdout.isatty(), redirect_stderr=False)
            self.task = self.bar.add_task("", total=None)

    def __enter__(self) -> "ModelProgress":
        if self.bar is not None:
            self.bar.start()
        return self

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.bar.stop()

    def model(self, name: str) -> None:
        """The next model starts."""
        self.index += 1
        if self.bar is not None:
            self.bar.reset(self.task, total=None,
                           description=f"{self.verb} {self.index}/{self.total} models: {name}")

    def steps(self, n: int) -> None:
        """The current model has n steps (obligations) to go."""
        if self.bar is not None:
            self.bar.update(self.task, total=n)

    def step(self, *_) -> None:
        if self.bar is not None:
            self.bar.advance(self.task)


# --------------------------------------------------------------------------- before any work


class OutputPathError(Exception):
    pass


def check_output(flag: str, name: str | None, folder: bool = False, stdout_ok: bool = False) -> None:
    """An output path can be written: its folder exists and is writable, and it is not a
    folder (or, for a folder flag, it is one or can be made). Raises OutputPathError."""
    if name is None or (stdout_ok and name == "-"):
        return
    path = Path(name)
    if folder:
        existing = next((p for p in (path, *path.parents) if p.exists()), Path("."))
        if not existing.is_dir():
            raise OutputPathError(f"{flag} {name}: {existing} is a file, not a folder")
        if not os.access(existing, os.W_OK):
            raise OutputPathError(f"{flag} {name}: {existing} is not writable")
        return
    parent = path.parent
    if not parent.is_dir():
        raise OutputPathError(f"{flag} {name}: the folder {parent} does not exist (create it first)")
    if path.is_dir():
        raise OutputPathError(f"{flag} {name}: it is a folder; give a file name")
    if not os.access(parent, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise OutputPathError(f"{flag} {name}: not writable (choose another location)")


HYPOTHESIS_HOME = ".certiloop/hypothesis"


def on_interrupt_exit_quietly() -> Callable[[], None]:
    """For one command: Ctrl-C raises KeyboardInterrupt in this process (reported on one line,
    exit 130, partial reports kept) while forked workers, which inherit the handler, exit
    without a traceback; and hypothesis keeps its caches (not only the example database)
    under .certiloop/ instead of ./.hypothesis. Returns what undoes both."""
    main_pid = os.getpid()

    def handler(signum, frame) -> None:
        if os.getpid() != main_pid:
            os._exit(EXIT_INTERRUPTED)
        raise KeyboardInterrupt

    previous = None
    try:
        previous = signal.signal(signal.SIGINT, handler)
    except ValueError:  # not the main thread (embedded use): leave signals alone
        pass
    had_home = "HYPOTHESIS_STORAGE_DIRECTORY" in os.environ
    os.environ.setdefault("HYPOTHESIS_STORAGE_DIRECTORY", HYPOTHESIS_HOME)

    def restore() -> None:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
        if not had_home:
            os.environ.pop("HYPOTHESIS_STORAGE_DIRECTORY", None)

    return restore
