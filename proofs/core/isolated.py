"""A z3 check in a child process, bounded by z3's allocation count as well as its units.

Some calls stall where z3's resource count (`rlimit`) does not reach: on quantified nonlinear
formulas, nlsat's cell projection under `qsat` can run for minutes on a few hundred thousand
units, and it does not look at z3's timeout either (a 2 s timeout returned after 69 s). z3
counts every allocation, deterministically, and `memory_max_alloc_count` stops there, but by
exiting the whole process. So such a check runs in a child forked from a fork server that
holds no z3 state: the child's count starts at the same value every time, the allocation
bound is a deterministic budget like the units, and the parent reads the child's exit as
`unknown`. The child can also be killed, so the wall-clock safety net really ends the call.
(The count is nearly the same for every check from one process (33 allocations in 293,000
apart were seen with both cores busy); from a process started with other arguments or paths
it can differ by up to about 0.4% (1,029 allocations in 293,000 in CI):
z3 folds a thread's count into the global one only at every 100 KB allocated, so the count
follows the process's memory layout. A budget is at least 10,000,000, so only a check
ending that close to its budget could end differently.)
"""

from __future__ import annotations

import os
import pickle
import sys
from contextlib import contextmanager
from typing import TYPE_CHECKING, Callable

from certiloop.models.lang.terms import Node
from certiloop.proofs.core.answers import SolverAnswer

if TYPE_CHECKING:
    from multiprocessing.connection import Connection

Check = Callable[[Node, int, "float | None"], SolverAnswer]

MAX_ALLOC_COUNT = 2**32 - 1  # z3's memory_max_alloc_count is an unsigned 32-bit parameter
ALLOC_EXCEEDED = 113  # z3's exit code when memory_max_alloc_count is passed (ERR_ALLOC_EXCEEDED)
_context = None
_warm = False  # this process's fork server has served its throwaway child


def available() -> bool:
    import multiprocessing  # here, not at import: most runs never need it

    return "forkserver" in multiprocessing.get_all_start_methods()


def check_in_child(check: Check, formula: Node, rlimit: int, wall_s: float,
                   max_allocs: int) -> SolverAnswer:
    """`check(formula, rlimit, wall_s)` (z3 in the process it runs in) computed in a child with
    an allocation budget as well; `unknown`, saying which, when the child passes that budget
    or the safety net."""
    _warm_up()
    receiver, sender = _fork_server().Pipe(duplex=False)
    child = _fork_server().Process(target=_child, args=(sender, check, formula, rlimit, wall_s, max_allocs),
                                   daemon=True)
    try:
        with _children_allowed(), _main_module_hidden():
            child.start()
    except (OSError, ValueError, TypeError, AttributeError, AssertionError, pickle.PicklingError):
        # no child (out of processes, or a term that does not pickle): check it here instead
        receiver.close()
        sender.close()
        return check(formula, rlimit, wall_s)
    sender.close()
    try:
        if receiver.poll(wall_s + 5):  # the child's z3 has the net as its timeout too
            try:
                return receiver.recv()
            except EOFError:  # the child ended without an answer: z3 exited it
                pass
        else:
            child.kill()
            return SolverAnswer("unknown", f"wall-clock safety net reached after {wall_s:g} s (z3 stalled "
                                "where its resource count does not reach, or the machine is overloaded; "
                                "not a verdict of the budget)", spent=-1)
    finally:
        receiver.close()
        child.join()
    if child.exitcode == ALLOC_EXCEEDED:
        return SolverAnswer("unknown", f"allocation budget spent ({max_allocs:,} z3 allocations: z3 "
                            "stalled where its resource count does not reach)", spent=-1)
    return SolverAnswer("unknown", f"z3 ended abnormally (exit code {child.exitcode})", spent=-1)


@contextmanager
def _children_allowed():
    """multiprocessing refuses children to a daemonic process (a pool's worker), so that none
    outlives it; this child always is joined, or killed at the net, so it may have one."""
    import multiprocessing

    config = multiprocessing.current_process()._config
    daemon = config.pop("daemon", None)
    try:
        yield
    finally:
        if daemon is not None:
            config["daemon"] = daemon


@contextmanager
def _main_module_hidden():
    """multiprocessing would have the child import the parent's main script first (as
    `__mp_main__`): a user's script without an `if __name__ == "__main__"` guard would run
    again inside it, and a script from stdin cannot be found. The child needs nothing from
    it, so the main module shows neither its file nor its spec while the child starts."""
    main = sys.modules.get("__main__")
    if main is None:
        yield
        return
    saved = {key: main.__dict__[key] for key in ("__file__", "__spec__") if key in main.__dict__}
    main.__dict__.pop("__file__", None)
    main.__spec__ = None
    try:
        yield
    finally:
        main.__dict__.pop("__spec__", None)
        main.__dict__.update(saved)


def _warm_up() -> None:
    """One throwaway child first: the fork server's first child allocates about 50 times
    fewer in z3 than every later one (the server changes once it has served), and the
    budget must not depend on which check comes first."""
    global _warm
    if _warm:
        return
    child = _fork_server().Process(target=_allocations_so_far, daemon=True)
    with _children_allowed(), _main_module_hidden():
        child.start()
    child.join()
    _warm = True


def _forget_inherited_server() -> None:
    """A forked process (a pool's worker) inherits its parent's fork server, which it cannot
    wait for as it is not its child: it starts its own when it needs one. multiprocessing keeps
    one server per process, so this holds whoever started it (this module, or other code)."""
    global _warm
    _warm = False
    forkserver = sys.modules.get("multiprocessing.forkserver")
    if forkserver is None:  # nothing in the parent ever used one
        return
    server = forkserver._forkserver
    server._forkserver_pid = server._forkserver_address = None


os.register_at_fork(after_in_child=_forget_inherited_server)


def _fork_server():
    global _context
    if _context is None:
        import multiprocessing

        _context = multiprocessing.get_context("forkserver")
        _context.set_forkserver_preload(["certiloop.proofs.core.solver"])  # z3 imported once, unused
    return _context


def _child(sender: Connection, check: Check, formula: Node, rlimit: int, wall_s: float,
           max_allocs: int) -> None:
    import z3

    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # z3 announces the exceeded count on stdout: keep the parent's output clean
    base = _allocations_so_far()
    z3.set_param("memory_max_alloc_count", min(base + max_allocs, MAX_ALLOC_COUNT))
    # no z3 timeout here: the parent kills the child at the net, and z3's timer thread would
    # make the allocation count vary with the machine's load (by a few hundred)
    answer = check(formula, rlimit, None)
    answer.allocations = _allocations_so_far() - base
    sender.send(answer)
    sender.close()


def _allocations_so_far() -> int:
    """z3's allocation count in this process (it is global and only grows)."""
    import z3

    solver = z3.Solver()
    solver.check()
    return int(solver.statistics().get_key_value("num allocs"))
