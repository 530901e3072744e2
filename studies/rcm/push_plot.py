"""The figure of `certiloop falsify rcm.push_* --plot F.png`: the entering push found by the
search, replayed on the paper's controller and on the guarded one (left: the brute-force
clearance over time, the entry marked; right: the push's force components).

matplotlib is an optional extra (`pip install 'certiloop[plot]'`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from certiloop.studies.rcm.push import SCENARIOS, PushRun, replay

PERIOD_MS = 4.0


def plot_push(run: PushRun, scenario: str, path: Path, points: int = 1000, gap: float = 0.02) -> None:
    try:
        import matplotlib
    except ImportError:
        raise ImportError("--plot needs matplotlib: pip install 'certiloop[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    options = SCENARIOS[scenario][0]
    guarded_name = "rcm.push_capsule_guarded" if options["mode"] == "tool" else "rcm.push_guarded"
    # the same push, a little longer, on the guarded controller: it must stay out
    longer = type(run.profile)((*run.profile.segments, (50, run.profile.segments[-1][1])))
    guarded = replay(guarded_name, longer, points, gap)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for r, label, style in ((run, scenario, "-"), (guarded, guarded_name, "--")):
        t = np.arange(len(r.clearance)) * PERIOD_MS
        left.plot(t, r.clearance * 1000, style, label=f"{label} (least {r.clearance.min() * 1000:.3f} mm)")
    if run.first_entry >= 0:
        left.axvline(run.first_entry * PERIOD_MS, color="red", lw=0.8)
        left.annotate("enters", (run.first_entry * PERIOD_MS, 0), color="red", xytext=(5, 10),
                      textcoords="offset points")
    left.axhline(0, color="black", lw=0.8)
    left.set(xlabel="time (ms)", ylabel="clearance to the cloud (mm, brute force)",
             title="the push found by the search, replayed")
    left.legend(fontsize=8)
    forces = longer.forces()
    t = np.arange(len(forces)) * PERIOD_MS
    for i, axis in enumerate("xyz"):
        right.step(t, forces[:, i], where="post", label=f"F_{axis}")
    right.set(xlabel="time (ms)", ylabel="human force at the flange (N)",
              title=f"peak {run.profile.peak():.2f} N")
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
