"""Gate reports for CI: JUnit XML (one test case per model and per obligation) and a
Markdown summary for a CI job's summary page."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from certiloop.api.gate_run import GateEntry
from certiloop.cli.proof_table import hint, label


def junit(entries: list[GateEntry], selected: int | None = None) -> str:
    """selected: how many models the gate was to check; fewer entries mean it was interrupted,
    which shows as a failing test case so CI cannot mistake the report for a whole one."""
    suites = ET.Element("testsuites", name="certiloop gate")
    for e in entries:
        cases = [_model_case(e)] + [_obligation_case(e, o) for o in e.obligations]
        suite = ET.SubElement(suites, "testsuite", name=e.model, tests=str(len(cases)),
                              failures=str(sum(c.find("failure") is not None for c in cases)),
                              time=f"{e.seconds:.3f}")
        suite.extend(cases)
    if selected is not None and len(entries) < selected:
        suites.set("partial", "true")
        suite = ET.SubElement(suites, "testsuite", name="certiloop gate (interrupted)", tests="1",
                              failures="1")
        case = ET.SubElement(suite, "testcase", classname="certiloop", name="gate finished")
        ET.SubElement(case, "failure", message=_interrupted(entries, selected))
    ET.indent(suites)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n"


def _model_case(e: GateEntry) -> ET.Element:
    case = ET.Element("testcase", classname=e.model, name=f"{e.model} is {e.expected}",
                      time=f"{e.seconds:.3f}")
    if not e.passed:
        failure = ET.SubElement(case, "failure", message=e.message)
        failure.text = _counterexample_text(e)
    else:
        ET.SubElement(case, "system-out").text = f"verdict {e.verdict}; falsify: {e.falsify.get('verdict')}"
    return case


def _obligation_case(e: GateEntry, o: dict) -> ET.Element:
    case = ET.Element("testcase", classname=e.model, name=f"{o['id']} {o['path']}",
                      time=f"{o['seconds']:.3f}")
    if o["verdict"] != "proved":
        if e.expected == "proved":
            rule = o.get("rule", "")
            why = "; ".join(x for x in (o.get("reason", ""), hint(o["verdict"], rule)) if x)
            failure = ET.SubElement(case, "failure", message=f"{label(o['verdict'], rule)}: {why}")
            if o.get("counterexample"):
                failure.text = ", ".join(f"{k} = {v}" for k, v in o["counterexample"].items())
        else:  # the design is expected to be unsafe: a failed branch is the point
            ET.SubElement(case, "skipped", message=f"{o['verdict']} (the model is expected to be refuted)")
    return case


def _counterexample_text(e: GateEntry) -> str:
    lines = [e.message]
    if e.counterexample:
        start = e.counterexample["initial"]
        lines.append("initial state: " + ", ".join(f"{k} = {v}" for k, v in start.items()))
        lines.append(f"violated: {e.counterexample['violated']}")
    return "\n".join(lines)


def _interrupted(entries: list[GateEntry], selected: int) -> str:
    return f"interrupted: a partial report of the {len(entries)} of {selected} models finished"


def markdown(entries: list[GateEntry], selected: int | None = None) -> str:
    passed = sum(e.passed for e in entries)
    partial = selected is not None and len(entries) < selected
    mark = "✅" if passed == len(entries) and not partial else "❌"
    out = [f"## certiloop gate: {mark} {passed}/{len(entries)} models met their expected verdict", "",
           *([f"**{_interrupted(entries, selected)}**", ""] if partial else []),
           "| model | expected | verdict | obligations proved | falsifier | replay | kernel | s | gate |",
           "|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        proved = sum(o["verdict"] == "proved" for o in e.obligations)
        replay = "—" if e.replay is None else ("violates" if e.replay["violated"] else "**fails**")
        kernel = "—" if e.kernel is None else ("matches" if not e.kernel else "**drifted**")
        falsify = e.falsify.get("verdict", "—")
        seconds = f"{e.seconds:.2f}{' (cached)' if e.cached else ''}"
        out.append(f"| `{e.model}` | {e.expected} | {e.verdict} | {proved}/{len(e.obligations)} | "
                   f"{falsify} | {replay} | {kernel} | {seconds} | {'pass' if e.passed else '**FAIL**'} |")
    failures = [e for e in entries if not e.passed]
    if failures:
        out += ["", "### Failures", ""]
        for e in failures:
            out.append(f"* `{e.model}`: {e.message}")
            if e.counterexample:
                out.append(f"  * counterexample: {e.counterexample['violated']}")
    return "\n".join(out) + "\n"
