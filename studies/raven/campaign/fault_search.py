"""The worst-case fault search of `certiloop campaign SCENARIO --search`.

Random campaigns sample faults; a boundary crossing that needs a fault of the right kind, at
the right time, of the right size may be rare among them. The search lets hypothesis choose
the faults (kind, stream, window, magnitude within the setup's ranges), steers them towards
the boundary (`target` on the robot's least distance to the plane), and, once a run crosses,
the fault is shrunk to the shortest window and the smallest magnitude that still cross. Each
candidate is one run of the same closed loop as the campaign (`run_campaign`), so a reported
crossing is a run the campaign replays exactly (`replay_fault`).

Deterministic for a seed: hypothesis draws from `random.Random(seed)`, no example database.
The budget is a number of examples, never a time.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, replace

import numpy as np
from hypothesis import HealthCheck, Phase, find, settings, target
from hypothesis import strategies as st
from hypothesis.errors import NoSuchExample

from certiloop.falsify.constant_pool import pinned_constants
from certiloop.studies.raven.campaign.run import (
    FAULT_KINDS,
    RUN_STRIDE,
    STREAMS,
    Fault,
    Records,
    Setup,
    run_campaign,
)


@dataclass
class SearchResult:
    fault: Fault | None  # the shrunk crossing fault, None if no run crossed
    examples: int  # runs tried (including shrinking)
    min_distance: float  # the crossing run's least true distance to the plane (m), or nan
    found_after: int = 0  # faults tried up to the batch with the first crossing (before shrinking)


def _faults(setup: Setup, kinds, ticks: int):
    @st.composite
    def fault(draw) -> Fault:
        kind = draw(st.sampled_from(sorted(kinds)))
        lo, hi = setup.magnitudes[kind]
        if kind == "delay":
            magnitude = float(draw(st.integers(int(lo), int(hi))))
        else:
            # log-uniform like the campaigns' draws: a fraction u of the range's decades, which
            # shrinks towards the smallest magnitude
            u = draw(st.floats(0.0, 1.0, allow_nan=False))
            magnitude = min(hi, lo * (hi / lo) ** u)
        return Fault(kind, draw(st.sampled_from(STREAMS)), draw(st.integers(100, ticks // 2 - 1)),
                     draw(st.integers(1, ticks // 4 - 1)), magnitude)
    return fault()


def replay_fault(setup: Setup, fault: Fault, seed: int = 0, ticks: int = 2000) -> Records:
    """The search's run of `fault`, again: its random draws (drop, noise) come from the run
    seed seed * RUN_STRIDE. The run stops when the fault's window closes: every fault acts
    only inside it, and after it the robot follows the model (kept >= m > 0 from the plane)
    or stays where the stop held it, so the run's least distance is reached by then."""
    horizon = min(ticks, fault.start + fault.duration + 1)
    return run_campaign([fault], replace(setup.scenario(ticks), ticks=horizon), run_seeds=[seed * RUN_STRIDE])


BATCH = 25  # faults hypothesis proposes at once: one batched closed-loop run checks them all


def _run_batch(setup: Setup, faults: list, seed: int, ticks: int) -> np.ndarray:
    """Least true distance to the plane of each fault's run (stopped at the last window's close)."""
    horizon = min(ticks, max(f.start + f.duration for f in faults) + 1)
    rec = run_campaign(list(faults), replace(setup.scenario(ticks), ticks=horizon),
                       run_seeds=[seed * RUN_STRIDE] * len(faults))
    return rec.min_distance


def worst_case(setup: Setup, kinds=FAULT_KINDS, max_examples: int = 500, seed: int = 0,
               ticks: int = 2000) -> SearchResult:
    """Search up to `max_examples` faults for a run of `setup` that crosses the boundary.

    Hypothesis draws BATCH faults at a time (one batched closed-loop run checks them all, at
    about the cost of one run), steered by the deepest point any of them reaches (`target`).
    The deepest crossing fault is then shrunk by `shrink`."""
    tried = 0

    def crosses(faults: list) -> bool:
        nonlocal tried
        tried += len(faults)
        depth = _run_batch(setup, faults, seed, ticks)
        target(-float(depth.min()), label="depth below the plane (m)")
        return bool(np.any(depth < 0))

    # every setting spelled out: a loaded profile (the test suite's derandomize=True) must not
    # replace the seed's random source
    config = settings(max_examples=max(1, -(-max_examples // BATCH)), database=None, deadline=None,
                      derandomize=False, phases=(Phase.generate, Phase.target),
                      suppress_health_check=list(HealthCheck))
    faults = st.lists(_faults(setup, kinds, ticks), min_size=BATCH, max_size=BATCH)
    # the constants hypothesis may draw: the setup's magnitude bounds, whatever was imported before
    bounds = [b for kind in kinds for b in setup.magnitudes[kind]]
    try:
        with pinned_constants(bounds):
            found = find(faults, crosses, settings=config, random=random.Random(seed))
    except NoSuchExample:
        return SearchResult(None, tried, float("nan"))
    found_after = tried
    depth = _run_batch(setup, found, seed, ticks)
    fault, runs = shrink(setup, found[int(np.argmin(depth))], seed, ticks)
    return SearchResult(fault, tried + runs, float(replay_fault(setup, fault, seed, ticks).min_distance[0]),
                        found_after)


def shrink(setup: Setup, fault: Fault, seed: int = 0, ticks: int = 2000,
           rounds: int = 2) -> tuple[Fault, int]:
    """A smaller crossing fault: the shortest window, then the smallest magnitude that still
    cross, each chosen from BATCH candidates checked in one batched
    run (a grid, refined `rounds` times). Only candidates whose run crosses are kept, so the
    result crosses whatever the grid. Returns it and the number of runs spent."""
    runs = 0

    def first_crossing(candidates: list[Fault]) -> Fault | None:
        nonlocal runs
        runs += len(candidates)
        depth = _run_batch(setup, candidates, seed, ticks)
        hits = np.flatnonzero(depth < 0)
        return candidates[int(hits[0])] if len(hits) else None

    lo = setup.magnitudes[fault.kind][0]
    for _ in range(rounds):
        durations = sorted({max(1, round(fault.duration * k / BATCH)) for k in range(1, BATCH + 1)})
        fault = first_crossing([replace(fault, duration=d) for d in durations]) or fault
        if fault.kind in ("drop", "delay", "stuck"):  # probabilities, lags, holds: keep as found
            continue
        sizes = sorted({lo * (fault.magnitude / lo) ** (k / BATCH) for k in range(BATCH + 1)})
        fault = first_crossing([replace(fault, magnitude=m) for m in sizes]) or fault
    return fault, runs
