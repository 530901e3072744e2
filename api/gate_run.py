"""The verification gate: every model must meet the verdict its author expects.

Per model: prove it; replay a prover counterexample in the interpreter; run the falsifier;
and, for models with a shipped kernel, check the kernel is exactly a fresh extraction.
A proved model passes only if every obligation is proved, the falsifier finds nothing, its
kernel has not drifted and, where the model asks for it, its control step provably never
blocks (vacuity). A refuted model passes only if the prover's counterexample
replays in the interpreter and the falsifier finds a violating run too. `unknown` (a
timeout, a solver give-up) never passes.
"""

from __future__ import annotations

import importlib
import os
import time
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable

from certiloop.api.loading import Unsupported
from certiloop.falsify.depth import FLOAT_ONLY, UNCONFIRMED
from certiloop.models.lang.terms import ModelError
from certiloop.models.lang.theorem import Theorem

if TYPE_CHECKING:  # the prover (z3, sympy) is imported only when a model is not cached
    from certiloop.proofs.engine.prover import Prover


@dataclass
class GateEntry:
    model: str
    expected: str
    verdict: str
    seconds: float
    obligations: list[dict[str, Any]]
    reason: str = ""
    counterexample: dict[str, Any] | None = None
    replay: dict[str, Any] | None = None
    falsify: dict[str, Any] = field(default_factory=dict)
    kernel: str | None = None  # None: no shipped kernel; "": matches; else the drift
    nonblocking: dict[str, Any] | None = None  # the vacuity check, for models that ask for it
    cross_check: dict[str, Any] | None = None  # cvc5's second opinion (gate --cross-check)
    inconsistent: bool = False  # proofs and a confirmed run disagree: a certiloop bug
    cached: bool = False
    vacuous: str = ""  # why the proof says nothing (unsatisfiable assumptions, a blocked first step)
    checked: str | None = None  # the proof checker's message on the proof's certificate (proved models)
    certificate: dict[str, Any] | None = field(default=None, repr=False)  # the one it checked; cached apart

    @property
    def alarm(self) -> bool:
        """A soundness alarm (exit 3), not just a failed expectation."""
        return self.inconsistent or bool(self.cross_check and self.cross_check["disagreements"])

    @property
    def problems(self) -> list[str]:
        out = []
        if self.verdict == "unknown":
            out.append(f"expected {self.expected}, but the proof is unknown: {self.reason}")
        elif self.verdict != self.expected:
            if self.expected == "refuted":
                out.append("expected refuted, but it PROVED: the unsafe design now looks safe")
            else:
                failed = [o for o in self.obligations if o["verdict"] != "proved"]
                where = f" at {failed[0]['path']}" if failed else ""
                out.append(f"expected proved, but it is {self.verdict}{where}: {self.reason}")
        if self.replay is not None and not self.replay["violated"]:
            out.append(f"the prover's counterexample does not replay: {self.replay['message']}")
        found = self.falsify.get("verdict") == "refuted"
        # a run checked in floating point only is no evidence against an exact proof (a lifted
        # root's s*s = e, an identity times 10^12: rounding); a validated one is
        validated = found and not str(self.falsify.get("check") or "").startswith(FLOAT_ONLY)
        if self.expected == "proved" and validated:
            out.append("the falsifier found a violating run of a proved model: "
                       f"{self.falsify.get('violated')}")
        if self.falsify.get("note"):  # e.g. unsatisfiable assumptions: a proof of nothing
            out.append(f"the falsifier could not start a single run: {self.falsify['note']}")
        # a model expected refuted: the prover's exactly replayed run decides it; the falsifier's
        # run, confirmed or only a float candidate, corroborates it
        elif self.expected == "refuted" and self.falsify and not self.falsify.get("skipped") \
                and self.falsify.get("verdict") not in ("refuted", UNCONFIRMED):
            out.append(f"the falsifier found no violating run in {self.falsify.get('examples')} examples")
        if self.verdict == "proved" and not (self.checked or "").startswith("accepted"):
            out.append("proved, but the proof checker's acceptance of its certificate is not recorded")
        if self.vacuous:
            out.append(f"vacuous: {self.vacuous}")
        if self.nonblocking is not None and self.nonblocking["verdict"] != "proved":
            out.append("the vacuity check is not proved: the control step may block")
        if self.kernel:
            out.append(self.kernel)
        if self.cross_check and self.cross_check["disagreements"]:
            ids = ", ".join(d["id"] for d in self.cross_check["disagreements"])
            out.append(f"SOUNDNESS ALARM: cvc5 disagrees with z3's proof of {ids}")
        return out

    @property
    def passed(self) -> bool:
        return not self.problems

    @property
    def message(self) -> str:
        return "; ".join(self.problems) or "as expected"

    def to_json(self) -> dict[str, Any]:
        return {"model": self.model, "expected": self.expected, "verdict": self.verdict,
                "seconds": round(self.seconds, 4), "reason": self.reason,
                "counterexample": self.counterexample, "replay": self.replay, "falsify": self.falsify,
                "kernel": self.kernel, "nonblocking": self.nonblocking, "obligations": self.obligations,
                "cross_check": self.cross_check, "inconsistent": self.inconsistent, "cached": self.cached,
                "passed": self.passed, "message": self.message, "checked": self.checked,
                **({"vacuous": self.vacuous} if self.vacuous else {})}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> "GateEntry":
        keep = {k: data.get(k) for k in ("model", "expected", "verdict", "seconds", "obligations", "reason",
                                         "counterexample", "replay", "falsify", "kernel", "nonblocking",
                                         "cross_check", "inconsistent")}
        return cls(**keep, cached=True, vacuous=data.get("vacuous", ""), checked=data.get("checked"))


