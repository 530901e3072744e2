"""What must be settled before any work: output paths that can be written (exit 2 at once,
not after a long run), and Ctrl-C (exit 130 on one line, workers silent). No rich here:
`certiloop --help` stays fast."""

from __future__ import annotations

import gc
import os
import signal
from pathlib import Path
from typing import Callable

EXIT_INTERRUPTED = 130


GC_THRESHOLDS = (20_000, 10, 10)  # Python's default is (700, 10, 10)


def collect_garbage_less_often() -> Callable[[], None]:
    """The prover allocates millions of short-lived term tuples; at Python's default the
    cyclic collector ran every 700 allocations and traversed the whole heap (sympy's caches
    included) every 70,000: 10-15 % of a proof's CPU. Reference counting still frees all
    acyclic garbage at once, so this only delays freeing cycles (peak memory +1 % on
    sbs.ctrl2). Forked workers inherit it. Returns the undo, for in-process callers."""
    old = gc.get_threshold()
    gc.set_threshold(*GC_THRESHOLDS)
    return lambda: gc.set_threshold(*old)


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
