"""Hypothesis-driven search for a run that violates a theorem's guarantee.

A model the batch simulator compiles (reals, families over one index sort; Hoare triples over
integers and arrays, `batch/ints.py`) is first run in vectorised batches seeded by the
search's seed (`batch_search`): thousands of runs per second, a hit reported only after
the interpreter replayed it. Hypothesis then searches as before.

Every example is one run of the interpreter whose decisions (initial values, family size,
alternatives, open values, ODE durations, number of control steps) hypothesis draws. The
search steers towards small guarantee margins (`hypothesis.target`), shrinks a violating
run to a short one with round values, and keeps its example database in the project
folder so a failure found once is tried first the next time.

A violation is reported (verdict "refuted") only after it was re-checked: replayed decision
by decision in exact rational arithmetic, or through ODEs without a closed form with
validated interval enclosures of their flows (`validated.py`). A run the exact replay
rejects is no counterexample and the search goes on. Where neither check can decide
(irrational unit normals, a flow that cannot be enclosed) a violation deeper than a tolerance
far above floating-point error is kept as an "unconfirmed candidate" whose check says
"floating point only (not validated: why)"; it is reported only if nothing confirmed turns
up, and never as a counterexample. A confirmed run's numbers are then shrunk to short
rationals the exact replay still confirms (`shrink.py`); shrinking is bounded by counts, not
the clock, so the same seed gives the same counterexample.
"""

from __future__ import annotations

import hashlib
import math
import sys
import time
from collections import Counter
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from certiloop.falsify.choosers import Diverged, HypothesisChooser, Recording, Scripted
from certiloop.falsify.constant_pool import pinned_constants
from certiloop.falsify.depth import (  # noqa: F401
    FLOAT_ONLY,
    FLOAT_TOLERANCE,
    UNCONFIRMED,
    depth,
    float_only,
    is_deep,
)
from certiloop.falsify.evaluate import Blocked
from certiloop.falsify.flows import Inexact
from certiloop.falsify.interpreter import Interpreter, Rejected, Run
from certiloop.falsify.sort_key_cache import cached_sort_keys
from certiloop.models.lang.programs import ODE, Program, Test, children
from certiloop.models.lang.terms import MODALITIES, Node
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.engine.forked import Forked, can_fork

SHRINK_STEPS = 100  # successful shrinks hypothesis makes (its default, 500, or its clock-bound
# 5 minutes, make CI wait); a count, not seconds: the same seed gives the same run
EXACT = "replayed in exact rational arithmetic"
NOT_IN_EXACT = ("the exact replay of the same decisions ends without a violation (a test decided otherwise "
                "than in floats)")
DEFAULT_DATABASE = Path(".certiloop") / "hypothesis"
MAX_ENCLOSED = 8  # near misses replayed with enclosures while searching (each costs up to a second)
ENCLOSE_ABOVE = 1e-2  # ... if deeper than this share of the float tolerance: shallower ones are
# within the integration's error (flows.RTOL), where a safe model's near misses sit by the hundred


@dataclass
class Options:
    max_examples: int = 2000
    seed: int = 0
    families: tuple[int, int] = (1, 8)
    max_steps: int = 3
    database: Path | None = DEFAULT_DATABASE
    shrink: bool = True  # False: report the first violating run as found (benchmarks)
    batch_runs: int = 4096  # runs of the vectorised batch phase before hypothesis (0: none)
    after_batch_examples: int | None = None  # hypothesis examples once the batch phase ran
    # all its runs and found nothing (None: max_examples); the gate's budget for safe models
    batch_first: int | None = None  # the batch's first round (None: small, to find an easy
    # counterexample at once); the gate draws a model expected safe in one round
    jobs: int = 1  # 2 or more: hypothesis searches in a forked child beside the batch phase
    # (the same result as one after the other, on two cores)

    def digest(self) -> str:
        return f"{self.families}/{self.max_steps}"


