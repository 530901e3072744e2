"""What the command line shows around the results: consoles that fit the terminal (80 columns
when piped), tables that fit or fold, progress on a terminal only, verbosity."""

from __future__ import annotations

import io
import sys
import textwrap

from rich import box
from rich.console import Console
from rich.table import Table

QUIET, NORMAL, VERBOSE = -1, 0, 1

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
            # the bar counts finished models until the model says how many steps it has
            self.bar.reset(self.task, total=self.total, completed=self.index - 1,
                           description=f"{self.verb} {self.index}/{self.total} models: {name}")

    def steps(self, n: int) -> None:
        """The current model has n steps (obligations) to go."""
        if self.bar is not None:
            self.bar.update(self.task, total=n, completed=0)

    def step(self, *_) -> None:
        if self.bar is not None:
            self.bar.advance(self.task)
