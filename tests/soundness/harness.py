"""Adversarial soundness suite: the case record, the ONE call into the engine, and the
independent tools the witnesses use.

Every case is a small theorem whose truth is known without certiloop: a witness computes a
violating run by hand (exact `Fraction` arithmetic on a hand-derived solution, or scipy's
`solve_ivp` for flows without a polynomial solution), or checks a one-line argument on
randomly sampled states. Witnesses never import certiloop's prover, interpreter, refuter or
falsifier (they may import nothing from certiloop at all).

Semantics the labels follow (differential dynamic logic, as README "Writing a model"):
  * a theorem is true iff every run from every state satisfying the assumptions ends in a
    state satisfying the guarantee; `x := *` picks any value of x's sort, a failing test
    has no run, loops iterate any finite number of times (annotations do not change truth);
  * an ODE runs for any duration τ >= 0 such that the evolution domain holds at every
    time in [0, τ] (the start included: no run at all if the domain is false at the start);
  * Int symbols only take integer values, and `/` is real division;
  * an index sort is any non-empty finite set;
  * a term dividing by something that can be 0 where it is evaluated, a symbol used with
    two sorts, an Int ODE state, ... make a theorem ill-formed.
Vacuity (`nonblocking`): "runs" iff from every state the control step can start in (the
body of the program's loop, at a state reachable at the loop's head; for a program that is
not a loop, its top-level loop's body, or the program itself if it has none) some run of
the step exists; otherwise "blocks". Cases are only labelled where the reading is clear.
"""

from __future__ import annotations

import multiprocessing
import os
import time
import traceback
import zlib
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Callable

import numpy as np

Q = Fraction
TRUTHS = ("true", "false", "ill-formed")


@dataclass
class Case:
    id: str  # short unique id, e.g. "ode-chain-3d-false"
    build: Callable[[], Any]  # () -> Theorem (may raise ModelError for ill-formed cases)
    truth: str  # "true" | "false" | "ill-formed"
    witness: Callable[[], None] | None  # independent evidence; asserts, run by the tests
    nonblocking: str | None = None  # for check_nonblocking theorems: "runs" | "blocks"
    # Also acceptable: the engine refuses the theorem. For cases whose only oddity is an
    # annotation (a dI with a division) or a name that looks internal: refusing them is a
    # fine answer, a wrong verdict is not.
    may_reject: bool = False

    def __post_init__(self) -> None:
        if self.truth not in TRUTHS:
            raise ValueError(f"{self.id}: truth must be one of {TRUTHS}")
        if self.nonblocking not in (None, "runs", "blocks"):
            raise ValueError(f"{self.id}: nonblocking must be runs/blocks/None")


# --------------------------------------------------------------------------- the engine


def verdict_of(theorem) -> tuple[str, str | None, str]:
    """THE ONLY CALL INTO THE ENGINE: (verdict, nonblocking verdict, reason).

    verdict is proved | refuted | unknown | rejected (ModelError) | crash:<Type>.
    verdict_of(None) only imports the engine (done once before forking the workers)."""
    from certiloop.models import ModelError

    try:
        from certiloop.proofs.engine import Prover

        if theorem is None:
            return "", None, ""
        with Prover(jobs=1) as p:
            r = p.prove(theorem)
    except ModelError as exc:
        return "rejected", None, str(exc)
    except Exception as exc:  # an internal error is a finding, not a verdict
        return f"crash:{type(exc).__name__}", None, _short_trace(exc)
    return r.verdict, r.nonblocking_verdict, r.reason


def _short_trace(exc: BaseException) -> str:
    tb = traceback.extract_tb(exc.__traceback__)[-3:]
    where = " <- ".join(f"{os.path.basename(f.filename)}:{f.lineno}" for f in reversed(tb))
    return f"{type(exc).__name__}: {exc} [{where}]"


