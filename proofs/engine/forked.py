"""A pure computation over many independent items, spread over forked children.

`forked_map(fn, count)` is `[fn(0), ..., fn(count - 1)]`, computed by WORKERS children forked
from this process (each takes every WORKERS-th index, so neighbours, which cost alike, are
spread), results pickled back. The children see this process's memory as it was at the fork,
so `fn` may close over anything; it must not depend on state another index changes, which
makes the result the same as the serial one. Small counts run here: a fork costs more than
they do."""

from __future__ import annotations

import multiprocessing
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