@dataclass
class Falsification:
    model: str
    found: bool
    examples: int  # examples run until the first re-checked violation (or in all)
    seconds: float
    run: Run | None = None
    check: str = ""  # how the violation was re-checked
    script: list[tuple[str, Any]] = field(default_factory=list)
    note: str = ""  # why the search could not run, e.g. no start state meets the assumptions
    phase: str = "hypothesis"  # which search found the run: "batch" or "hypothesis"
    initial: dict[str, Any] | None = None  # a batch run's initial state (its script starts after it)
    skipped: str = ""  # why no search was made: the claim has a modality the runs cannot evaluate
    shrunk: bool = False  # its numbers were shortened (each kept only if the exact replay confirms)

    @property
    def candidate(self) -> bool:
        """A run only floating point shows violating (`check` says why no exact or validated
        replay confirmed it): reported, never as a counterexample."""
        return not self.found and self.run is not None

    @property
    def verdict(self) -> str:
        if self.found:
            return "refuted"
        return "not run" if self.skipped else UNCONFIRMED if self.candidate else "no counterexample"

    @property
    def validated(self) -> bool:
        """The run was re-checked exactly or by interval enclosures (every `found` run is)."""
        return self.found and not self.check.startswith(FLOAT_ONLY)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"model": self.model, "verdict": self.verdict, "examples": self.examples,
                               "seconds": round(self.seconds, 4), "counterexample": None,
                               "note": self.note, "phase": self.phase,
                               **({"skipped": self.skipped} if self.skipped else {})}
        if self.run is not None:
            out["counterexample"] = {"trace": [c.to_json() for c in self.run.checkpoints],
                                     "violated": self.run.violated, "check": self.check,
                                     "validated": self.validated, "confirmed": self.found,
                                     "shrunk": self.shrunk, "steps": self.run.checkpoints[-1].step,
                                     # the run's decisions as replayed (exact: "1/10"), in order
                                     "decisions": [[kind, _text(v)] for kind, v in self.script]}
        return out


def _text(v: Any) -> Any:
    return v if isinstance(v, (bool, int)) else str(v)


def _modal(f: Node) -> bool:
    return f.op in MODALITIES or any(_modal(a) for a in f.args)


def _has_flow(p: Program) -> bool:
    return isinstance(p, ODE) or any(_has_flow(q) for q in children(p))


def _modal_tests(p: Program) -> bool:
    return _modal(p.cond) if isinstance(p, Test) else any(_modal_tests(q) for q in children(p))


def _why_blocked(exc: Exception) -> str:
    if isinstance(exc, Rejected):
        return "the drawn start state missed the assumptions (are the assumptions satisfiable?)"
    if isinstance(exc, Blocked):
        return f"{exc}"
    return "values beyond the models' scale"


def _blocked_note(blocked: Counter[str]) -> str:
    """Why every run was rejected, most common first (a test no run passes, such as the
    `?t >= 2` of `[flow](t >= 2 -> P)`, or assumptions no drawn state meets)."""
    if not blocked:
        return "every run was rejected"
    reasons = [f"{why} ({n})" for why, n in blocked.most_common(2)]
    return "every run stopped early: " + "; ".join(reasons)


class _Found(Exception):
    def __init__(self, run: Run, check: str, script) -> None:
        super().__init__(run.violated)
        self.run, self.check, self.script = run, check, script

    def __reduce__(self):  # sent back from a forked search
        return (_Found, (self.run, self.check, self.script))