def outcome_of(case: Case) -> dict[str, Any]:
    """Build the theorem (a ModelError there is a rejection too) and ask the engine."""
    from certiloop.models import ModelError

    start = time.perf_counter()
    try:
        theorem = case.build()
    except ModelError as exc:
        return {
            "verdict": "rejected",
            "nonblocking": None,
            "reason": f"at build: {exc}",
            "seconds": time.perf_counter() - start,
        }
    except Exception as exc:
        return {
            "verdict": f"crash:{type(exc).__name__}",
            "nonblocking": None,
            "reason": f"at build: {_short_trace(exc)}",
            "seconds": time.perf_counter() - start,
        }
    verdict, nonblocking, reason = verdict_of(theorem)
    return {
        "verdict": verdict,
        "nonblocking": nonblocking,
        "reason": reason,
        "seconds": time.perf_counter() - start,
    }


def allowed(case: Case, outcome: dict[str, Any]) -> tuple[bool, str]:
    """Is the engine's outcome acceptable for the case's truth? (ok, why not)."""
    v = outcome["verdict"]
    ok_set = {
        "true": {"proved", "unknown"},
        "false": {"refuted", "unknown"},
        "ill-formed": {"rejected", "unknown"},
    }[case.truth]
    if case.may_reject:
        ok_set = ok_set | {"rejected"}
    if v not in ok_set:
        return False, f"{v} for a {case.truth} theorem"
    if case.nonblocking == "blocks" and outcome.get("nonblocking") == "proved":
        return False, "nonblocking proved for a step that can block"
    return True, ""


# --------------------------------------------------------------------------- running many


def _child(conn, module: str, index: int) -> None:
    import importlib

    try:
        case = importlib.import_module(module).CASES[index]
        conn.send(outcome_of(case))
    except BaseException as exc:  # pragma: no cover - reported, never hidden
        conn.send(
            {
                "verdict": f"crash:{type(exc).__name__}",
                "nonblocking": None,
                "reason": _short_trace(exc),
                "seconds": 0.0,
            }
        )
    finally:
        conn.close()


HANG_SECONDS = float(os.environ.get("SOUNDNESS_HANG_SECONDS", "120"))


def _start_server(ctx) -> None:
    """Start the forkserver (once) with the engine imported. Python 3.11's forkserver does
    not apply the parent's sys.path before importing its preload, so PYTHONPATH carries the
    directory holding this package while the server starts (and is restored at once)."""
    from multiprocessing import forkserver

    ctx.set_forkserver_preload([f"{__package__}._warm"])  # no effect if a server already runs
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    old = os.environ.get("PYTHONPATH")
    os.environ["PYTHONPATH"] = root if not old else root + os.pathsep + old
    try:
        forkserver.ensure_running()
    finally:
        if old is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = old


def run_all(module: str, cases: list[Case], only: set[str] | None = None) -> dict[str, dict[str, Any]]:
    """Outcomes of every case of a theme module (or of those whose id is in `only`), each in
    its own process (so a hang or a crash of one cannot take the others down), SOUNDNESS_JOBS
    (default: cores) at once.

    The processes are forked from a forkserver that has imported the engine once (fast,
    and safe even if this pytest process runs threads). SOUNDNESS_INPROCESS=1 runs the
    cases here, one after the other (for debugging)."""
    if os.environ.get("SOUNDNESS_INPROCESS"):
        return {c.id: outcome_of(c) for c in cases if only is None or c.id in only}
    jobs = max(1, int(os.environ.get("SOUNDNESS_JOBS", str(os.cpu_count() or 1))))
    ctx = multiprocessing.get_context("forkserver")
    _start_server(ctx)
    # the index is the case's place in the module's CASES: the child looks it up there
    pending = [(k, c) for k, c in enumerate(cases) if only is None or c.id in only]
    running: dict[int, tuple[Any, Any, float]] = {}
    out: dict[str, dict[str, Any]] = {}

    def crash(kind: str, why: str, seconds: float = 0.0) -> dict[str, Any]:
        return {"verdict": f"crash:{kind}", "nonblocking": None, "reason": why, "seconds": seconds}

    while pending or running:
        while pending and len(running) < jobs:
            k, _case = pending.pop(0)
            parent, child = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_child, args=(child, module, k), daemon=True)
            proc.start()
            child.close()
            running[k] = (proc, parent, time.perf_counter())
        for k, (proc, conn, started) in list(running.items()):
            if conn.poll(0.01):
                try:
                    out[cases[k].id] = conn.recv()
                except EOFError:
                    out[cases[k].id] = crash("Died", f"process exited with {proc.exitcode}")
                proc.join(5)
            elif not proc.is_alive():
                out[cases[k].id] = crash("Died", f"process exited with {proc.exitcode}")
            elif time.perf_counter() - started > HANG_SECONDS:
                proc.kill()  # our own child, by its handle
                proc.join(5)
                out[cases[k].id] = crash("Hang", f"no answer after {HANG_SECONDS:g} s", HANG_SECONDS)
            else:
                continue
            conn.close()
            del running[k]
    return out


