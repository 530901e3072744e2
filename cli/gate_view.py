"""The gate's table on a terminal or in a log: every column when they fit, else the five that
matter (model, verdict, obligations, seconds, gate) with the rest on a line per failed model,
else one line per model. Model names and verdicts are never cut."""

from __future__ import annotations

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from certiloop.api.gate_run import GateEntry
from certiloop.cli import ui
from certiloop.cli.proof_table import hint, label, verdict_text


def show_gate(out: Console, entries: list[GateEntry], cross_check: bool, level: int, tail: str) -> None:
    """The table (not with --quiet), a FAIL line per failed model with its details, and the
    summary line `N passed, M failed` + tail."""
    failed = [e for e in entries if not e.passed]
    folded = False
    if level > ui.QUIET and entries:
        full = _full_table(out, entries, cross_check)
        if ui.fits(out, full):
            out.print(full)
        else:
            folded = True
            compact = _compact_table(out, entries)
            if ui.fits(out, compact):
                out.print(compact)
            else:
                for e in entries:
                    ui.say(out, f"{_gate_word(e)} {e.model}  {e.verdict}  {_proved(e)}  {_seconds(e)}")
    for e in entries:
        if not e.passed:
            ui.say(out, f"FAIL {e.model}: {e.message}")
        if (folded and not e.passed) or level == ui.VERBOSE:
            ui.say(out, f"  {e.model}: " + "; ".join(_details(e, cross_check)), indent="    ")
        if level == ui.VERBOSE or not e.passed:
            _show_failed_obligations(out, e, limit=None if level == ui.VERBOSE else 3)
    ui.say(out, f"{len(entries) - len(failed)} passed, {len(failed)} failed{tail}")


def _full_table(out: Console, entries: list[GateEntry], cross_check: bool) -> Table:
    table = ui.table(out, title="certiloop gate")
    columns = ("model", "expected", "verdict", "obligations", "checker", "step runs", "falsifier", "replay",
               "kernel", *(("cvc5",) if cross_check else ()), "s", "gate")
    for col in columns:
        table.add_column(col, no_wrap=True)
    for e in entries:
        checks = _checks(e)
        table.add_row(escape(e.model), e.expected, verdict_text(e.verdict), _proved(e), checks["checker"],
                      checks["step runs"],
                      checks["falsifier"], checks["replay"], checks["kernel"],
                      *((checks["cvc5"],) if cross_check else ()), _seconds(e), _gate_text(e))
    return table


def _compact_table(out: Console, entries: list[GateEntry]) -> Table:
    table = ui.table(out, title="certiloop gate")
    for col in ("model", "verdict", "proved", "s", "gate"):
        table.add_column(col, no_wrap=True, justify="right" if col == "s" else "left")
    for e in entries:
        table.add_row(escape(e.model), verdict_text(e.verdict), _proved(e), _seconds(e, short=True),
                      _gate_text(e))
    return table


def _checks(e: GateEntry) -> dict[str, str]:
    cvc5 = "-"
    if e.cross_check:
        cvc5 = f"{e.cross_check['confirmed']}/{e.cross_check['checked']}" + (
            " DISAGREES" if e.cross_check["disagreements"] else "")
    return {
        "checker": "-" if e.checked is None else "accepted" if e.checked.startswith("accepted")
        else "REJECTED",
        "step runs": "-" if e.nonblocking is None else e.nonblocking["verdict"],
        "falsifier": e.falsify.get("verdict", "-"),
        "replay": "-" if e.replay is None else ("violates" if e.replay["violated"] else "FAILS"),
        "kernel": "-" if e.kernel is None else ("matches" if not e.kernel else "DRIFTED"),
        "cvc5": cvc5,
    }


def _details(e: GateEntry, cross_check: bool) -> list[str]:
    """The columns the folded table leaves out, as `name: value` pairs."""
    shown = [f"expected: {e.expected}", f"obligations proved: {_proved(e)}"]
    for name, value in _checks(e).items():
        if value != "-" and (name != "cvc5" or cross_check):
            shown.append(f"{name}: {value}")
    return shown


def _show_failed_obligations(out: Console, e: GateEntry, limit: int | None) -> None:
    if e.expected != "proved":
        return  # an unsafe design's failed branches are the point, not news
    failed = [o for o in e.obligations if o["verdict"] != "proved"]
    for o in failed[:limit]:
        rule = o.get("rule", "")
        why = f" — {o['reason']}" if o.get("reason") else ""
        ui.say(out, f"    {o['id']} {o['path']}: {label(o['verdict'], rule)}{why}", indent="    ")
        if e.verdict != "refuted" and hint(o["verdict"], rule):
            ui.say(out, f"      hint: {hint(o['verdict'], rule)}", indent="  ")
    if limit is not None and len(failed) > limit:
        ui.say(out, f"    ... and {len(failed) - limit} more not proved (--verbose shows them)")


def _proved(e: GateEntry) -> str:
    return f"{sum(o['verdict'] == 'proved' for o in e.obligations)}/{len(e.obligations)}"


def _seconds(e: GateEntry, short: bool = False) -> str:
    if e.cached:
        return "cached" if short else f"{e.seconds:.2f} (cached)"
    return f"{e.seconds:.2f}"


def _gate_word(e: GateEntry) -> str:
    return "PASS" if e.passed else "FAIL"


def _gate_text(e: GateEntry) -> str:
    return "[green]PASS[/]" if e.passed else "[bold red]FAIL[/]"
