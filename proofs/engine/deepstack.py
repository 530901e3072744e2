"""Run a command on a thread with a large stack, so deeply nested models do not hit Python's
recursion limit.

A user's program of 10,000 statements or a formula nested 2,000 deep is walked recursively
in many places: certiloop's own term and program walkers, lark's parse-tree transformers,
sympy, pickling an obligation for a worker process, z3's printers. Python's default limit
(1,000 frames) stops these with a RecursionError long before memory runs out; raising the
limit alone is unsafe on the main thread, whose C stack (8 MiB by default) overflows into a
segmentation fault first. A thread's stack size is chosen when it starts, so the command runs
on one with `STACK_BYTES` of stack (virtual memory: only the pages touched are used) and a
recursion limit that stack holds with room to spare (measured on CPython 3.11: nested frozen
dataclasses hash, compare, pickle and print 200,000 levels deep in 256 MiB). Worker
processes forked from this thread inherit both.

Ctrl-C still reaches the command: the signal handler raises KeyboardInterrupt on the main
thread, which waits here and passes the exception on to the command's thread.
"""

from __future__ import annotations

import ctypes
import sys
import threading
from typing import Callable, TypeVar

T = TypeVar("T")

STACK_BYTES = 1 << 30
RECURSION_LIMIT = 400_000  # about 2.7 KiB of stack per level: a RecursionError, never a crash


def call_with_deep_stack(fn: Callable[[], T]) -> T:
    """fn() on a thread with a large stack; its result, or its exception re-raised here."""
    outcome: dict[str, object] = {}
    done = threading.Event()

    def body() -> None:
        try:
            outcome["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed to the caller as is
            outcome["error"] = exc
        finally:
            done.set()

    old_limit = sys.getrecursionlimit()
    old_size = threading.stack_size()
    try:
        threading.stack_size(STACK_BYTES)
        worker = threading.Thread(target=body, name="certiloop-deep-stack", daemon=True)
        sys.setrecursionlimit(max(old_limit, RECURSION_LIMIT))
        worker.start()
    finally:
        threading.stack_size(old_size)
    try:
        _wait(worker, done)
    finally:
        sys.setrecursionlimit(old_limit)
    if "error" in outcome:
        raise outcome["error"]  # type: ignore[misc]
    return outcome["value"]  # type: ignore[return-value]


def _wait(worker: threading.Thread, done: threading.Event) -> None:
    """Wait until `worker` is done; a KeyboardInterrupt raised here meanwhile is raised in it
    as well, and the command's own handling of it (partial reports) finishes before this
    returns. (Not `Thread.join`: on CPython 3.11, a join interrupted by a signal handler's
    exception releases the running thread's state lock and reports it finished.)"""
    while True:
        try:
            while not done.wait(0.5):
                pass
            return
        except KeyboardInterrupt:
            _raise_in(worker, KeyboardInterrupt)


def _raise_in(worker: threading.Thread, exc_type: type[BaseException]) -> None:
    if worker.ident is not None and worker.is_alive():
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(worker.ident), ctypes.py_object(exc_type))