def falsify(theorem: Theorem, options: Options | None = None) -> Falsification:
    opts = options or Options()
    if _modal(theorem.assumptions) or _modal(theorem.guarantee) or _modal_tests(theorem.program):
        return Falsification(theorem.name, False, 0, 0.0, skipped="a modality inside the assumptions, the "
                             "guarantee or a test: a run cannot evaluate it (the proof stands alone)")
    start = time.perf_counter()
    batched = 0
    candidate: Falsification | None = None  # the first run only floating point shows violating
    beside: Forked | None = None  # the hypothesis search, forked to run beside the batch phase
    try:
        if opts.batch_runs > 0:  # many seeded runs at once; a hit is reported only once replayed
            from certiloop.falsify.batch.phase import batch_search, batches

            if opts.jobs > 1 and can_fork() and batches(theorem, opts.max_steps):
                examples = opts.max_examples if opts.after_batch_examples is None \
                    else min(opts.max_examples, opts.after_batch_examples)
                if _has_flow(theorem.program):  # both processes follow flows, which import it
                    import scipy.optimize  # noqa: F401  (0.5 s of CPU: once, before the fork)
                beside = Forked(lambda: _search(theorem, opts, examples, recording=True))
            first = {} if opts.batch_first is None else {"first": opts.batch_first}
            outcome = batch_search(theorem, opts.batch_runs, opts.seed, opts.max_steps, opts.families,
                                   **first)
            if outcome.run is not None:
                found = Falsification(theorem.name, True, outcome.runs, 0.0, outcome.run, outcome.check,
                                      outcome.script or [], phase="batch", initial=outcome.initial)
                return _finish(theorem, opts, found, start)
            if outcome.candidate is not None:
                run, check, script, initial, runs = outcome.candidate
                candidate = Falsification(theorem.name, False, runs, 0.0, run, check, script, phase="batch",
                                          initial=initial)
            batched = outcome.runs
        examples = opts.max_examples
        if batched and opts.after_batch_examples is not None:
            examples = min(examples, opts.after_batch_examples)
        if beside is not None:
            searched, beside = beside.result(), None
            if searched.writes and opts.database:
                from hypothesis.database import DirectoryBasedExampleDatabase

                from certiloop.falsify.recording_database import replay_on

                replay_on(DirectoryBasedExampleDatabase(str(opts.database)), searched.writes)
        else:
            searched = _search(theorem, opts, examples)
    finally:
        if beside is not None:  # the batch phase found a run first (or failed): the search does not count
            beside.cancel()
    count, found = searched.count, searched.found
    if found is not None:
        result = Falsification(theorem.name, True, batched + count["first"], 0.0, found.run, found.check,
                               found.script)
        return _finish(theorem, opts, result, start)
    if searched.unsatisfiable and candidate is None:  # every draw was rejected: nothing was run,
        return Falsification(theorem.name, False, 0, time.perf_counter() - start,  # which is not a pass
                             note=f"no run reached the end in {count['examples']} tries: "
                             f"{_blocked_note(searched.blocked)}")
    if candidate is None and searched.floats:
        f = searched.floats[0]
        candidate = Falsification(theorem.name, False, batched + count["candidate"], 0.0, f.run, f.check,
                                  f.script)
    if candidate is not None:
        candidate.seconds = time.perf_counter() - start
        return candidate
    return Falsification(theorem.name, False, batched + count["examples"], time.perf_counter() - start)


@dataclass
class _Searched:
    """What the hypothesis search found: the confirmed run to report (None: none), the first
    float-only one, the example counts, why runs were rejected, and, run beside the batch
    phase, its database writes still to be made."""

    found: _Found | None
    floats: list[_Found]
    count: dict[str, int]
    blocked: Counter[str]
    unsatisfiable: bool = False
    writes: list = field(default_factory=list)


