"""The falsifier's batch phase: many seeded runs at once, each hit confirmed by replay.

Before hypothesis searches run by run, a model the batch simulator compiles is run in
vectorised batches whose decisions come from numpy's generator seeded with the search's
seed (the same verdict for the same seed). A violating run of a batch is a candidate only:
the tree-walking interpreter replays its initial state and decisions, in exact rational
arithmetic where the flows have closed forms, else with validated enclosures of the flows
(`validated.py`) — the check every reported counterexample passes. A candidate the exact
replay rejects (it blocks where the floats went on, or ends without a violation) is dropped;
one only floating point shows violating, deeper than the search's tolerance, is kept as an
unconfirmed candidate (so reported, never as a counterexample) while the search goes on.
A model with families runs each round's runs split over the family sizes of the search's
range, one batch per size (`_split`); a Hoare triple over integers (`batch/ints.py`) splits
them the same way over group slots, each batch with integer constants of its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from certiloop.falsify.batch.program import compiled
from certiloop.falsify.choosers import Diverged, Scripted
from certiloop.falsify.depth import FLOAT_ONLY, float_only, is_deep
from certiloop.falsify.evaluate import Blocked, Compiler, NeedValue, Table
from certiloop.falsify.flows import Inexact
from certiloop.falsify.interpreter import Interpreter, Rejected, Run
from certiloop.falsify.store import solve_linear
from certiloop.falsify.vectorise import Unsupported, conjuncts, read_order
from certiloop.models.lang.theorem import Theorem

BATCH_SIZE = 4096  # a batch's cost is mostly per statement, not per run: large batches
FIRST_BATCH = 256  # ... but an easy counterexample needs no 4,096 runs: 256, 1,024, 4,096, ...
CONFIRMS_PER_BATCH = 16  # candidates replayed per batch (deepest first)
SNAP = 1e-9  # relative: how far rounding may have moved a value an equation pins down
MAX_CONFIRMS = 32  # replays in all: float-only near misses of a safe model stay cheap
AFTER_CANDIDATE = 4  # replays left once a run only floating point shows violating was kept


@dataclass
class BatchOutcome:
    runs: int  # runs drawn (started or rejected by the assumptions)
    started: int  # runs whose drawn state met the assumptions
    run: Run | None = None
    check: str = ""
    initial: dict[str, Any] | None = None
    script: list[tuple[str, Any]] | None = None
    unsupported: str = ""  # why the model has no batch phase
    # the first run only floating point shows violating: (run, check, script, initial, runs drawn)
    candidate: tuple | None = None


def batches(theorem: Theorem, max_steps: int) -> bool:
    """The batch simulator compiles the theorem (else `batch_search` draws no run)."""
    try:
        compiled(theorem, max_steps)
    except Unsupported:
        return False
    return True


def batch_search(theorem: Theorem, runs: int, seed: int, max_steps: int,
                 families: tuple[int, int], first: int = FIRST_BATCH) -> BatchOutcome:
    """first: the first round's runs. Small finds an easy counterexample at once; a search
    expected to draw all `runs` (a model expected safe) takes them in one round: fewer,
    larger batches (sbs.ctrl2's 4,096 runs 3.4 -> 2.6 s CPU)."""
    try:
        program = compiled(theorem, max_steps)
    except Unsupported as exc:
        return BatchOutcome(0, 0, unsupported=str(exc))
    rng = np.random.default_rng(seed)
    sizes = program.sizes(families)
    drawn = started = confirms = 0
    candidate = None
    size = max(1, first)
    while drawn < runs:
        size = min(size, runs - drawn)
        for elements, count in _split(size, sizes):
            batch = program.simulate(rng, count, elements)
            started += int(batch.accepted.sum())
            for r in batch.candidates()[:CONFIRMS_PER_BATCH]:
                if confirms >= MAX_CONFIRMS:
                    break
                confirms += 1
                initial, script = batch.initial_state(r), batch.script(r)
                run, check = confirm_candidate(theorem, initial, script, max_steps, families)
                if check.startswith(FLOAT_ONLY):  # kept, in case nothing confirmed turns up
                    candidate = candidate or (run, check, script, initial, drawn + r + 1)
                    # the next few replays only: float-only runs of one model tend to be alike
                    confirms = max(confirms, MAX_CONFIRMS - AFTER_CANDIDATE)
                elif check:
                    return BatchOutcome(drawn + r + 1, started, run, check, initial, script)
            drawn += count
        size = _grow(size, len(sizes))
    return BatchOutcome(drawn, started, candidate=candidate)


def _grow(size: int, sizes: int) -> int:
    """The next round's runs: 4x, up to BATCH_SIZE per batch. Split over several family sizes,
    a round pays each batch's per-statement cost once per size: it grows 16x (sbs.ctrl2's
    4,096 runs in 16 batches rather than 24: 4.0 -> 2.7 s)."""
    if sizes == 1:
        return min(4 * size, BATCH_SIZE)
    return min(16 * size, BATCH_SIZE * sizes)


def _split(runs: int, sizes: list[int]) -> list[tuple[int, int]]:
    """`runs` shared out over the family sizes as evenly as can be, as (size, runs) pairs."""
    share, extra = divmod(runs, len(sizes))
    return [(m, share + (k < extra)) for k, m in enumerate(sizes) if share + (k < extra) > 0]


def confirm_candidate(theorem: Theorem, initial: dict[str, float], script, max_steps: int,
                      families: tuple[int, int]) -> tuple[Run | None, str]:
    """Replay a batch run in the interpreter: (the replayed run, how it was confirmed), or
    (None, "") if it does not replay to a violation."""

    failures = (Diverged, Rejected, Blocked, Inexact, ArithmeticError)
    floats = Interpreter(theorem, max_steps=max_steps, families=families)
    try:
        run: Run | None = floats.run(Scripted(script), dict(initial))
    except failures:
        run = None
    exact = Interpreter(theorem, exact=True, max_steps=max_steps, families=families)
    start = exact_initial(theorem, initial, exact.c)
    why = ""
    try:
        exact_run = exact.run(Scripted(script), start)
        if exact_run.violated is not None:
            shown = run if run is not None and run.violated is not None else exact_run
            return shown, "replayed in exact rational arithmetic"
        why = ("the exact replay of the same decisions ends without a violation (a test decided otherwise "
               "than in floats)")
    except Inexact:  # a flow without a closed form: follow it by validated enclosures
        from certiloop.falsify.validated import confirm_enclosed

        deep = run is not None and run.violated is not None and is_deep(run)
        validated, why = confirm_enclosed(theorem, script, max_steps, families, start, retreat=deep)
        if validated and run is not None and run.violated is not None:
            return run, validated
    except (Blocked, Rejected, Diverged):  # blocks or turns where the floats went on (e.g. at a
        return None, ""  # domain's edge), or the start misses the assumptions: not a run
    except ArithmeticError as exc:
        why = f"the exact replay failed: {type(exc).__name__}"
    if run is not None and run.violated is not None and is_deep(run):
        return run, float_only(run, why)
    return None, ""


def exact_initial(theorem: Theorem, initial: dict[str, float], c: Compiler) -> dict[str, Any]:
    """The float initial state as rationals, with every equation of the assumptions that
    the floats meet only up to rounding (x = 33/10000, a·z = 0) solved exactly for one of
    its values, where that moves the value by rounding only. The interpreter then checks
    the assumptions exactly, so this can only make a replay possible, never forge one."""
    s: dict[str, Any] = {k: _exact(v) for k, v in initial.items()}
    for atom in conjuncts(theorem.assumptions):
        if atom.op == "forall" and atom.args[-1].op == "cmp" and atom.args[-1].payload == "==":
            _snap_cells_to_sphere(atom, s, c(atom))  # ∀j nx[j]^2 + ny[j]^2 + nz[j]^2 = 1
            continue
        if atom.op != "cmp" or atom.payload != "==" or not atom.args[0].sort.is_numeric:
            continue
        holds = c(atom)
        try:
            if holds(s):
                continue
        except (NeedValue, Blocked):
            continue
        for name in read_order(atom):
            if name not in s:
                continue
            x = solve_linear(c(atom.args[0]), c(atom.args[1]), name, s, True)
            old = s[name]
            if x is None or abs(x - old) > SNAP * (1 + abs(old)):
                continue
            s[name] = x
            if holds(s):
                break
            s[name] = old
        else:  # no value solves it linearly: a circle u^2 + v^2 = r^2 has dense rational points
            _snap_to_circle(atom, s, holds)
    return s


def _snap_to_circle(atom, s: dict[str, Any], holds) -> None:
    from certiloop.falsify.snap_circle import circle_point

    point = circle_point(atom, s, [n for n in read_order(atom) if n in s])
    if point is None or any(abs(x - s[n]) > SNAP * (1 + abs(s[n])) for n, x in point.items()):
        return
    old = {n: s[n] for n in point}
    s.update(point)
    if not holds(s):
        s.update(old)


def _snap_cells_to_sphere(atom, s: dict[str, Any], holds) -> None:
    """Each index's cells of the families the equation reads, as a point of a sphere with a
    rational radius, moved to a rational point of it within rounding; kept only if the
    equation then holds exactly."""
    from certiloop.falsify.snap_circle import radius, sphere_point
    from certiloop.models.lang.terms import free_vars

    try:
        if holds(s):
            return
    except (NeedValue, Blocked):
        return
    tables = [n for n in free_vars(atom) if isinstance(s.get(n), Table)]
    if not tables:
        return
    keys = set.intersection(*(set(s[n].cells) for n in tables))
    old = {n: s[n] for n in tables}
    new = {n: dict(s[n].cells) for n in tables}
    for key in sorted(keys):
        values = [float(new[n][key]) for n in tables]
        r = radius(values)
        point = None if r is None else sphere_point(values, r)
        if point is None or any(abs(x - v) > SNAP * (1 + abs(v)) for x, v in zip(point, values)):
            continue
        for n, x in zip(tables, point):
            new[n][key] = x
    for n in tables:
        s[n] = Table(new[n], old[n].default)
    try:
        if holds(s):
            return
    except (NeedValue, Blocked):
        pass
    s.update(old)


def _exact(v: Any) -> Any:
    """A value of a float initial state as a rational (families cell by cell)."""
    if isinstance(v, Table):
        return Table({k: _exact(x) for k, x in v.cells.items()}, v.default)
    if isinstance(v, (bool, range)):
        return v
    return Fraction(v)
