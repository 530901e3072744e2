"""The performance page, generated from the benchmark records in benchmarks/results/*.json.

Each record holds the machine, the date and one row per measurement; this page shows the latest
record of each benchmark, one table per record, and each row with the command that measures it
again. Records that compare two installs side by side (`old_*` / `new_*` columns) are history,
not today's numbers, and are left out; so are columns not listed here.
"""

from __future__ import annotations

import json
from pathlib import Path

RESULTS = Path(__file__).resolve().parent.parent / "benchmarks" / "results"


def _kyx_rows(record: dict) -> list[dict]:
    return [
        {
            "archive": name,
            **{k: v for k, v in t.items() if k != "wrong"},
            "wrong": len(t["wrong"]),
            "side": "--invalid " if t["refuted"] == t["entries"] else "",
        }  # archives of false claims
        for name, t in record["totals"].items()
    ]


# file -> (title, what it measures, columns, command (formatted with the row), rows from the record)
TABLES = {
    "prove.json": (
        "Proof time per model",
        "`certiloop prove MODEL`, wall time, CLI start-up included",
        ["model", "verdict", "obligations", "median_s", "min_s", "max_s", "runs"],
        "python benchmarks/bench_prove.py {model}",
        None,
    ),
    "falsify.json": (
        "Falsifier: finding a violating run",
        "runs found / seeds, median examples and time",
        ["model", "found", "median_examples", "median_s"],
        "python benchmarks/bench_falsify.py --only {model}",
        None,
    ),
    "interpreter.json": (
        "Interpreter throughput",
        "control steps per second of the model interpreter",
        ["model", "control_steps", "steps_per_s"],
        "python benchmarks/bench_falsify.py",
        None,
    ),
    "kyx.json": (
        "KeYmaera X archives: basic and counterexample",
        "every entry through `certiloop prove 'FILE:\"Entry\"'` (entries false by construction "
        "through `certiloop falsify` too); `wrong` counts verdicts that contradict the archive. "
        "The archives are those of LS-Lab/KeYmaeraX-projects, `benchmarks/` (not copied here)",
        ["archive", "entries", "proved", "refuted", "unknown", "not supported", "wrong", "median_s", "max_s"],
        "python benchmarks/bench_kyx.py {side}{archive}",
        _kyx_rows,
    ),
    "kyx_more.json": (
        "KeYmaera X archives: essential, advanced, nonlinear",
        "as above",
        ["archive", "entries", "proved", "refuted", "unknown", "not supported", "wrong", "median_s", "max_s"],
        "python benchmarks/bench_kyx.py {archive} --record kyx_more",
        _kyx_rows,
    ),
    "kernel.json": (
        "Runtime kernel step (sbs.ctrl2)",
        "one `VirtualFixture.step`, median microseconds",
        ["boundaries", "backend", "step_median_us", "numpy_step_median_us"],
        "python benchmarks/bench_kernel.py",
        None,
    ),
    "kernel_c.json": (
        "C kernel (sbs.ctrl2)",
        "the extracted C controller, median microseconds per call",
        ["boundaries", "step_median_us", "controller_median_us"],
        "python benchmarks/bench_kernel_c.py",
        None,
    ),
    "monitors.json": (
        "Generated monitors",
        "median microseconds per call",
        ["monitor", "median_us"],
        "python benchmarks/bench_monitors.py",
        None,
    ),
    "campaign.json": (
        "Fault-injection campaigns",
        "simulated runs per second and the safety loop's tick",
        ["measure", "runs", "seconds", "value", "unit"],
        "python benchmarks/bench_campaign.py",
        None,
    ),
    "rcm.json": (
        "RCM admittance kernel",
        "step latency against its target",
        ["case", "median_ms", "p99_ms", "target_ms"],
        "python benchmarks/bench_rcm.py --no-prove",
        None,
    ),
    "rcm_push.json": (
        "RCM: the human-force search",
        "`certiloop falsify rcm.push_*`",
        ["measure", "profiles", "seconds", "value"],
        "certiloop falsify {measure}",
        None,
    ),
    "cfmpa.json": (
        "Dual-arm planner: builtDR and the two swept regions",
        "free cells and solved queries per scene",
        ["scene", "dt", "cells", "free_orig", "free_mod", "ok_orig", "ok_mod"],
        "python benchmarks/bench_cfmpa.py --scene {scene} --dt {dt}",
        None,
    ),
    "cfmpa_soundness.json": (
        "Dual-arm planner: collisions at sampled instants",
        "0 expected for the paper's regions; the mutants must collide",
        ["scene", "dt", "variant", "samples", "collisions"],
        "python benchmarks/bench_cfmpa.py --soundness --scene {scene} --dt {dt}",
        None,
    ),
    "cfmpa_ompl.json": (
        "Dual-arm planner beside OMPL",
        "",
        ["scene", "dt", "planner", "success", "planning_s", "waypoints"],
        "python benchmarks/bench_cfmpa.py --ompl --scene {scene} --dt {dt}",
        None,
    ),
    "fmt.json": (
        "Certified FMT* (raven.frs_box)",
        "success rate and planning time beside the paper's Table 2",
        ["n", "runs", "success", "paper_success", "median_planning_s", "paper_planning_s", "median_check_s"],
        "python benchmarks/bench_fmt.py --samples {n}",
        None,
    ),
}


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, list):
        return ", ".join(_cell(v) for v in value)
    return str(value).replace("|", "\\|")


def page(results: Path = RESULTS) -> str:
    out = [
        "# Performance",
        "",
        "Generated from the benchmark records in `benchmarks/results/*.json` when the docs are built. "
        "Each table is the latest record of one benchmark, with the machine and date it was measured on; "
        "each row ends with the command that measures it again (from a clone, after "
        "`pip install '.[test]'`). Verdicts never depend on these times: budgets are deterministic.",
        "",
    ]
    for name, (title, what, columns, command, rows_of) in TABLES.items():
        path = results / name
        if not path.is_file():
            continue
        record = json.loads(path.read_text())
        rows = rows_of(record) if rows_of else record["rows"]
        out += [
            f"## {title}",
            "",
            f"{what}. Measured {record.get('date', '?')} on {record.get('machine', '?')}"
            f"{', ' + str(record['cores']) + ' cores' if record.get('cores') else ''}"
            f" (`benchmarks/results/{name}`).",
            "",
        ]
        out.append("| " + " | ".join(columns) + " | command |")
        out.append("|" + "---|" * (len(columns) + 1))
        for row in rows:
            cells = [_cell(row.get(c, "")) for c in columns]
            out.append("| " + " | ".join(cells) + f" | `{command.format(**row)}` |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    print(page())
