"""Plain-text and HTML renderings of a proof result, for assertion messages
(`certiloop.testing`) and notebooks (`TheoremResult._repr_html_`).

Both read only the result's documented JSON (`TheoremResult.to_json()`, the same as
`certiloop prove --json`), so they show exactly what the CLI reports.
"""

from __future__ import annotations

from html import escape
from typing import Any

SHOWN_OBLIGATIONS = 3  # failing obligations listed before "... and N more"


def failing_obligations(data: dict[str, Any]) -> list[dict[str, Any]]:
    return [o for o in data["obligations"] if o["verdict"] != "proved"]


def headline(data: dict[str, Any]) -> str:
    obligations = data["obligations"]
    proved = sum(o["verdict"] == "proved" for o in obligations)
    return (f"{data['model']}: {data['verdict']} ({proved}/{len(obligations)} obligations proved; "
            f"expected {data['expected']})")


def obligation_lines(data: dict[str, Any], limit: int = SHOWN_OBLIGATIONS) -> list[str]:
    """The first `limit` obligations not proved: id, path, verdict, reason, counterexample."""
    failing = failing_obligations(data)
    lines = []
    for o in failing[:limit]:
        line = f"{o['id']} {o['path']}: {o['verdict']}"
        lines.append(line + (f" — {o['reason']}" if o["reason"] else ""))
        if o["verdict"] == "refuted" and o.get("counterexample"):
            values = ", ".join(f"{k} = {v}" for k, v in o["counterexample"].items())
            lines.append(f"  obligation counterexample ({o['check']}): {values}")
    if len(failing) > limit:
        lines.append(f"... and {len(failing) - limit} more not proved")
    return lines


def run_lines(counterexample: dict[str, Any], run_check: dict[str, Any] | None = None) -> list[str]:
    """A violating run (`"counterexample"` of the JSON) as the CLI prints it: the initial
    state, each statement with the values it changed, the violated guarantee."""
    what = "state" if counterexample.get("depth") == 0 and not counterexample["trace"] else "run"
    lines = [f"counterexample {what} (checked with {counterexample['check']}):",
             "  start: " + _values(counterexample["initial"])]
    if counterexample.get("frame"):
        frame = counterexample["frame"].items()
        lines.append("  at the start: " + ", ".join(f"{k} is {v}" for k, v in frame))
    before = counterexample["initial"]
    for step in counterexample["trace"]:
        lines.append(f"  {_where(step)}{step['what']}  →  {_values(_changed(before, step))}")
        before = step["state"]
    lines.append(f"  violated: {counterexample['violated']}")
    if run_check and run_check.get("detail"):
        lines.append(f"  independent checks: {run_check['detail']}")
    return lines


def result_text(data: dict[str, Any]) -> str:
    """The whole result as indented plain text (what an assertion message shows)."""
    lines = [headline(data)]
    if failing_obligations(data):
        lines.append("  not proved:")
        lines += ["    " + line for line in obligation_lines(data)]
    if data["reason"]:
        lines.append(f"  {data['reason']}")
    if data["counterexample"]:
        lines += ["  " + line for line in run_lines(data["counterexample"], data["run_check"])]
    return "\n".join(lines)


_COLOUR = {"proved": "#1a7f37", "refuted": "#cf222e", "unknown": "#9a6700"}


def result_html(data: dict[str, Any]) -> str:
    """The result for a notebook: headline with a coloured verdict, the obligations not
    proved, the reason and the violating run (everything escaped)."""
    verdict = data["verdict"]
    head = escape(headline(data)).replace(
        escape(verdict), f'<b style="color:{_COLOUR.get(verdict, "inherit")}">{escape(verdict)}</b>', 1)
    parts = [f"<div class=\"certiloop-result\"><p>{head}</p>"]
    failing = obligation_lines(data, limit=20)
    if failing:
        parts.append("<p>not proved:</p><pre>" + escape("\n".join(failing)) + "</pre>")
    if data["reason"]:
        parts.append(f"<p>{escape(data['reason'])}</p>")
    if data["counterexample"]:
        parts.append("<pre>" + escape("\n".join(run_lines(data["counterexample"], data["run_check"])))
                     + "</pre>")
    return "".join(parts) + "</div>"


def _where(step: dict[str, Any]) -> str:
    return f"[{step['path']}] " if step["path"] else ""


def _values(values: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {v}" for k, v in values.items()) or "no change"


def _changed(before: dict[str, Any], step: dict[str, Any]) -> dict[str, Any]:
    """The values `step` changed from the state `before` it; an assignment of an unchanged
    value still shows its target (a family's cell shows as the whole family)."""
    target = step["what"].split(" := ")[0].split("[")[0] if " := " in step["what"] else None
    return {k: v for k, v in step["state"].items() if before.get(k, v) != v or k == target}
