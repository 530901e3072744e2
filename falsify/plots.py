"""Plots of a run: distance to every boundary over time, and the tool path.

matplotlib is an optional extra (`pip install 'certiloop[plot]'`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from certiloop.falsify.interpreter import Run


def plot_run(run: Run, model: str, path: Path) -> None:
    try:
        import matplotlib
    except ImportError:
        raise ImportError("--plot needs matplotlib: pip install 'certiloop[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    points = _points(run)
    pos = _position_axes(points)
    fig = plt.figure(figsize=(13, 5.5) if pos else (8, 5.5))
    ax = fig.add_subplot(1, 2, 1) if pos else fig.add_subplot(1, 1, 1)
    _margins(ax, run, points)
    if pos:
        three = len(pos) == 3
        ax2 = fig.add_subplot(1, 2, 2, projection="3d" if three else None)
        _path(ax2, run, points, pos)
    title = f"{model}: " + ("violated: " + run.violated if run.violated else "no violation")
    fig.suptitle(title if len(title) < 110 else title[:107] + "...", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _points(run: Run) -> list[tuple[float, dict[str, float], dict[str, float]]]:
    """Checkpoints and samples along flows, in time order."""
    pts = [(c.time, c.margins, _scalars(c.state)) for c in run.checkpoints]
    pts += run.samples
    return sorted(pts, key=lambda p: p[0])


def _scalars(state: dict[str, Any]) -> dict[str, float]:
    return {k: v for k, v in state.items() if isinstance(v, float)}


def _margins(ax, run: Run, points) -> None:
    labels = list(dict.fromkeys(k for _, m, _ in points for k in m))
    for label in labels:
        ts = [t for t, m, _ in points if label in m]
        ys = [m[label] for t, m, _ in points if label in m]
        ax.plot(ts, ys, label=_short(label), linewidth=1.2)
    for t in run.step_starts:
        ax.axvline(t, color="0.75", linestyle=":", linewidth=0.8)
    ax.axhline(0.0, color="red", linewidth=1.0)
    ax.set_xlabel("time (dotted: start of each control step ε)")
    ax.set_ylabel("margin of the guarantee (distance to the boundary)")
    if len(labels) <= 12:
        ax.legend(fontsize=7, loc="best")


def _short(label: str) -> str:
    if "[" in label and label.endswith("]"):
        return "boundary " + label[label.rindex("[") + 1:-1]
    return label if len(label) < 40 else label[:37] + "..."


def _position_axes(points) -> list[str]:
    names = set().union(*(s for _, _, s in points)) if points else set()
    return [a for a in ("px", "py", "pz") if a in names] if {"px", "py"} <= names else []


def _path(ax, run: Run, points, axes: list[str]) -> None:
    track = [[s[a] for a in axes] for _, _, s in points if all(a in s for a in axes)]
    cols = list(zip(*track))
    ax.plot(*cols, color="black", linewidth=1.2, label="tool tip")
    ax.scatter(*[[c[0]] for c in cols], color="green", label="start")
    ax.scatter(*[[c[-1]] for c in cols], color="red", label="end")
    _planes(ax, run.checkpoints[-1].state, axes, cols)
    ax.set_xlabel(axes[0])
    ax.set_ylabel(axes[1])
    if len(axes) == 3:
        ax.set_zlabel(axes[2])
    ax.legend(fontsize=7, loc="best")
    ax.set_title("tool path and boundaries", fontsize=9)


def _planes(ax, state: dict[str, Any], axes: list[str], cols) -> None:
    import numpy as np

    normals = [state.get("n" + a[1:]) for a in axes]
    points = [state.get("r" + a[1:]) for a in axes]
    span = max(1.0, *(max(c) - min(c) for c in cols))
    centre = np.array([np.mean(c) for c in cols])
    if not all(isinstance(x, dict) for x in normals + points):
        if len(axes) == 2:  # a model whose boundary is the x-axis (Table 1)
            ax.axhline(0.0, color="red", linewidth=1.0, label="boundary")
        return
    for key in normals[0]:
        n = np.array([nn.get(key, 0.0) for nn in normals])
        r = np.array([rr.get(key, 0.0) for rr in points])
        if not np.any(n):
            continue
        # the plane's point nearest to the path's centre, and two directions within it
        foot = centre - np.dot(centre - r, n) / np.dot(n, n) * n
        if len(axes) == 2:
            d = np.array([-n[1], n[0]]) / np.linalg.norm(n) * span
            ax.plot([foot[0] - d[0], foot[0] + d[0]], [foot[1] - d[1], foot[1] + d[1]], linewidth=1,
                    label=f"boundary {key}")
        else:
            u = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
            u = u / np.linalg.norm(u) * span / 2
            v = np.cross(n, u) / np.linalg.norm(n)
            grid = [[foot + a * u + b * v for a in (-1, 1)] for b in (-1, 1)]
            xs, ys, zs = (np.array([[p[k] for p in row] for row in grid]) for k in range(3))
            ax.plot_surface(xs, ys, zs, alpha=0.2)
