"""Plots of a fault-injection campaign (`certiloop campaign ... --plot F.png`).

Left, ROC per fault kind: the monitor alarms when the deviation ||e|| exceeds a threshold, so
each threshold tau gives a detector "peak ||e|| > tau" over the runs; its TPR is the share of
the kind's faulty runs whose peak exceeds tau, its FPR the share of golden runs (no fault)
whose peak does. The monitor's own threshold (tol) is marked on each curve. Right, the
detection latency (first alarm minus fault start, TP runs) per kind as an empirical CDF,
with the p95 from the summary. The peak is over the whole run, so an alarm before the fault
window counts as detection here while the summary calls it a false positive: the ROC is the
monitor's separating power, the table its run-level outcome.

matplotlib is an optional extra (`pip install 'certiloop[plot]'`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def roc_points(scores_positive, scores_negative) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(thresholds, FPR, TPR) of the detectors "score > tau" for every distinct score, from
    the strictest (nothing alarms) to the loosest (everything alarms)."""
    pos, neg = np.asarray(scores_positive, float), np.asarray(scores_negative, float)
    taus = np.unique(np.concatenate([pos, neg, [np.inf]]))[::-1]
    taus = np.append(taus, -np.inf)
    tpr = np.array([(pos > t).mean() if len(pos) else np.nan for t in taus])
    fpr = np.array([(neg > t).mean() if len(neg) else np.nan for t in taus])
    return taus, fpr, tpr


def plot_campaign(rows: list[dict], doc: dict, path: Path) -> None:
    try:
        import matplotlib
    except ImportError:
        raise ImportError("--plot needs matplotlib: pip install 'certiloop[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tol = doc.get("tol", 0.003)
    scored = [r for r in rows if r.get("peak_deviation") is not None]
    golden = [r["peak_deviation"] for r in scored if r["kind"] == "none"]
    kinds = sorted({r["kind"] for r in rows} - {"none"})
    fig, (roc, lat) = plt.subplots(1, 2, figsize=(12, 5))
    for kind in kinds:
        faulty = [r["peak_deviation"] for r in scored if r["kind"] == kind]
        if faulty and golden:
            _, fpr, tpr = roc_points(faulty, golden)
            line, = roc.step(fpr, tpr, where="post", label=kind)
            roc.plot([np.mean(np.asarray(golden) > tol)], [np.mean(np.asarray(faulty) > tol)], "o",
                     color=line.get_color())
        latencies = np.sort([r["latency"] for r in rows if r["kind"] == kind and r["latency"] is not None])
        if len(latencies):
            lat.step(latencies, np.arange(1, len(latencies) + 1) / len(latencies), where="post",
                     label=f"{kind} (p95 {np.percentile(latencies, 95):.0f} ms)")
    roc.plot([0, 1], [0, 1], ":", color="grey", linewidth=0.8)
    roc.set(xlabel="false positive rate (golden runs)", ylabel="true positive rate",
            title=f"ROC of 'peak ||e|| > tau' (dots: tau = tol = {1000 * tol:g} mm)",
            xlim=(-0.02, 1.02), ylim=(-0.02, 1.02))
    lat.set(xlabel="detection latency (ms after the fault starts)", ylabel="share of detected runs",
            title="detection latency, true positives")
    for ax in (roc, lat):
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8, loc="lower right")
        ax.grid(alpha=0.3)
    if not scored:
        roc.text(0.5, 0.5, "no per-run scores (a fixed experiment)", ha="center")
    title = f"{doc.get('scenario', 'campaign')}: {len(rows)} rows, seed {doc.get('seed', '')}"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
