"""A function run in a forked child beside the caller's own work, its result sent back.

The falsifier's batch phase and its hypothesis search are independent (each draws from its
own seeded generator), so on two cores they run at once: the search in a child forked after
the imports, the batch phase here. The result is the same as one after the other; the
child is stopped unused when the batch phase finds a counterexample first.
"""

from __future__ import annotations

import gc
import multiprocessing
import os
import pickle
from typing import Any, Callable


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