def _search(theorem: Theorem, opts: Options, examples: int, recording: bool = False) -> _Searched:
    """The hypothesis search of `falsify`; `recording`: its database writes are kept in the
    result (made once the result is used), not made."""
    from hypothesis import HealthCheck, Phase, Verbosity, given, reject, settings, target
    from hypothesis import seed as fixed_seed
    from hypothesis import strategies as st
    from hypothesis.database import DirectoryBasedExampleDatabase
    from hypothesis.errors import Flaky, Unsatisfiable

    interp = Interpreter(theorem, max_steps=opts.max_steps, families=opts.families)
    count = {"examples": 0, "first": 0, "near": 0}
    blocked: Counter[str] = Counter()  # why runs were rejected, for the note when all were
    confirmed: list[_Found] = []  # the first run the exact (or validated) replay confirmed
    floats: list[_Found] = []  # the first run only floating point shows violating

    outer_limit = sys.getrecursionlimit()  # the command's (deep stack): hypothesis lowers it per example

    def one_run(data) -> None:
        with _recursion_limit_at_least(outer_limit):
            one_example(data)

    def one_example(data) -> None:
        count["examples"] += 1
        chooser = Recording(HypothesisChooser(data))
        try:
            run = interp.run(chooser)
        except (Rejected, Blocked, ArithmeticError) as exc:  # overflow: values beyond the models' scale
            blocked[_why_blocked(exc)] += 1
            reject()
        worst = run.worst
        if math.isfinite(worst):
            target(max(-1e6, min(1e6, -worst)), label="smallest guarantee margin")
        if run.violated is None:
            return
        worst, tolerance = depth(run)
        if confirmed and worst < -tolerance:
            # shrinking a confirmed run: a violation far beyond rounding needs no replay on
            # each step; the shrunk run is replayed once at the end (else the first one stands)
            raise _Found(run, "deep", chooser.script)
        # enclosures (up to a second each) for the first few violations beyond rounding only
        enclose = count["near"] < MAX_ENCLOSED and -worst > ENCLOSE_ABOVE * tolerance
        count["near"] += enclose
        check = confirm(theorem, chooser.script, run, opts, enclose=enclose)
        if not check:
            return  # the exact replay rejects the run: no counterexample, not even a candidate
        if check.startswith(FLOAT_ONLY):
            if not floats:
                floats.append(_Found(run, check, chooser.script))
                count["candidate"] = count["examples"]
            return  # reported only if nothing confirmed turns up
        if not confirmed:
            confirmed.append(_Found(run, check, chooser.script))
            count["first"] = count["examples"]
        raise _Found(run, check, chooser.script)

    db = DirectoryBasedExampleDatabase(str(opts.database)) if opts.database else None
    if db is not None and recording:
        from certiloop.falsify.recording_database import RecordingDatabase

        db = RecordingDatabase(db)
    phases = list(Phase) if opts.shrink else [p for p in Phase if p != Phase.shrink]
    # settings after seed: `@seed` switches the example database off, and so it was never
    # written (nor a failure found once tried first the next time)
    test = fixed_seed(opts.seed)(given(st.data())(one_run))
    test = settings(max_examples=examples, database=db, deadline=None, phases=phases,
                    derandomize=False,
                    verbosity=Verbosity.quiet, report_multiple_bugs=False, print_blob=False,
                    suppress_health_check=list(HealthCheck))(test)
    test._hypothesis_internal_database_key = hashlib.sha256(  # one database entry per model
        f"{theorem.content_hash}/{opts.digest()}".encode()).digest()
    searched = _Searched(None, floats, count, blocked)
    try:
        with _shrink_budget(SHRINK_STEPS), pinned_constants(_literals(theorem)), cached_sort_keys():
            test()
    except _Found as found:
        check = found.check if found.check != "deep" else confirm(theorem, found.script, found.run, opts)
        if not check or check.startswith(FLOAT_ONLY):  # the shrunk run did not replay: the first did
            found = confirmed[0]
            check = found.check
        searched.found = _Found(found.run, check, found.script)
    except Unsatisfiable:  # every draw was rejected: nothing was run, which is not a pass
        searched.unsatisfiable = True
    except Flaky:  # a step of the shrinking decided differently from before: the first run stands
        if confirmed:
            searched.found = confirmed[0]
    if recording and db is not None:
        searched.writes = db.writes
    return searched


def _finish(theorem: Theorem, opts: Options, found: Falsification, start: float) -> Falsification:
    """A confirmed run with its numbers shrunk to short rationals (each kept only if the exact
    replay still confirms the run), and the search's time."""
    if opts.shrink and found.check == EXACT:
        found = shrunk(theorem, opts, found)
    found.seconds = time.perf_counter() - start
    return found