# results of the session, for the summary table: theme -> case id -> (outcome, ok, why)
RESULTS: dict[str, dict[str, tuple[dict[str, Any], bool, str]]] = {}


def record(theme: str, case: Case, outcome: dict[str, Any]) -> tuple[bool, str]:
    ok, why = allowed(case, outcome)
    RESULTS.setdefault(theme, {})[case.id] = (outcome, ok, why)
    return ok, why


# --------------------------------------------------------------------------- witness tools
# Plain Python / numpy / scipy only.

DEEP = os.environ.get("HYPOTHESIS_PROFILE") == "deep" or bool(os.environ.get("SOUNDNESS_DEEP"))
SAMPLES = 2000 if DEEP else 200


def rng(tag: str) -> np.random.Generator:
    """A fixed seed per case (derived from its id) by default; a fresh one in deep mode."""
    if DEEP:
        seed = int.from_bytes(os.urandom(8), "little")
        print(f"[{tag}] seed {seed}")
        return np.random.default_rng(seed)
    return np.random.default_rng(zlib.crc32(tag.encode()))


def rat(g: np.random.Generator, lo, hi, den: int = 64) -> Fraction:
    """A random rational in [lo, hi] with denominator dividing `den` (ends included)."""
    lo, hi = Fraction(lo), Fraction(hi)
    n_lo, n_hi = int(np.ceil(lo * den)), int(np.floor(hi * den))
    return Fraction(int(g.integers(n_lo, n_hi + 1)), den)


def rint(g: np.random.Generator, lo: int, hi: int) -> int:
    return int(g.integers(lo, hi + 1))


def grid(T, n: int = 64) -> list[Fraction]:
    """n+1 equally spaced rational times in [0, T]."""
    T = Fraction(T)
    return [T * k / n for k in range(n + 1)]


def ivp(f: Callable[[float, np.ndarray], Any], y0, T: float, dense: bool = False, **kw):
    """solve_ivp with tight tolerances; returns the end state (or the solution object)."""
    from scipy.integrate import solve_ivp

    sol = solve_ivp(
        f,
        (0.0, float(T)),
        np.asarray(y0, dtype=float),
        method="DOP853",
        rtol=1e-11,
        atol=1e-12,
        dense_output=dense,
        **kw,
    )
    assert sol.success, sol.message
    return sol if dense else sol.y[:, -1]


def crosscheck(
    rhs: Callable[[np.ndarray], list], y0: list, T, closed: Callable[[Fraction], list], tol: float = 1e-7
) -> None:
    """Check a hand-derived closed-form solution against numerical integration at T (and
    midway), so a slip in the derivation cannot hide behind a wrong label."""
    for when in (Fraction(T) / 2, Fraction(T)):
        num = ivp(lambda _t, y: rhs(y), [float(v) for v in y0], float(when))
        ref = [float(v) for v in closed(when)]
        scale = max(1.0, *(abs(r) for r in ref))
        assert np.allclose(num, ref, rtol=0, atol=tol * scale), (when, num, ref)


def check(cond: bool, *what) -> None:
    if not cond:
        raise AssertionError(" ".join(map(str, what)))


def randomized(tag: str, draw: Callable[[np.random.Generator], Any], holds: Callable[[Any], bool]):
    """A TRUE witness: SAMPLES states (and choices) drawn by `draw`, which builds them so that
    they satisfy the assumptions and runs the program by hand; `holds` checks the guarantee."""

    def w() -> None:
        g = rng(tag)
        for _ in range(SAMPLES):
            st = draw(g)
            check(holds(st), tag, st)

    return w
