"""Prove a theorem: obligations -> (abstraction) -> z3 in a process pool -> theorem verdict."""

from __future__ import annotations

import multiprocessing
import os
import time
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from certiloop.models.lang.terms import INT, ModelError
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.arith.abstraction import abbreviation_instances, abstract, congruences, lower_term
from certiloop.proofs.core.instantiate import instantiate
from certiloop.proofs.core.lowering import lower
from certiloop.proofs.core.solver import check_valid, smtlib_text
from certiloop.proofs.core.vacuity import nonblocking_obligations
from certiloop.proofs.core.vcgen import Obligation, generate
from certiloop.proofs.core.verdicts import ObligationResult, judge


@dataclass
class TheoremResult:
    model: str
    verdict: str  # proved | refuted | unknown
    expected: str
    seconds: float
    obligations: list[ObligationResult]
    reason: str = ""
    refutation: Any = None  # refute.Refutation
    extra: dict[str, Any] = field(default_factory=dict)
    # vacuity (theorems with check_nonblocking, once proved): the step always has a run
    nonblocking: list[ObligationResult] | None = None

    @property
    def nonblocking_verdict(self) -> str | None:
        if self.nonblocking is None:
            return None
        return "proved" if all(o.verdict == "proved" for o in self.nonblocking) else "unknown"

    @property
    def met_expectation(self) -> bool:
        return self.verdict == self.expected

    def to_json(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "verdict": self.verdict,
            "expected": self.expected,
            "seconds": round(self.seconds, 4),
            "reason": self.reason,
            "counterexample": self.refutation.to_json() if self.refutation else None,
            "obligations": [o.to_json() for o in self.obligations],
            **({"nonblocking": {"verdict": self.nonblocking_verdict,
                                "obligations": [o.to_json() for o in self.nonblocking]}}
               if self.nonblocking is not None else {}),
            **self.extra,
        }


PROJECTED_CEX_SECONDS = 2.0


QUICK_SECONDS = 0.5  # per check once a violating run is known: the report, not the verdict


def discharge_one(ob: Obligation, timeout_s: float, keep_model: bool = False) -> ObligationResult:
    """Prove one obligation: first in abstracted form (if that applies), then as stated.

    The abstracted form is only trusted for `proved` (a generalisation); a counterexample
    always comes from the obligation as stated. keep_model keeps the raw solver model,
    which may hold live z3 handles and so cannot leave this process."""
    start = time.perf_counter()
    budget = timeout_s  # shrinks once a projected form has a counterexample
    projected_cex = False

    def left() -> float:  # timeout_s is for the whole obligation, all its forms together
        return max(0.05, min(budget, start + timeout_s - time.perf_counter()))

    for backend, weaker in _weakenings(ob):
        if projected_cex and budget <= QUICK_SECONDS and "abstracted" not in backend:
            continue  # quick mode: raw forms of a projected-false obligation never finish in time
        answer = check_valid(weaker, left())
        if answer.status == "unsat":
            res = judge(ob.id, ob.path, weaker, answer, time.perf_counter() - start)
            res.backend = backend
            return res
        if answer.status == "sat" and "abstracted" in backend:
            # likely false as stated too: the raw forms below rarely decide it, so keep them short
            projected_cex = True
            budget = min(budget, PROJECTED_CEX_SECONDS)
    if projected_cex and budget <= QUICK_SECONDS:
        return ObligationResult(ob.id, ob.path, "unknown", time.perf_counter() - start,
                                reason="not proved: its projected form (abstracted) has a counterexample")
    answer = check_valid(ob.formula, left())
    res = judge(ob.id, ob.path, ob.formula, answer, time.perf_counter() - start)
    if res.verdict == "unknown" and projected_cex:
        res.reason = (f"{res.reason}; its projected form (abstracted) has a counterexample, "
                      "so it is probably false")
    if not keep_model:
        res.raw_model = None
    return res


def _weakenings(ob: Obligation):
    """Formulas that imply the obligation and are easier for z3: instantiated quantifiers,
    then projected (abstracted) arithmetic. Only an `unsat` (proved) answer is used."""
    if _quantifies_integers(ob.formula):
        return  # z3's own quantifier engine handles integer-indexed arrays (builtDR) best
    yield from _weakened(ob, wide=False)
    if instantiate(ob.formula) is not None:
        yield from _weakened(ob, wide=True)


def _quantifies_integers(n) -> bool:
    if n.op in ("forall", "exists") and any(v.sort == INT for v in n.payload):
        return True
    return any(_quantifies_integers(a) for a in n.args)


def _weakened(ob: Obligation, wide: bool):
    base, steps = ob.formula, []
    instantiated = instantiate(base, wide)
    if instantiated is not None:
        base, steps = instantiated, ["instantiated more" if wide else "instantiated"]
    lowered = lower(base) if _has_arrays(base) else None
    instances = abbreviation_instances(ob.abbreviations, base)
    index_term = lambda t: t  # noqa: E731
    if lowered is not None:
        base, steps = lowered, steps + ["lowered"]
        instances = [i.with_definition(lower_term(i.definition)) for i in instances]
        index_term = lower_term
    abstracted = abstract(base, instances, congruences(instances, index_term))
    if abstracted is not None:
        yield f"z3 ({', '.join(steps + ['abstracted'])})", abstracted
    if steps:
        yield f"z3 ({', '.join(steps)})", base


def _has_arrays(n) -> bool:
    return n.op in ("select", "store") or any(_has_arrays(a) for a in n.args)


