"""Campaign metrics: run-level confusion, rates with Wilson 95 % intervals, latency.

Rows are `falsify.campaign.run_setup`'s: one per run with its `kind`, `outcome` (TP, FP, FN,
TN as raven2_sim labels runs), `latency` (ticks from the fault's start to the first alarm,
for TP runs) and `crossed`. TPR = TP / (TP + FN), FPR = FP / (FP + TN), F1 = 2TP / (2TP + FP
+ FN); the intervals are for TPR and FPR (binomial proportions), F1 is a point estimate.
"""

from __future__ import annotations

import math

import numpy as np

Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval for k successes in n trials ((nan, nan) when n = 0)."""
    if n == 0:
        return (math.nan, math.nan)
    p, zz = k / n, z * z
    centre = (p + zz / (2 * n)) / (1 + zz / n)
    half = z * math.sqrt(p * (1 - p) / n + zz / (4 * n * n)) / (1 + zz / n)
    return (0.0 if k == 0 else max(0.0, centre - half), 1.0 if k == n else min(1.0, centre + half))


def _rate(k: int, n: int) -> float:
    return k / n if n else math.nan


def summarize(rows: list[dict]) -> dict:
    """Counts, rates with intervals, latency median and p95 (ticks = ms), crossings."""
    c = {k: sum(r["outcome"] == k for r in rows) for k in ("TP", "FP", "FN", "TN")}
    tp, fp, fn, tn = c["TP"], c["FP"], c["FN"], c["TN"]
    lat = [r["latency"] for r in rows if r["latency"] is not None]
    return {"runs": len(rows), **c,
            "TPR": _rate(tp, tp + fn), "TPR_ci": wilson(tp, tp + fn),
            "FPR": _rate(fp, fp + tn), "FPR_ci": wilson(fp, fp + tn),
            "F1": _rate(2 * tp, 2 * tp + fp + fn),
            "latency_median": float(np.median(lat)) if lat else math.nan,
            "latency_p95": float(np.percentile(lat, 95)) if lat else math.nan,
            "crossings": sum(r["crossed"] for r in rows)}


def by_kind(rows: list[dict]) -> dict[str, dict]:
    """summarize() per fault kind ("none": the golden runs), sorted by name, then "all"."""
    kinds = sorted({r["kind"] for r in rows})
    out = {k: summarize([r for r in rows if r["kind"] == k]) for k in kinds}
    out["all"] = summarize(rows)
    return out
