"""A second opinion: re-check an obligation z3 proved with cvc5, on our own SMT-LIB text.

cvc5 reads the script `smtlib.script(formula)` (the negation of the obligation) through its
own SMT-LIB parser, so the check shares neither z3's solver nor z3's translation/printer.
The budget is cvc5's deterministic resource limit (`rlimit-per`, counted in solver steps),
not a wall-clock limit: the same formula and budget give the same answer on any machine and
under any load. The one exception is a safety net (each cvc5 run is a child process, killed
after SAFETY_NET_S seconds) for the rare formula on which cvc5 stalls inside a step its
resource count does not cover; such a check is "unknown" and its detail says why.
"""

from __future__ import annotations

import multiprocessing
import time
from dataclasses import dataclass
from fractions import Fraction

from certiloop.models.lang.terms import Node
from certiloop.proofs.arith.smtlib import original_name, printed, readable

# cvc5 resource units per stage (steps: rewrites, SAT decisions, theory checks ...). On the
# library every obligation cvc5 confirms takes under 130,000 units in its stage; see the
# measurements in the cross-check report.
DEFAULT_RLIMIT = 200_000

# Only a guard against a hung solver, never the budget: cvc5 does not count resources inside
# one step of its cylindrical-covering procedure (nl-cov), and a few formulas spend minutes
# there with fewer than 20,000 units used. A check cut off by this net says so.
SAFETY_NET_S = 5.0

MISSING = "--cross-check needs cvc5: pip install 'certiloop[crosscheck]'"


@dataclass
class CrossCheck:
    status: str  # "confirmed" (cvc5: unsat, the obligation is valid) | "disagrees" (sat) | "unknown"
    detail: str  # the model (disagrees), cvc5's reason (unknown), logic and stage (confirmed)
    seconds: float
    resources: int = 0  # cvc5 resource units spent, all stages (deterministic, unlike seconds)


def _stages(logic: str) -> list[tuple[str, dict[str, str]]]:
    """cvc5 configurations tried in turn; the next one only when the previous one answers
    `unknown (INCOMPLETE)` (a deterministic outcome), never after a spent budget.

    Nonlinear real arithmetic: first the cylindrical-covering procedure alone (nl-ext=none):
    complete and quick, and it almost never stalls; when it reports INCOMPLETE, cvc5's
    default (incremental linearisation lemmas + coverings)."""
    base = {"produce-models": "true"}
    # Quantifiers: cvc5's defaults. enum-inst (enumerative instantiation) confirmed nothing
    # more on the library and only spent the budget on obligations that are false.
    if logic.endswith(("NRA", "NIRA")):
        return [("coverings", {**base, "nl-ext": "none"}), ("linearisation+coverings", base)]
    return [("default", base)]


def cross_check(formula: Node, rlimit: int = DEFAULT_RLIMIT, *, wall_s: float | None = SAFETY_NET_S,
                options: dict[str, str] | None = None) -> CrossCheck:
    """Ask cvc5 whether `formula` is valid: unsat of its negation -> "confirmed", a model ->
    "disagrees" (a soundness alarm if z3 proved it), anything else -> "unknown".

    rlimit: cvc5 resource units per stage (`rlimit-per`), the budget; 0 means unlimited.
    wall_s: a safety net against a hung cvc5, not a budget: each stage runs in a child
        process, killed after wall_s seconds (the answer is then "unknown" and says so);
        None runs cvc5 in this process with no net.
    options: extra cvc5 options (name -> value) for every stage."""
    try:
        import cvc5  # noqa: F401
    except ImportError:
        raise ImportError(MISSING) from None

    start = time.perf_counter()
    script = printed(formula)
    spent = 0
    for stage, opts in _stages(script.logic):
        opts = {**opts, **(options or {})}
        if rlimit:
            opts["rlimit-per"] = str(int(rlimit))
        if wall_s is None:
            status, detail, used = _solve(script.text, opts)
        else:
            status, detail, used = _isolated(script.text, opts, wall_s)
        spent += used
        where = f"{script.logic}, {stage}"
        if status == "unsat":
            return CrossCheck("confirmed", f"cvc5: unsat ({where})", time.perf_counter() - start, spent)
        if status == "sat":
            return CrossCheck("disagrees", detail, time.perf_counter() - start, spent)
        if status == "unknown" and detail == "INCOMPLETE":
            continue
        if status == "unknown":
            if detail == "RESOURCEOUT":
                detail = f"RESOURCEOUT: resource budget of {int(rlimit):,} units spent"
            detail = f"cvc5 gave up: {detail}"
        # else a cvc5 error, or the safety net: the detail says which
        return CrossCheck("unknown", f"{detail} ({where})", time.perf_counter() - start, spent)
    return CrossCheck("unknown", f"cvc5 gave up: INCOMPLETE ({script.logic}, every stage)",
                      time.perf_counter() - start, spent)


