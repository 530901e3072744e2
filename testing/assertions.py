"""assert_proved / assert_refuted: a theorem's verdict as a pytest assertion.

Only the prover decides: `proved` needs every obligation proved, `refuted` a violating run
that was re-checked exactly, replayed and had its flows confirmed. `unknown` fails both
assertions. With `falsify=N` the falsifier also runs N examples and must agree (no run for
a proved model, a run for a refuted one), as `certiloop gate` checks.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

if TYPE_CHECKING:  # the prover is imported only when an assertion runs
    from certiloop.falsify.search import Falsification
    from certiloop.models.lang.theorem import Theorem
    from certiloop.proofs.core.verdicts import RunEvidence
    from certiloop.proofs.engine.prover import TheoremResult

__tracebackhide__ = True  # pytest shows the assertion's message, not our frames


@dataclass
class Counterexample:
    """What `assert_refuted` returns: the prover's confirmed violating run.

    initial: the start state, readable (`{"v": "0.5"}`); values: the same, exact (Fraction,
    ...); steps: the statements of the run (`.path`, `.what`, `.state`); violated: the
    guarantee part that is false at the end; result: the whole `TheoremResult`;
    falsification: the falsifier's own run, when `falsify=N` was asked for.
    """

    result: TheoremResult
    falsification: Falsification | None = None

    @property
    def initial(self) -> dict[str, str]:
        return self.result.refutation.initial

    @property
    def values(self) -> dict[str, Any]:
        return self.result.refutation.raw_initial

    @property
    def steps(self) -> list:
        return self.result.refutation.shown

    @property
    def violated(self) -> str:
        return self.result.refutation.violated

    @property
    def evidence(self) -> RunEvidence:
        return self.result.run

    def __str__(self) -> str:
        from certiloop.proofs.engine.display import run_lines

        data = self.result.to_json()
        return f"{data['model']}:\n" + "\n".join(run_lines(data["counterexample"], data["run_check"]))

    def _repr_html_(self) -> str:
        from certiloop.proofs.engine.display import result_html

        return result_html(self.result.to_json())


class VerdictUnknown(AssertionError):
    """The theorem is neither proved nor refuted (the pytest plugin reports a work-in-progress
    model's as xfail); `result` is its TheoremResult."""

    def __init__(self, message: str, result: TheoremResult) -> None:
        super().__init__(message)
        self.result = result


def _failed(result: TheoremResult, wanted: str) -> AssertionError:
    message = _message(result, wanted)
    return VerdictUnknown(message, result) if result.verdict == "unknown" else AssertionError(message)


def prove(theorem: Theorem | Callable[[], Theorem], *, rlimit: int | None = None,
          timeout: float | None = None, jobs: int | None = 1) -> TheoremResult:
    """Prove `theorem` (or a zero-argument function returning one) and return the result.

    rlimit: z3 resource units per obligation form (default 2,000,000, as the CLI); timeout:
    the per-call safety net in seconds (default 60); jobs: worker processes (default 1, so a
    test suite run in parallel by pytest-xdist does not oversubscribe the machine; None: one
    per core)."""
    from certiloop.proofs.engine.budget import Budget
    from certiloop.proofs.engine.deepstack import call_with_deep_stack
    from certiloop.proofs.engine.prover import Prover

    theorem = _theorem(theorem)
    budget = Budget(**{k: v for k, v in (("rlimit", rlimit), ("wall_s", timeout)) if v is not None})

    def run() -> TheoremResult:
        with Prover(jobs=jobs, budget=budget) as prover:
            return prover.prove(theorem)

    return call_with_deep_stack(run)  # a deeply nested model: no recursion limit, as in the CLI


def assert_proved(theorem: Theorem | Callable[[], Theorem], *, rlimit: int | None = None,
                  timeout: float | None = None, jobs: int | None = 1, falsify: int = 0) -> TheoremResult:
    """Fail unless the theorem is proved; return the `TheoremResult`.

    The message names the model and its verdict, lists the first obligations not proved
    (path, reason, counterexample) and shows the violating run if one was found. falsify=N
    also runs the falsifier for N examples and fails if it finds a violating run, or cannot
    start a single run (assumptions no state meets make the proof vacuous)."""
    theorem = _theorem(theorem)
    result = prove(theorem, rlimit=rlimit, timeout=timeout, jobs=jobs)
    if result.verdict != "proved":
        raise _failed(result, "proved")
    if falsify:
        found = _falsify(theorem, falsify, shrink=True)  # a bug report: make the run short
        if found.found:
            raise AssertionError(f"{result.model} is proved, yet the falsifier found a violating run "
                                 f"(a certiloop bug; please report it):\n{_falsification_text(found)}")
        if found.note:  # as the gate: a proof about no runs at all is vacuous
            raise AssertionError(f"{result.model} is proved, but the falsifier could not start a single "
                                 f"run: {found.note}")
    return result


def assert_refuted(theorem: Theorem | Callable[[], Theorem], *, rlimit: int | None = None,
                   timeout: float | None = None, jobs: int | None = 1, falsify: int = 0) -> Counterexample:
    """Fail unless the theorem is refuted by a confirmed violating run; return that run as
    a `Counterexample` for further assertions. A proved or `unknown` theorem fails, with the
    reason. falsify=N also runs the falsifier for N examples and fails if it finds no run."""
    theorem = _theorem(theorem)
    result = prove(theorem, rlimit=rlimit, timeout=timeout, jobs=jobs)
    if result.verdict != "refuted":
        raise _failed(result, "refuted")
    found = None
    if falsify:
        found = _falsify(theorem, falsify, shrink=False)  # a confirmation: the first run will do
        if not found.found:
            note = f": {found.note}" if found.note else ""
            raise AssertionError(f"{result.model} is refuted by the prover, but the falsifier found no "
                                 f"violating run in {found.examples} examples{note}")
    return Counterexample(result, found)


def _message(result: TheoremResult, wanted: str) -> str:
    from certiloop.proofs.engine.display import result_text

    why = {
        ("proved", "refuted"): "a confirmed run violates the guarantee",
        ("proved", "unknown"): "neither proved nor refuted (unknown never passes)",
        ("refuted", "proved"): "every obligation is proved, so no run violates the guarantee",
        ("refuted", "unknown"): "no confirmed violating run (unknown never passes)",
    }[(wanted, result.verdict)]
    return f"{result.model} is {result.verdict}, not {wanted}: {why}\n{result_text(result.to_json())}"


def _theorem(theorem: Theorem | Callable[[], Theorem]) -> Theorem:
    from certiloop.models.lang.theorem import Theorem

    built = theorem if isinstance(theorem, Theorem) else theorem() if callable(theorem) else None
    if not isinstance(built, Theorem):
        raise TypeError(f"expected a Theorem or a function returning one, got {theorem!r}")
    return built


def _falsify(theorem: Theorem, examples: int, shrink: bool) -> Falsification:
    from certiloop.falsify.search import Options, falsify
    from certiloop.proofs.engine.deepstack import call_with_deep_stack

    options = Options(max_examples=examples, seed=0, database=None, shrink=shrink)
    return call_with_deep_stack(lambda: falsify(theorem, options))


def _falsification_text(found: Falsification) -> str:
    import io

    from rich.console import Console

    from certiloop.falsify.report import show_falsification

    out = io.StringIO()
    show_falsification(Console(file=out, width=120, color_system=None, highlight=False), found)
    return out.getvalue().rstrip()
