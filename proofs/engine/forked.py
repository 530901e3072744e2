"""Work in forked children, for a second core: the children see this process's memory as
it was at the fork, so nothing need be pickled to them, only their results back.

`Forked(fn)` runs fn() in one child beside the caller's own work (the falsifier's hypothesis
search beside its batch phase: independent, each with its own seeded generator, so the result
is the serial one); `.result()` waits for it, `.cancel()` stops it unused.

`forked_map(fn, count)` is `[fn(0), ..., fn(count - 1)]`, computed by WORKERS children forked
from this process (each takes every WORKERS-th index, so neighbours, which cost alike, are
spread), results pickled back. The children see this process's memory as it was at the fork,
so `fn` may close over anything; it must not depend on state another index changes, which
makes the result the same as the serial one. Small counts run here: a fork costs more than
they do (the certificate's leaves, proofs/engine/certificate_writer.py)."""

from __future__ import annotations

import gc
import multiprocessing
import os
import pickle
from multiprocessing.connection import wait
from typing import Any, Callable

WORKERS = 2
SERIAL_BELOW = 16  # items: fewer run in this process


def forked_map(fn: Callable[[int], Any], count: int, workers: int = WORKERS) -> list:
    if count < SERIAL_BELOW or workers < 2:
        return [fn(i) for i in range(count)]
    context = multiprocessing.get_context("fork")
    pipes, children = [], []
    for k in range(workers):
        mine, theirs = context.Pipe(duplex=False)
        child = context.Process(target=_each, args=(fn, range(k, count, workers), theirs), daemon=True)
        child.start()
        theirs.close()
        pipes.append(mine)
        children.append(child)
    out: dict[int, Any] = {}
    try:
        while pipes:
            for pipe in wait(pipes):
                try:
                    i, ok, value = pipe.recv()
                except EOFError:
                    pipes.remove(pipe)
                    continue
                if not ok:
                    raise value
                out[i] = value
    finally:
        for child in children:
            child.kill()
            child.join()
    if len(out) != count:
        raise RuntimeError(f"a forked child ended with {count - len(out)} of {count} items not done")
    return [out[i] for i in range(count)]


def _each(fn: Callable[[int], Any], share: range, out) -> None:
    for i in share:
        try:
            out.send((i, True, fn(i)))
        except Exception as exc:  # noqa: BLE001 - raised again in the parent
            out.send((i, False, exc))
            return


def can_fork() -> bool:
    return "fork" in multiprocessing.get_all_start_methods()


class Forked:
    def __init__(self, fn: Callable[[], Any]) -> None:
        ctx = multiprocessing.get_context("fork")
        self._receive, send = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=_serve, args=(fn, send))
        gc.freeze()  # the child's collections skip what it inherited: no copies of those pages
        try:
            self._process.start()
        finally:
            gc.unfreeze()
        send.close()

    def result(self) -> Any:
        """fn's value, or its exception raised here."""
        try:
            kind, payload = self._receive.recv()
        except EOFError:
            self._process.join()
            raise RuntimeError(f"the forked search ended without a result (exit code "
                               f"{self._process.exitcode})") from None
        finally:
            self._receive.close()
        self._process.join()
        if kind == "error":
            raise payload
        return payload

    def cancel(self) -> None:
        if self._process.is_alive():
            self._process.terminate()
        self._process.join()
        self._receive.close()


def _serve(fn: Callable[[], Any], send) -> None:
    try:
        message: tuple[str, Any] = ("value", fn())
    except BaseException as exc:  # noqa: BLE001 - handed to the parent as is
        message = ("error", exc)
    try:
        data = pickle.dumps(message)
    except Exception as exc:  # noqa: BLE001 - an unpicklable result or exception
        data = pickle.dumps(("error", RuntimeError(f"the forked search's result could not be sent: {exc}")))
    send.send_bytes(data)
    send.close()
    os._exit(0)  # no atexit handlers or flushes of the parent's inherited state