def _solve(text: str, opts: dict[str, str]) -> tuple[str, str, int]:
    """One cvc5 run on an SMT-LIB script, in a fresh term manager and solver:
    (unsat|sat|unknown|error, model text or reason, resource units)."""
    import cvc5

    tm = cvc5.TermManager()
    solver = cvc5.Solver(tm)
    symbols = cvc5.SymbolManager(tm)
    try:
        for name, value in opts.items():
            solver.setOption(name, value)
        parser = cvc5.InputParser(solver, symbols)
        parser.setStringInput(cvc5.InputLanguage.SMT_LIB_2_6, text, "certiloop")
        while True:
            command = parser.nextCommand()
            if command.isNull():
                break
            if command.getCommandName() == "check-sat":
                continue  # we call checkSat ourselves to get a Result object
            command.invoke(solver, symbols)
        result = solver.checkSat()
    except RuntimeError as exc:  # cvc5 reports parse and solver errors as RuntimeError
        return "error", f"cvc5 error: {exc}", 0
    used = _resources(solver)
    if result.isUnsat():
        return "unsat", "", used
    if result.isSat():
        return "sat", _model(solver, symbols), used
    return "unknown", str(result.getUnknownExplanation()).split(".")[-1], used


def _child(conn, text: str, opts: dict[str, str]) -> None:
    try:
        conn.send(_solve(text, opts))
    except BaseException as exc:  # noqa: BLE001 - report anything to the parent
        conn.send(("error", f"cvc5 run failed: {type(exc).__name__}: {exc}", 0))
    finally:
        conn.close()


def _isolated(text: str, opts: dict[str, str], wall_s: float) -> tuple[str, str, int]:
    """_solve in a child process (a crash or a hang in cvc5 cannot take certiloop down)."""
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, text, opts))
    proc.start()
    send.close()
    try:
        if recv.poll(wall_s):
            return recv.recv()
        return ("safety-net", f"wall-clock safety net of {wall_s:g} s reached (cvc5 stalled inside "
                "one step its resource count does not cover; machine-dependent, not a verdict)", 0)
    except EOFError:
        proc.join(5)
        return "error", f"cvc5 ended without an answer (exit code {proc.exitcode})", 0
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join()
        recv.close()


def _resources(solver) -> int:
    try:
        stat = solver.getStatistics().get(True, False).get("resource::resourceUnitsUsed")
        return int(stat["value"]) if stat else 0
    except Exception:  # statistics are a report, never a verdict
        return 0


def _model(solver, symbols) -> str:
    lines = []
    for term in symbols.getDeclaredTerms():
        name = original_name(term.getSymbol())
        try:
            value = _value(solver.getValue(term))
        except RuntimeError as exc:
            value = f"? ({exc})"
        lines.append(f"{name} = {value}")
    return "\n".join(sorted(lines))


def _value(v) -> str:
    if v.isBooleanValue():
        return "true" if v.getBooleanValue() else "false"
    if v.isIntegerValue():
        return str(v.getIntegerValue())
    if v.isRealValue():
        f = Fraction(v.getRealValue())
        return str(f)
    if v.isRealAlgebraicNumber():
        lo = Fraction(v.getRealAlgebraicNumberLowerBound().getRealValue())
        hi = Fraction(v.getRealAlgebraicNumberUpperBound().getRealValue())
        return f"the root in ({lo}, {hi}) (~{float((lo + hi) / 2):.6g}) of {_poly(v)}"
    return readable(str(v))


def _poly(v) -> str:
    text = str(v)  # (_ real_algebraic_number <1*x^2 + (-2), (5/4, 3/2)>)
    start, end = text.find("<"), text.find(",")
    return text[start + 1:end] if 0 <= start < end else text