def shrunk(theorem: Theorem, opts: Options, found: Falsification) -> Falsification:
    from certiloop.falsify.batch.phase import exact_initial
    from certiloop.falsify.shrink import shrink

    exact = Interpreter(theorem, exact=True, max_steps=opts.max_steps, families=opts.families)
    last: dict[str, Any] = {}

    def confirms(script, initial) -> bool:
        try:
            start = None if initial is None else exact_initial(theorem, initial, exact.c)
            run = exact.run(Scripted(script), start)
        except (Diverged, Rejected, Blocked, Inexact, ArithmeticError):
            return False
        if run.violated is None:
            return False
        last["run"] = run
        return True

    script, initial = shrink(found.script, found.initial, confirms)
    if not confirms(script, initial):  # cannot be (each value was kept only if it confirmed)
        return found
    # the run shown is the exact replay's: its states are the rationals the replay confirmed
    return Falsification(found.model, True, found.examples, found.seconds, last["run"], EXACT, script,
                         phase=found.phase, initial=initial,
                         shrunk=script != found.script or initial != found.initial)


@contextmanager
def _recursion_limit_at_least(limit: int):
    """Hypothesis sets the recursion limit to its caller's depth + 2,000 around each example,
    far below the limit the command's deep stack allows (`deepstack.py`): a guarantee nested
    2,000 deep, evaluated recursively, stopped with a RecursionError. The limit the search
    started with holds inside the example, and hypothesis's own is back after it."""
    inside = sys.getrecursionlimit()
    sys.setrecursionlimit(max(inside, limit))
    try:
        yield
    finally:
        sys.setrecursionlimit(inside)


@contextmanager
def _shrink_budget(steps: int):
    """Bound hypothesis's shrinking by a count of shrinks, not by the clock (a verdict or a
    counterexample must not depend on the machine's speed). Hypothesis has no public setting
    for it; its engine reads these module constants when shrinking starts. Without them
    (another hypothesis version) shrinking just takes its default budget."""
    from hypothesis.internal.conjecture import engine

    saved = {k: getattr(engine, k) for k in ("MAX_SHRINKS", "MAX_SHRINKING_SECONDS") if hasattr(engine, k)}
    if "MAX_SHRINKS" in saved:
        engine.MAX_SHRINKS = steps
        if "MAX_SHRINKING_SECONDS" in saved:
            engine.MAX_SHRINKING_SECONDS = 10**9  # the count decides
    try:
        yield
    finally:
        for k, v in saved.items():
            setattr(engine, k, v)


def _literals(theorem: Theorem) -> set:
    """Every numeric literal of the theorem, and its negation: the pool hypothesis draws
    constants from while it searches this theorem (`pinned_constants`)."""
    from certiloop.models.lang.theorem import visit

    found: set = set()

    def on_node(n, _where) -> None:
        if n.op == "const" and n.sort.is_numeric:
            found.update((n.payload, -n.payload))

    visit(theorem, on_node)
    return found


def confirm(theorem: Theorem, script, run: Run, opts: Options, enclose: bool = True) -> str:
    """How a violating float run was re-checked: exactly, else (flows without a closed form,
    unless `enclose` is False) by validated enclosures. "" if the exact replay rejects it (it
    blocks where the floats went on, e.g. at a domain's edge the float flow ran through, or
    it ends without a violation): no counterexample. A run the exact replay cannot decide
    gets a check starting with FLOAT_ONLY that says why: a candidate, never a counterexample;
    so does one the exact replay follows to its end without a violation (a flow's end on an
    equality test such as a ball's `h = 0`, at an irrational time, decided otherwise)."""
    exact = Interpreter(theorem, exact=True, max_steps=opts.max_steps, families=opts.families)
    why = ""
    try:
        if exact.run(Scripted(script)).violated is not None:
            return EXACT
        why = NOT_IN_EXACT
    except Inexact:  # a flow without a closed form: follow it by validated enclosures
        from certiloop.falsify.validated import confirm_enclosed

        validated, why = (confirm_enclosed(theorem, script, opts.max_steps, opts.families,
                                           retreat=is_deep(run))
                          if enclose else ("", "enclosures not tried"))
        if validated:
            return validated
    except (Blocked, Rejected, Diverged):  # blocks or turns where the floats went on (e.g. at a
        return ""  # domain's edge), or the start misses the assumptions: not a run
    except (ZeroDivisionError, OverflowError) as exc:
        why = f"the exact replay failed: {type(exc).__name__}"
    return float_only(run, why)