def _no_refutation(r: ObligationResult) -> ObligationResult:
    """A vacuity obligation is a strengthening of "has a run" (witnesses, flows of duration
    0), so a counterexample to it only shows where the argument failed, not a blocked state."""
    if r.verdict == "refuted":
        r.verdict = "unknown"
        r.reason = ("not proved: the argument that a run exists fails at the state shown, "
                    "which may still have one")
    return r


def _refute_task(theorem: Theorem, timeout_s: float):
    from certiloop.proofs.refute.search import refute

    return refute(theorem, timeout_s)


class Prover:
    """Holds the worker pool across theorems so workers are forked once, before z3 is used
    in this process."""

    def __init__(self, jobs: int | None = None, timeout_s: float = 30.0, executor: str | None = None) -> None:
        """executor: a Dask scheduler address (tcp://host:8786) to discharge obligations on
        instead of the local process pool."""
        self.jobs = max(1, jobs or os.cpu_count() or 1)
        self.timeout_s = timeout_s
        self._pool: Executor | None = None
        self._client = None
        if executor is not None:
            self._pool = _dask_executor(executor)

    def __enter__(self) -> "Prover":
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is None:
            return
        client = getattr(self._pool, "_certiloop_client", None)
        if client is not None:  # a Dask executor: leave the cluster running, drop our connection
            self._pool.shutdown(wait=False)
            client.close()
        else:
            self._pool.shutdown(cancel_futures=True)

    def _executor(self) -> Executor | None:
        if self._pool is not None:
            return self._pool
        if self.jobs == 1:
            return None
        if self._pool is None:
            ctx = multiprocessing.get_context("fork")
            self._pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=ctx)
        return self._pool

    def prove(
        self,
        theorem: Theorem,
        on_result: Callable[[ObligationResult], None] | None = None,
        on_start: Callable[[int], None] | None = None,
        smtlib_dir: Path | None = None,
    ) -> TheoremResult:
        start = time.perf_counter()
        obligations = generate(theorem)
        if on_start:
            on_start(len(obligations))
        if smtlib_dir is not None:
            write_smtlib(theorem.name, obligations, smtlib_dir)
        refutation, why = None, ""
        if theorem.expected == "refuted":
            # Scheduling only: a violating run makes `proved` impossible whatever the
            # obligations say, so search for it while a quick per-branch report runs, and
            # give the branches their full time only if no run was found.
            search = self._submit(_refute_task, theorem, self.timeout_s)
            results = self._discharge(obligations, None, QUICK_SECONDS)
            refutation, why = search.result()
            if refutation is None:
                results = self._redischarge(obligations, results)
            if on_result:
                for r in results:
                    on_result(r)
        else:
            results = self._discharge(obligations, on_result, self.timeout_s)
        verdict, reason = "proved", ""
        if any(r.verdict != "proved" for r in results):
            if refutation is None and theorem.expected != "refuted":
                refutation, why = self._run(_refute_task, theorem, self.timeout_s)
            if refutation is not None:
                verdict = "refuted"
                reason = f"a run with {refutation.depth} loop iteration(s) violates the guarantee"
            else:
                verdict = "unknown"
                failed = [r for r in results if r.verdict != "proved"]
                reason = (f"{len(failed)} obligation(s) not proved (first: {failed[0].path}: "
                          f"{failed[0].verdict}{': ' + failed[0].reason if failed[0].reason else ''}); "
                          f"{why}")
        nonblocking = None
        if theorem.check_nonblocking and verdict == "proved":
            nonblocking = [_no_refutation(r) for r in
                           self._discharge(nonblocking_obligations(theorem), None, self.timeout_s)]
        return TheoremResult(theorem.name, verdict, theorem.expected, time.perf_counter() - start,
                             results, reason, refutation, nonblocking=nonblocking)

    def _run(self, fn, *args):
        return self._submit(fn, *args).result()

    def _submit(self, fn, *args) -> Future:
        pool = self._executor()
        if pool is not None:
            return pool.submit(fn, *args)
        done: Future = Future()
        done.set_result(fn(*args))
        return done

    def _redischarge(self, obligations: list[Obligation],
                     quick: list[ObligationResult]) -> list[ObligationResult]:
        """Give the obligations a quick pass left open their full time."""
        again = [ob for ob, r in zip(obligations, quick) if r.verdict != "proved"]
        redone = iter(self._discharge(again, None, self.timeout_s))
        return [r if r.verdict == "proved" else next(redone) for r in quick]

    def _discharge(self, obligations: list[Obligation],
                   on_result: Callable[[ObligationResult], None] | None,
                   timeout_s: float) -> list[ObligationResult]:
        pool = self._executor()
        results: list[ObligationResult] = []
        if pool is None or len(obligations) == 1:
            for ob in obligations:
                results.append(discharge_one(ob, timeout_s))
                if on_result:
                    on_result(results[-1])
            return results
        futures = [pool.submit(discharge_one, ob, timeout_s) for ob in obligations]
        for fut in futures:
            results.append(fut.result())
            if on_result:
                on_result(results[-1])
        return results


def _dask_executor(address: str) -> Executor:
    """A concurrent.futures executor on an existing Dask cluster: obligations are
    independent units of work, as in the paper's distributed KeYmaeraD."""
    try:
        from distributed import Client
    except ImportError:
        raise ImportError("--executor needs Dask: pip install 'certiloop[distributed]'") from None
    try:
        client = Client(address, timeout=10)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ModelError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
    executor = client.get_executor()
    executor._certiloop_client = client  # keep the connection alive with the executor
    return executor


def write_smtlib(model: str, obligations: list[Obligation], folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for ob in obligations:
        text = smtlib_text(ob.formula, f"{model} {ob.id}: {ob.path}")
        (folder / f"{model}.{ob.id}.smt2").write_text(text + "(check-sat)\n" if "(check-sat)" not in text
                                                      else text)
