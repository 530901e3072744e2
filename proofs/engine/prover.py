"""Prove a theorem: obligations -> (abstraction) -> z3 in a process pool -> theorem verdict."""

from __future__ import annotations

import math
import multiprocessing
import os
import re
import time
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

from certiloop.models.lang.terms import ModelError
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.core.vacuity import nonblocking_obligations
from certiloop.proofs.core.vcgen import Obligation, TooManyObligations, generate
from certiloop.proofs.core.verdicts import Decision, ObligationResult, RunEvidence, decide_theorem, readable
from certiloop.proofs.engine.budget import PLAN_SHARE, QUICK_SHARE, SCREEN_SHARE, WAVE, Budget
from certiloop.proofs.engine.discharge import discharge_one
from certiloop.proofs.engine.early_iterations import (
    division_by_zero_on_a_run,
    ill_defined_reason,
    loop_division_open,
)
from certiloop.proofs.engine.eigen import ghost_options
from certiloop.proofs.engine.odeplan import plan_odes
from certiloop.proofs.engine.vacuous import vacuity
from certiloop.proofs.engine.witnesses import WITNESS_RETRY_OBLIGATIONS, witness_options


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
    run: RunEvidence | None = None  # how the refutation's run was confirmed
    ill_defined: bool = False  # a division in the claim itself can be by zero
    inconsistent: bool = False  # proofs and a confirmed run disagree: a certiloop bug
    # vacuity (theorems with check_nonblocking, once proved): the step always has a run
    nonblocking: list[ObligationResult] | None = None
    witness: str = ""  # the vacuity witness run: how it replayed, or why there is none
    witness_replayed: bool = False
    vacuous: str = ""  # why the proof says nothing (vacuous.py), "" when it is not shown vacuous
    # (theorem, ODE plan) whose obligations the results are: what a certificate records
    proof: Any = field(default=None, repr=False)

    @property
    def nonblocking_verdict(self) -> str | None:
        if self.nonblocking is None:
            return None
        proved = all(o.verdict == "proved" for o in self.nonblocking) and self.witness_replayed
        return "proved" if proved else "unknown"

    def _repr_html_(self) -> str:  # notebook display
        from certiloop.proofs.engine.display import result_html

        return result_html(self.to_json())

    def to_json(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "verdict": self.verdict,
            "expected": self.expected,
            "seconds": round(self.seconds, 4),
            "reason": self.reason,
            "counterexample": self.refutation.to_json() if self.refutation else None,
            "run_check": None if self.run is None else {
                "rechecked": self.run.rechecked, "replayed": self.run.replayed,
                "flows_confirmed": self.run.flows_confirmed, "detail": self.run.detail,
                "negation_proved": self.run.negation_proved},
            "ill_defined": self.ill_defined,
            "inconsistent": self.inconsistent,
            "obligations": [o.to_json() for o in self.obligations],
            **({"nonblocking": {"verdict": self.nonblocking_verdict, "witness": self.witness,
                                "obligations": [o.to_json() for o in self.nonblocking]}}
               if self.nonblocking is not None else {}),
            **({"vacuous": self.vacuous} if self.vacuous else {}),
            **self.extra,
        }


def _no_refutation(r: ObligationResult) -> ObligationResult:
    """A vacuity obligation is a strengthening of "has a run" (witnesses, flows of duration
    0), so a counterexample to it only shows where the argument failed, not a blocked state."""
    if r.verdict == "refuted":
        r.verdict = "unknown"
        r.reason = ("not proved: the argument that a run exists fails at the state shown, "
                    "which may still have one")
    return r


def _refute_task(theorem: Theorem, budget: Budget):
    from certiloop.proofs.refute import refute

    return refute(theorem, budget)


def _witness_task(theorem: Theorem, budget: Budget):
    from certiloop.proofs.refute.witness import find_witness

    return find_witness(theorem, budget)


def _nonblocking_task(theorem: Theorem, budget: Budget) -> tuple[list[ObligationResult], str | None, bool]:
    """The vacuity check (Prover._vacuity) whole, on a worker beside the proof of a claim
    expected to hold: its obligations' results, then the witness's message and whether its run
    replayed (None, False when an obligation is not proved: nothing more was tried)."""
    results = [_no_refutation(discharge_one(ob, budget)) for ob in nonblocking_obligations(theorem)]
    if not all(r.verdict == "proved" for r in results):
        return results, None, False
    witness, why = _witness_task(theorem, budget)
    if witness is None:
        return results, why, False
    from certiloop.falsify.replay import replay_witness

    outcome = replay_witness(theorem, witness)
    return results, outcome.message, outcome.violated