AHEAD = 2  # falsifiers queued ahead of the model being proved: while the main process builds
# the next obligations, both workers have a falsifier to run (22-model gate: 45.0 s -> 41.2 s)
REFUTED_FACTOR = 10  # a model expected refuted may take 10x the examples: the search stops at
# its first violating run, so this costs only when there is none (some seeds need 500+)
AFTER_BATCH_SHARE = 3  # a model expected proved whose 4,096 batch runs found nothing gets a
# third of the hypothesis examples: guided runs towards small margins after the broad sweep
# (sbs.ctrl2's falsifier: 6.8 -> 4.7 s; sbs.ctrl1: 1.9 -> 0.9 s). Mutants keep the full budget.


@dataclass
class GateOptions:
    falsify_examples: int = 300
    seed: int = 0
    cross_check: bool = False  # cvc5 re-checks every proved obligation

    def text(self) -> str:
        return f"falsify={self.falsify_examples}/seed={self.seed}" + ("/cvc5" if self.cross_check else "")


def falsify_task(theorem: Theorem, opts: GateOptions):
    """The gate's falsifier run, on a prover worker: it needs nothing from the proof, so it
    runs beside it (a seeded search: the same answer in any process)."""
    from certiloop.falsify.search import Options, falsify

    refuted = theorem.expected == "refuted"
    examples = opts.falsify_examples * (REFUTED_FACTOR if refuted else 1)
    after_batch = None if refuted else max(1, opts.falsify_examples // AFTER_BATCH_SHARE)
    return falsify(theorem, Options(max_examples=examples, seed=opts.seed, database=None, shrink=False,
                                    after_batch_examples=after_batch,
                                    batch_first=None if refuted else Options.batch_runs))


def check_model(theorem: Theorem, prover: Prover, opts: GateOptions,
                falsifier: Future | None = None) -> GateEntry:
    """falsifier: this model's falsify_task, if already submitted."""
    start = time.perf_counter()
    if falsifier is None:
        falsifier = prover.submit(falsify_task, theorem, opts)
    result = prover.prove(theorem)
    checked = _check_proof(result)
    replay = None
    if result.run is not None:  # the engine's independent checks of its run
        replay = {"violated": result.run.replayed and result.run.flows_confirmed,
                  "message": result.run.detail}
    found = falsifier.result()
    summary = {"verdict": found.verdict, "examples": found.examples, "seconds": round(found.seconds, 3),
               "violated": found.run.violated if found.run else None, "check": found.check,
               "note": found.note, **({"skipped": found.skipped} if found.skipped else {})}
    kernel = _kernel_check(theorem)
    opinion = None
    if opts.cross_check:
        from certiloop.proofs.engine.second_opinion import second_opinion

        check = second_opinion(result.obligations + (result.nonblocking or []))
        opinion = {**check.to_json(), "summary": check.summary}
    data = result.to_json()
    return GateEntry(theorem.name, theorem.expected, result.verdict, time.perf_counter() - start,
                     data["obligations"], result.reason, data["counterexample"], replay, summary, kernel,
                     data.get("nonblocking"), opinion, result.inconsistent, vacuous=result.vacuous,
                     checked=checked.message if checked else None,
                     certificate=checked.certificate if checked and checked.accepted else None)


def _check_proof(result):
    """Nothing is `proved` in the gate unless the proof checker accepted its certificate (checked
    here, while this model's falsifier runs on a worker): a rejected proof is `unknown`, with the
    checker's reason."""
    if result.verdict != "proved":
        return None
    from certiloop.proofs.engine.checked import check_proof, rejected_reason

    checked = check_proof(result.proof, result.obligations)
    if not checked.accepted:
        result.verdict, result.reason = "unknown", rejected_reason(checked.message)
    return checked


def _certificate_key(cache, key: str) -> str:
    return cache.key("certificate", key)


def _certificate_kept(cache, key: str, hit: dict) -> bool:
    """A cached proved entry counts only with the certificate the checker accepted beside it."""
    return hit.get("verdict") != "proved" or not hit.get("checked") or \
        cache.get(_certificate_key(cache, key), counted=False) is not None


def _unsupported(model: str, reason: str, expected: str = "proved") -> GateEntry:
    """A model certiloop cannot read or handle: it fails the gate, with the reason."""
    return GateEntry(model, expected, "not supported", 0.0, [], reason)


def run_gate(theorems: list, start_prover: Callable[[], Prover], rlimit: int,
             opts: GateOptions, cache=None, on_model=None, on_start=None,
             into: list[GateEntry] | None = None) -> list[GateEntry]:
    """Gate each theorem in order (an `Unsupported` archive entry fails with its reason); each
    entry is appended to `into` as soon as it is done (so an interrupted gate still has the
    finished ones to report). `start_prover` is called
    only if some model is not in the cache (a warm gate never loads z3 or sympy); `rlimit`
    is its budget, part of each cache key."""
    entries = [] if into is None else into
    setting = f"{opts.text()}/rlimit={rlimit}"
    keys = [cache.key("gate", f"{t.canonical}\n{setting}") if cache and isinstance(t, Theorem) else None
            for t in theorems]
    hits = [cache.get(key) if key else None for key in keys]
    hits = [hit if hit is None or _certificate_kept(cache, key, hit) else None
            for key, hit in zip(keys, hits)]
    todo = [i for i, (t, hit) in enumerate(zip(theorems, hits)) if hit is None and isinstance(t, Theorem)]
    if todo:
        _import_for_workers()
    prover = start_prover() if todo else None
    # the next models' falsifiers are queued before this model's obligations, so the workers
    # always have one to run while the proof waits on its last obligations
    falsifiers = {i: prover.submit(falsify_task, theorems[i], opts) for i in todo[:AHEAD]}
    for i, (theorem, key, hit) in enumerate(zip(theorems, keys, hits)):
        if on_start:
            on_start(theorem.name)
        if isinstance(theorem, Unsupported):
            entry = _unsupported(theorem.name, theorem.reason)
        elif hit is not None:
            entry = GateEntry.from_json(hit)
            entry.kernel = _kernel_check(theorem)  # the shipped file may have changed: never cached
        else:
            for j in todo[todo.index(i) + 1:todo.index(i) + 1 + AHEAD]:
                if j not in falsifiers:
                    falsifiers[j] = prover.submit(falsify_task, theorems[j], opts)
            try:
                entry = check_model(theorem, prover, opts, falsifiers.pop(i))
            except ModelError as exc:  # a rule the engine lacks: this model's row, the others run
                entry = _unsupported(theorem.name, str(exc), theorem.expected)
            except Exception as exc:  # a certiloop bug in this model: its failing row, the others run
                if os.environ.get("CERTILOOP_DEBUG"):
                    raise
                entry = _unsupported(theorem.name, f"internal error: {type(exc).__name__}: {exc} "
                                     "(set CERTILOOP_DEBUG=1 for the traceback)", theorem.expected)
            if cache and entry.verdict not in ("unknown", "not supported"):  # a budget may be raised
                if entry.certificate is not None:  # the certificate the checker accepted, beside the verdict
                    cache.put(_certificate_key(cache, key), entry.certificate)
                cache.put(key, entry.to_json())
        if cache and entry.verdict == "proved":  # lets `certiloop extract` skip the proof
            cache.put(cache.key("proof", theorem.canonical), {"model": theorem.name, "verdict": "proved"})
        entries.append(entry)
        if on_model:
            on_model(entry)
    return entries


# What the gate's workers import lazily (the falsifier, its search and replay, scipy's root
# finder): imported here once, before the workers are forked, they inherit it rather than
# each import a copy (22-model gate: 66 -> 62 s CPU, 37 -> 35 s wall)
WORKER_MODULES = ("certiloop.falsify.search", "certiloop.falsify.batch.phase", "certiloop.falsify.replay",
                  "certiloop.proofs.refute", "certiloop.proofs.refute.witness", "hypothesis",
                  "hypothesis.strategies", "hypothesis.database", "scipy.optimize", "scipy.integrate")


def _import_for_workers() -> None:
    for name in WORKER_MODULES:
        importlib.import_module(name)


def _kernel_check(theorem: Theorem) -> str | None:
    from certiloop.kernel.extract import shipped, shipped_drift

    return shipped_drift(theorem.name) if theorem.name in shipped() else None
