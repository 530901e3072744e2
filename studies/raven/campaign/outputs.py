"""What `certiloop campaign` writes: the per-run CSV, the JSON summary, the table per fault kind."""

from __future__ import annotations

import csv
import math
from pathlib import Path

from rich.console import Console

from certiloop.cli import ui
from certiloop.studies.raven.campaign.metrics import by_kind
from certiloop.studies.raven.campaign.run import FAULT_KINDS, Setup

CSV_FIELDS = ("run", "seed", "kind", "stream", "start", "duration", "magnitude", "alarmed", "first_alarm",
              "latency", "outcome", "min_distance", "crossed", "peak_deviation")


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "1" if v else "0"
    return repr(v) if isinstance(v, float) else str(v)


def write_campaign_csv(rows: list[dict], path: Path) -> None:
    """One row per run; floats as repr (exact, platform-independent), so the same seed gives
    the same bytes. Golden runs: kind "none", start -1, empty latency."""
    with open(path, "w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(CSV_FIELDS)
        for r in rows:
            writer.writerow([_cell(r[f]) for f in CSV_FIELDS])


def _clean(x):
    """NaN -> None, tuples -> lists: strict JSON."""
    if isinstance(x, float) and math.isnan(x):
        return None
    if isinstance(x, (tuple, list)):
        return [_clean(v) for v in x]
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    return x


def summary(setup: Setup, rows: list[dict], kinds, seed: int, ticks: int) -> dict:
    """The --json document: the scenario, its claim and whether it holds, metrics per kind."""
    crossing = next((r for r in rows if r["crossed"]), None)
    return _clean({"scenario": setup.name, "description": setup.description, "claim": setup.claim,
                   "holds": setup.holds(rows), "seed": seed, "ticks": ticks, "tol": setup.scenario(ticks).tol,
                   "runs": 2 if setup.schedule == "paper" else len(rows), "rows": len(rows),
                   "faults": list(kinds), "by_kind": by_kind(rows), "first_crossing": crossing})


def _rate(x, ci) -> str:
    return "-" if x is None else f"{100 * x:.1f} [{100 * ci[0]:.0f}-{100 * ci[1]:.0f}]"


def _num(x) -> str:
    return "-" if x is None else f"{x:.0f}"


def show_campaign(out: Console, doc: dict, quiet: bool = False, seconds: float = 0.0) -> None:
    if not quiet:
        table = ui.table(out, title=f"{doc['scenario']}: {doc['runs']} runs, seed {doc['seed']}")
        for name in ("fault", "TP/FP/FN/TN", "TPR %", "FPR %", "F1", "latency", "crossed"):
            table.add_column(name, justify="left" if name == "fault" else "right", no_wrap=True)
        for kind, m in doc["by_kind"].items():
            table.add_row(kind, f"{m['TP']}/{m['FP']}/{m['FN']}/{m['TN']}", _rate(m["TPR"], m["TPR_ci"]),
                          _rate(m["FPR"], m["FPR_ci"]), "-" if m["F1"] is None else f"{m['F1']:.2f}",
                          f"{_num(m['latency_median'])}/{_num(m['latency_p95'])}", str(m["crossings"]))
        out.print(table)
        ui.say(out, "rates with Wilson 95% intervals in brackets; latency: median/p95 ticks (1 ms) "
                    "from the fault's start to the first alarm, over the true positives; 'none' = "
                    "runs without a fault")
    crossings = doc["by_kind"]["all"]["crossings"]
    unit = "runs" if doc["rows"] == doc["runs"] else "windows and fault-free stretches"
    ui.say(out, f"{doc['scenario']}: {crossings} of {doc['rows']} {unit} crossed the boundary; claim "
                f"'{doc['claim']}' {'holds' if doc['holds'] else 'FAILS'} ({seconds:.1f} s)")
    r = doc["first_crossing"]
    if r is not None:
        window = f"[{r['start']}, {r['start'] + r['duration']})"
        ui.say(out, f"first crossing: run {r['run']} (run seed {r['seed']}): {r['kind']} on the "
                    f"{r['stream']} stream, ticks {window}, magnitude {r['magnitude']:g}, "
                    f"min distance {1000 * r['min_distance']:.2f} mm; replay it alone: "
                    f"certiloop.studies.raven.campaign.run.replay(SETUPS[{doc['scenario']!r}], "
                    f"{_replay_args(doc, r)})")


def _replay_args(doc: dict, row: dict) -> str:
    kinds = "" if tuple(doc["faults"]) == FAULT_KINDS else f", kinds={tuple(doc['faults'])!r}"
    ticks = "" if doc["ticks"] == 2000 else f", ticks={doc['ticks']}"
    return f"{row['seed']}{kinds}{ticks}"


def search_summary(setup: Setup, result, kinds, seed: int, ticks: int, examples: int) -> dict:
    """The --json document of `campaign --search`: the claim, whether it held over the faults
    tried, and the shrunk crossing fault (with its replay)."""
    fault = result.fault
    return _clean({"scenario": setup.name, "description": setup.description, "claim": setup.claim,
                   "search": True, "holds": fault is None, "seed": seed, "ticks": ticks,
                   "max_examples": examples, "examples": result.examples, "faults": list(kinds),
                   "crossing": None if fault is None else {
                       "kind": fault.kind, "stream": fault.stream, "start": fault.start,
                       "duration": fault.duration, "magnitude": fault.magnitude,
                       "min_distance": result.min_distance}})


def show_search(out: Console, doc: dict, seconds: float = 0.0) -> None:
    c = doc["crossing"]
    if c is None:
        ui.say(out, f"{doc['scenario']}: no crossing among {doc['examples']} faults searched; claim "
                    f"'{doc['claim']}' holds for them ({seconds:.1f} s)")
        return
    ui.say(out, f"{doc['scenario']}: a crossing after {doc['examples']} faults tried (shrunk); claim "
                f"'{doc['claim']}' FAILS ({seconds:.1f} s)")
    ui.say(out, f"crossing fault: {c['kind']} on the {c['stream']} stream, ticks [{c['start']}, "
                f"{c['start'] + c['duration']}), magnitude {c['magnitude']:g}; min distance "
                f"{1000 * c['min_distance']:.3f} mm; replay it: "
                f"certiloop.studies.raven.campaign.fault_search.replay_fault("
                f"SETUPS[{doc['scenario']!r}], Fault({c['kind']!r}, {c['stream']!r}, {c['start']}, "
                f"{c['duration']}, {c['magnitude']!r}), seed={doc['seed']})")