def confirm_run(theorem: Theorem, refutation) -> RunEvidence:
    """The independent checks of a violating run the refuter found (and re-checked exactly
    on the unrolled claim): the interpreter replays it from the same start — other code:
    compiled closures, real loops — and every closed-form flow on it is integrated
    numerically (scipy) and must agree."""
    from certiloop.falsify.replay import replay_refutation

    outcome = replay_refutation(theorem, refutation)
    return RunEvidence(True, outcome.violated, outcome.flows_confirmed, outcome.message)


class Prover:
    """Holds the worker pool across theorems so workers are forked once, before z3 is used
    in this process."""

    def __init__(self, jobs: int | None = None, budget: Budget | None = None,
                 executor: str | None = None) -> None:
        """executor: a Dask scheduler address (tcp://host:8786) to discharge obligations on
        instead of the local process pool."""
        self.jobs = max(1, jobs or os.cpu_count() or 1)
        self.budget = budget or Budget()
        self._pool: Executor | None = None
        self._memo: dict[tuple, ObligationResult] = {}  # this theorem's discharged obligations
        if executor is not None:
            self._pool = dask_executor(executor)

    def __enter__(self) -> "Prover":
        return self

    def __exit__(self, exc_type=None, *exc) -> None:
        if self._pool is None:
            return
        client = getattr(self._pool, "_certiloop_client", None)
        if client is not None:  # a Dask executor: leave the cluster running, drop our connection
            self._pool.shutdown(wait=False)
            client.close()
        elif exc_type is KeyboardInterrupt:  # Ctrl-C: stop the workers, do not wait for them
            for worker in list((getattr(self._pool, "_processes", None) or {}).values()):
                worker.terminate()
            self._pool.shutdown(wait=False, cancel_futures=True)
        else:
            self._pool.shutdown(cancel_futures=True)

    def _executor(self) -> Executor | None:
        if self._pool is not None:
            return self._pool
        if self.jobs == 1:
            return None
        ctx = multiprocessing.get_context("fork")
        self._pool = ProcessPoolExecutor(max_workers=self.jobs, mp_context=ctx)
        return self._pool

    def prove(
        self,
        theorem: Theorem,
        on_result: Callable[[ObligationResult], None] | None = None,
        on_start: Callable[[int], None] | None = None,
        smtlib_dir: Path | None = None,
        search: bool = True,
    ) -> TheoremResult:
        """search=False only discharges the obligations: a theorem not proved is then
        'unknown', without the (costly) search for a violating run."""
        if options := witness_options(theorem):
            return self._witnessed(theorem, options, on_result, on_start, smtlib_dir)
        start = time.perf_counter()
        self._memo = {}
        # whether a proof would be vacuous, on a worker beside the proof of a claim expected to hold
        beside = theorem.expected == "proved" and self._executor() is not None
        vacuous = self._submit(vacuity, theorem, self.budget) if beside else None
        nonblocking = self._submit(_nonblocking_task, theorem, self.budget) \
            if beside and theorem.check_nonblocking else None
        source = (theorem, {})
        too_many: TooManyObligations | None = None
        try:
            obligations = generate(theorem, limit=self.budget.max_obligations)
        except TooManyObligations as exc:  # a count: nothing is tried, the verdict is at most unknown
            obligations, too_many = [], exc
        except ModelError as exc:
            # no obligations (e.g. a flow without a polynomial solution inside a formula's
            # modality): the claim may still be refuted at a small state by a proof
            found = self._refute_by_negation(theorem, [], exc) if search else None
            if found is None:
                raise
            refutation, evidence = found
            reason = (f"the claim is false at the state shown: its negation is proved there "
                      f"(its own obligations cannot be generated: {exc})")
            return TheoremResult(theorem.name, "refuted", theorem.expected, time.perf_counter() - start, [],
                                 reason, refutation, run=evidence)
        if on_start:
            on_start(len(obligations))
        if smtlib_dir is not None:
            write_smtlib(theorem.name, obligations, smtlib_dir)
        refutation, why, evidence = None, "", None
        if too_many is not None:
            # never an empty list: decide_theorem calls no obligations all proved
            results = [ObligationResult("o1", "the whole proof", "unknown", 0.0, backend="none",
                                        reason=str(too_many))]
            if on_result:
                on_result(results[0])
            if search:
                refutation, why = self._run(_refute_task, theorem, self.budget)
                evidence = confirm_run(theorem, refutation) if refutation is not None else None
        elif theorem.expected == "refuted" and search:
            # Scheduling only: search for the run while a quick per-branch report runs, and
            # give the branches their full budget only if no confirmed run was found.
            search = self._submit(_refute_task, theorem, self.budget)
            results = self._discharge(obligations, None, self.budget.share(QUICK_SHARE), quick=True)
            refutation, why = search.result()
            evidence = confirm_run(theorem, refutation) if refutation is not None else None
            full = evidence is None or not evidence.confirmed
            results = self._redischarge(obligations, results, everything=full)
            if on_result:
                for r in results:
                    on_result(r)
        else:
            results = self._screened(obligations, on_result)
            self._source = (theorem, {})
            if any(r.verdict != "proved" for r in results):
                results = self._planned(theorem, results)
            source = self._source
            if search and any(r.verdict != "proved" for r in results):
                refutation, why = self._run(_refute_task, theorem, self.budget)
                evidence = confirm_run(theorem, refutation) if refutation is not None else None
        if search and not (evidence is not None and evidence.confirmed) and any(r.verdict != "proved"
                                                                               for r in results):
            found = self._refute_by_negation(theorem, results)
            if found is not None:
                refutation, evidence = found
        decision = decide_theorem(results, evidence, why)
        if search and not decision.ill_defined and not decision.inconsistent and loop_division_open(results):
            found = division_by_zero_on_a_run(theorem, lambda obs: self._discharge(obs, None, self.budget))
            if found is not None:
                decision = Decision("unknown", ill_defined_reason(found), ill_defined=True)
        result = TheoremResult(theorem.name, decision.verdict, theorem.expected, 0.0, results,
                               decision.reason, refutation, run=evidence, ill_defined=decision.ill_defined,
                               inconsistent=decision.inconsistent)
        if decision.verdict == "proved" and too_many is None:
            result.proof = source
        if theorem.check_nonblocking and decision.verdict == "proved":
            self._vacuity(theorem, result, nonblocking)
        if decision.verdict == "proved":
            result.vacuous = (vacuous or self._submit(vacuity, theorem, self.budget)).result()
        result.seconds = time.perf_counter() - start
        return result

    def _witnessed(self, theorem: Theorem, options: list, on_result, on_start, smtlib_dir) -> TheoremResult:
        """The guarantee's ∃s around loops proved with each choice of witness terms in turn
        (witnesses.py; any choice is sound) until one proves the claim; else the attempt that
        left the fewest obligations open, unknown. A proof with more than
        WITNESS_RETRY_OBLIGATIONS obligations gets one attempt. No run can refute such a claim (a run
        shows a box false, not an ∃), so there is no search for one."""
        start = time.perf_counter()
        best = None
        for option in options:
            witnesses, ghosts = option
            attempt = self.prove(replace(theorem, witnesses=witnesses, ghosts=ghosts), smtlib_dir=smtlib_dir,
                                 search=False)
            still_open = sum(r.verdict != "proved" for r in attempt.obligations)
            if best is None or still_open < best[0]:
                best = (still_open, attempt, option)
            if attempt.verdict == "proved" or len(attempt.obligations) > WITNESS_RETRY_OBLIGATIONS:
                break  # a large proof is not tried again (a count, not a clock)
        _, result, option = best

        def shown(option) -> str:
            witnesses, ghosts = option
            text = ", ".join(f"{v} := {t}" for v, t in witnesses[len(theorem.witnesses):])
            new = ghosts[len(theorem.ghosts):]
            return text + "".join(f" (a ghost with {fact})" for _, fact in new)

        if result.verdict == "proved":
            result.reason = f"with the witness {shown(option)}" + (f"; {result.reason}" * bool(result.reason))
        else:
            tried = "; ".join(shown(o) for o in options)
            result.reason = f"{result.reason} (witnesses tried: {tried}; the closest: {shown(option)})"
        if on_start:
            on_start(len(result.obligations))
        for r in result.obligations if on_result else ():
            on_result(r)
        result.seconds = time.perf_counter() - start
        return result

    def _refute_by_negation(self, theorem: Theorem, results: list[ObligationResult],
                            no_obligations: ModelError | None = None):
        """(refutation, evidence) when the claim's negation is proved at the state of a failed
        obligation's model or, when the theorem has no obligations, at a small state
        (refute/negation.py), else None."""
        from certiloop.proofs.refute.negation import candidates, negation_at, small_states
        from certiloop.proofs.refute.unroll import Refutation

        models = [r.raw_model for r in results if r.raw_model is not None and r.kind == "safety"]
        states = small_states(theorem) if no_obligations is not None else candidates(theorem, models)
        for state in states:
            start = time.perf_counter()
            try:
                proofs = [self.prove(part, search=False) for part in negation_at(theorem, state)]
            except ModelError:  # the negation has no obligations either
                return None
            if any(proof.verdict != "proved" for proof in proofs):
                continue
            shown = readable(state)
            refutation = Refutation(0, shown, [], f"{theorem.guarantee} fails from this state",
                                    "a proof of the negation", time.perf_counter() - start, dict(state))
            detail = (f"not one run: the claim's negation at this state is proved "
                      f"({sum(len(proof.obligations) for proof in proofs)} obligation(s))")
            return refutation, RunEvidence(True, False, False, detail, negation_proved=True)
        return None

    def _planned(self, theorem: Theorem, results: list[ObligationResult]) -> list[ObligationResult]:
        """When obligations are open, search ODE cut chains (automatic invariants, other
        rules and orders) and keep the planned proof if it leaves fewer open; if some stay
        open, search again with SDP certificates as the chains of the ODEs they cover (costly,
        hence second). All are sound; the search only chooses which to report."""
        planning = self.budget.share(PLAN_SHARE)
        for certify in (False, True):
            plan = plan_odes(theorem, lambda ob: discharge_one(ob, planning, shaping=False), certify)
            if not plan:
                continue
            planned = self._screened(generate(theorem, plan), None)
            if sum(r.verdict != "proved" for r in planned) < sum(r.verdict != "proved" for r in results):
                results, self._source = planned, (theorem, plan)
            if all(r.verdict == "proved" for r in results):
                return results
        for option in ghost_options(theorem):  # eigen.py: the same claim, with a ghost's hints
            plan = plan_odes(option, lambda ob: discharge_one(ob, planning, shaping=False))
            planned = self._screened(generate(option, plan), None)
            if sum(r.verdict != "proved" for r in planned) < sum(r.verdict != "proved" for r in results):
                results, self._source = planned, (option, plan)
            if all(r.verdict == "proved" for r in results):
                break
        return results

    def _vacuity(self, theorem: Theorem, result: TheoremResult, beside: Future | None = None) -> None:
        """The step has a run from every state it can start in (obligations), and here is
        one (a witness the interpreter replays). beside: the same, already submitted to a
        worker (_nonblocking_task) while the proof ran."""
        if beside is not None:
            result.nonblocking, witness, replayed = beside.result()
            if witness is not None:
                result.witness, result.witness_replayed = witness, replayed
            return
        result.nonblocking = [_no_refutation(r) for r in
                              self._discharge(nonblocking_obligations(theorem), None, self.budget)]
        if not all(r.verdict == "proved" for r in result.nonblocking):
            return
        witness, why = self._run(_witness_task, theorem, self.budget)
        if witness is None:
            result.witness = why
            return
        from certiloop.falsify.replay import replay_witness

        outcome = replay_witness(theorem, witness)
        result.witness, result.witness_replayed = outcome.message, outcome.violated

    def _run(self, fn, *args):
        return self._submit(fn, *args).result()

    def submit(self, fn, *args) -> Future:
        """Run `fn(*args)` on the prover's workers (in this process with one job), e.g. the
        gate's falsifier beside the proof: `fn` and its arguments must pickle."""
        return self._submit(fn, *args)

    def _submit(self, fn, *args) -> Future:
        pool = self._executor()
        if pool is not None:
            return pool.submit(fn, *args)
        done: Future = Future()
        done.set_result(fn(*args))
        return done

    def _screened(self, obligations: list[Obligation],
                  on_result: Callable[[ObligationResult], None] | None) -> list[ObligationResult]:
        """The obligations in waves of WAVE, in order, each with the whole budget, until one
        is refuted: then this proof cannot succeed (an obligation refuted with some budget is
        refuted with any, its counterexample being exact), and the later waves get a share,
        all but those about well-definedness, which decide whether the claim means anything.
        A proof that holds costs what it did; one that fails early no longer spends a whole
        budget on every open obligation after it (IJRR17 Theorem 13: three of 2,000,000
        units, 20 s each, after a refuted link). Waves of a fixed size, not the order the
        workers finish in, decide: the report is the same on every machine."""
        results: list[ObligationResult] = []
        for k in range(0, len(obligations), WAVE):
            wave = obligations[k:k + WAVE]
            if any(r.verdict == "refuted" for r in results):
                share = self._discharge(wave, None, self.budget.share(SCREEN_SHARE))
                results += self._redischarge(wave, share, everything=False)
            else:
                results += self._discharge(wave, None, self.budget)
        if on_result:
            for r in results:
                on_result(r)
        return results

    def _redischarge(self, obligations: list[Obligation], quick: list[ObligationResult],
                     everything: bool) -> list[ObligationResult]:
        """Give obligations a quick pass left open their full budget: all of them, or (when
        a confirmed run already decides the verdict) those about well-definedness, which
        must never be left undecided by a share."""
        again = [ob for ob, r in zip(obligations, quick)
                 if r.verdict != "proved" and (everything or ob.kind == "defined")]
        redone = {r.id: r for r in self._discharge(again, None, self.budget)}
        return [redone.get(r.id, r) for r in quick]

    def _discharge(self, obligations: list[Obligation],
                   on_result: Callable[[ObligationResult], None] | None,
                   budget: Budget, quick: bool = False) -> list[ObligationResult]:
        """Each obligation's result, in order. One the theorem's proof met already (the
        planner's proofs repeat most of the first one's) is not discharged again: the same
        obligation with the same budget gets the same answer."""
        keys = [(_identity(ob), budget, quick) for ob in obligations]
        todo = list({k: ob for k, ob in zip(keys, obligations) if k not in self._memo}.items())
        for (key, _), result in zip(todo, self._discharge_all([ob for _, ob in todo], budget, quick)):
            self._memo[key] = result
        results = [replace(self._memo[k], id=ob.id, path=ob.path, rule=ob.rule)
                   for k, ob in zip(keys, obligations)]
        if on_result:
            for result in results:
                on_result(result)
        return results

    def _discharge_all(self, obligations: list[Obligation], budget: Budget,
                       quick: bool) -> list[ObligationResult]:
        pool = self._executor()
        if pool is None or len(obligations) <= 1:
            return [discharge_one(ob, budget, quick) for ob in obligations]
        size = max(1, math.ceil(len(obligations) / (self.jobs * RUNS_PER_WORKER)))
        runs = [obligations[k:k + size] for k in range(0, len(obligations), size)]
        futures = [pool.submit(_discharge_run, run, budget, quick) for run in runs]
        return [result for fut in futures for result in fut.result()]


