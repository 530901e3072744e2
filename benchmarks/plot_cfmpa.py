"""Occupancy layers of the dual-arm paper's state database, original vs modified swept region, like the
paper's Figs. 3-4 (matplotlib; `python benchmarks/bench_cfmpa.py --plot DIR` or run this file).

    python benchmarks/plot_cfmpa.py [--dt 0.1] [--scene R1] [-o DIR]

Writes DIR/cfmpa_<scene>_<dt>_layers.png: for a few layers k, the subordinate's (θ1, θ2) grid
coloured by cell: blocked in both databases, blocked only by the original region (freed by the
modification), free in both; and DIR/cfmpa_<scene>_<dt>_swept.png: the principal's link
enclosures in the workspace for those layers, original region against modified, with the static
arm at the layer's planned pose.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from certiloop.studies.dualarm.arms import arm_enclosures, builtdr, static_arm

COLOURS = np.array([[1.0, 1.0, 1.0], [0.95, 0.6, 0.2], [0.2, 0.2, 0.3]])  # free, freed by mod, blocked


def pick_layers(count: int, shown: int = 4) -> list[int]:
    """`shown` layers spread over 0 .. count-1 (all of them when there are fewer)."""
    return sorted({int(round(x)) for x in np.linspace(0, count - 1, min(shown, count))})


def plot_layers(scene, name: str, folder: Path) -> list[Path]:
    """Both figures for one scene; returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon
    from scipy.spatial import ConvexHull

    folder.mkdir(parents=True, exist_ok=True)
    orig, mod = builtdr(scene, "original"), builtdr(scene, "modified")
    layers = pick_layers(scene.layers)
    stem = f"cfmpa_{name}_{scene.dt:g}"
    m, n = scene.grid
    h1, h2 = scene.steps
    extent = (scene.r2_offset, scene.r2_offset + n * h2, m * h1, 0.0)
    fig, axes = plt.subplots(1, len(layers), figsize=(3.6 * len(layers), 3.8), squeeze=False)
    for ax, k in zip(axes[0], layers):
        kind = np.where(mod[k] == 1, 2, np.where(orig[k] == 1, 1, 0))  # mod <= orig cellwise
        ax.imshow(COLOURS[kind], extent=extent, aspect="auto", interpolation="nearest")
        freed = int(((orig[k] == 1) & (mod[k] == 0)).sum())
        ax.set_title(f"layer k={k}: {freed} cells freed", fontsize=9)
        ax.set_xlabel("θ2 (rad)")
    axes[0][0].set_ylabel("θ1 (rad)")
    fig.suptitle(f"{name}, Δt = {scene.dt:g}: dark = blocked in both, orange = blocked only by the original "
                 "swept region, white = free", fontsize=9)
    fig.tight_layout()
    layers_png = folder / f"{stem}_layers.png"
    fig.savefig(layers_png, dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(1, len(layers), figsize=(3.6 * len(layers), 3.8), squeeze=False)
    boxes = {mode: scene.principal_boxes(mode) for mode in ("original", "modified")}
    for ax, k in zip(axes[0], layers):
        for mode, colour in (("original", "tab:orange"), ("modified", "tab:blue")):
            box = boxes[mode][k]
            for link in arm_enclosures(scene.principal, box[0], box[1]):
                hull = link[ConvexHull(link).vertices]
                filled = mode == "modified"
                ax.add_patch(Polygon(hull, closed=True, fill=filled, alpha=0.35 if filled else 1.0,
                                     edgecolor=colour, facecolor=colour, label=mode))
        for rect in static_arm(scene.principal, scene.planned_pose(k * scene.dt)):
            ax.add_patch(Polygon(rect, closed=True, fill=True, facecolor="k", alpha=0.8))
        ax.set_xlim(-2, 2)
        ax.set_ylim(-2, 2)
        ax.set_aspect("equal")
        ax.set_title(f"layer k={k}", fontsize=9)
    handles, labels = axes[0][0].get_legend_handles_labels()
    unique = dict(zip(labels, handles))
    axes[0][0].legend(unique.values(), unique.keys(), fontsize=7, loc="lower left")
    fig.suptitle(f"{name}, Δt = {scene.dt:g}: the principal's swept region S_k (orange outline) and S'_k "
                 "(blue), static arm at kΔt (black)", fontsize=9)
    fig.tight_layout()
    swept_png = folder / f"{stem}_swept.png"
    fig.savefig(swept_png, dpi=110)
    plt.close(fig)
    return [layers_png, swept_png]


def main(argv: list[str] | None = None) -> int:
    from bench_cfmpa import SCENES, scene_for

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dt", type=float, nargs="+", default=[0.1])
    ap.add_argument("--scene", nargs="+", default=["R1"], choices=list(SCENES))
    ap.add_argument("-o", "--out", type=Path, default=Path("benchmarks/results/plots"))
    args = ap.parse_args(argv)
    if any(not 0 < dt < 1.5 for dt in args.dt):
        ap.error("--dt must lie in (0, 1.5)")
    for name in args.scene:
        for dt in args.dt:
            for path in plot_layers(scene_for(name, dt), name, args.out):
                print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
