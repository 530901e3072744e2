"""Session summary: per theme, how many cases the engine proved / refuted / left unknown /
rejected, and every case whose outcome is not allowed (with the engine's reason)."""

import json
import os

from .harness import RESULTS

KINDS = ("proved", "refuted", "unknown", "rejected")


def _natural(theme: str):
    head = theme.split("-")[0]
    return (int(head) if head.isdigit() else 0, theme)


def pytest_terminal_summary(terminalreporter):
    if not RESULTS:
        return
    w = terminalreporter.write_line
    w("")
    w("soundness suite: engine outcomes per theme")
    head = f"{'theme':<14}{'cases':>6}" + "".join(f"{k:>10}" for k in KINDS) + f"{'crash':>8}{'wrong':>8}"
    w(head)
    totals = [0] * (len(KINDS) + 3)
    wrong_rows = []
    for theme in sorted(RESULTS, key=_natural):
        rows = RESULTS[theme]
        counts = [sum(1 for o, _, _ in rows.values() if o["verdict"] == k) for k in KINDS]
        crash = sum(1 for o, _, _ in rows.values() if o["verdict"].startswith("crash"))
        wrong = sum(1 for _, ok, _ in rows.values() if not ok)
        line = [len(rows), *counts, crash, wrong]
        totals = [a + b for a, b in zip(totals, line)]
        w(f"{theme:<14}{len(rows):>6}" + "".join(f"{c:>10}" for c in counts) + f"{crash:>8}{wrong:>8}")
        wrong_rows += [(theme, cid, o, why) for cid, (o, ok, why) in rows.items() if not ok]
    w(
        f"{'total':<14}{totals[0]:>6}"
        + "".join(f"{c:>10}" for c in totals[1:5])
        + f"{totals[5]:>8}{totals[6]:>8}"
    )
    if wrong_rows:
        w("")
        w("outcomes not allowed:")
        for theme, cid, o, why in wrong_rows:
            w(f"  {theme}/{cid}: {why} ({o['reason'][:160]})")
    bugs = [
        (t, cid, o)
        for t, rows in sorted(RESULTS.items())
        for cid, (o, _, _) in rows.items()
        if "BUG" in o["reason"]
    ]
    if bugs:
        w("")
        w("outcomes whose reason reports an engine BUG (allowed, but worth a look):")
        for theme, cid, o in bugs:
            w(f"  {theme}/{cid}: {o['verdict']} ({o['reason'][:160]})")
    path = os.environ.get("SOUNDNESS_REPORT")
    if path:
        with open(path, "w") as fh:
            json.dump(
                {
                    t: {cid: {"outcome": o, "ok": ok, "why": why} for cid, (o, ok, why) in rows.items()}
                    for t, rows in RESULTS.items()
                },
                fh,
                indent=1,
                default=str,
            )