# Obligations go to the workers in runs of neighbours, a run in one message: the hypotheses
# they share are pickled once and stay one object in the worker, where the weakenings'
# memos (terms.NodeMemo) find them again. Six runs per worker keep the last ones short.
RUNS_PER_WORKER = 6


def _identity(ob: Obligation) -> tuple:
    """What decides an obligation's answer: its formula, kind, stronger forms and abbreviations."""
    return (ob.formula.key, ob.kind, tuple(f.key for _, f in ob.stronger),
            tuple(sorted((k, v.key) for k, v in ob.abbreviations.items())))


def _discharge_run(obligations: list[Obligation], budget: Budget, quick: bool) -> list[ObligationResult]:
    return [discharge_one(ob, budget, quick) for ob in obligations]


def dask_executor(address: str) -> Executor:
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
    """Each obligation as a standalone SMT-LIB 2.6 script (our printer; `unsat` proves it)."""
    from certiloop.proofs.arith.smtlib import script

    folder.mkdir(parents=True, exist_ok=True)
    for ob in obligations:
        text = script(ob.formula, f"certiloop obligation {model} {ob.id}: {ob.path}")
        safe = re.sub(r"[^\w.+=-]+", "_", model).strip("_")  # an archive entry's name may hold / or :
        (folder / f"{safe}.{ob.id}.smt2").write_text(text)
