"""Demo: a surgeon pushes the tool into the corner of three planes; the fixture holds it.

    python -m certiloop.studies.sbs.demo [--plot demo.png] [--steps 60]

The tool starts at (1, 1, 1) above the corner of the planes x = 0, y = 0 and z = 0 (safe
side: positive coordinates) and the scripted force drives it diagonally into the corner,
with a wobble. The plant is simulated exactly (p' = G k f, f' = fp over each period ε).
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from certiloop.studies.sbs.fixture import VirtualFixture

G, D, EPS = 1.0, 0.5, 0.0182  # the paper's control delay ε = 18.2 ms
PLANES = [((0, 0, 0), (1, 0, 0)), ((0, 0, 0), (0, 1, 0)), ((0, 0, 0), (0, 0, 1))]


def force(t: float) -> np.ndarray:
    """The surgeon's push: into the corner at up to 40 units, wobbling sideways."""
    push = 40 * min(1.0, t / 0.2)
    return np.array([-push * (1 + 0.3 * math.sin(9 * t)), -push * (1 + 0.3 * math.cos(7 * t)), -push])


def simulate(steps: int):
    fixture = VirtualFixture(PLANES, gain=G, buffer=D, period=EPS)
    p = np.array([1.0, 1.0, 1.0])
    rows = []
    for n in range(steps):
        t = n * EPS
        f, fp = force(t), (force(t + EPS) - force(t)) / EPS  # the rate over the coming period
        cmd = fixture.step(p, f, fp)
        rows.append((n, t, cmd.k, *[float(np.dot(p - pt, nn)) for pt, nn in fixture.planes.values()],
                     cmd.reason))
        p = p + G * cmd.k * (f * EPS + fp * EPS**2 / 2)
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m certiloop.studies.sbs.demo",
                                     description=__doc__.split("\n")[0])
    parser.add_argument("--steps", type=int, default=60, help="control periods to simulate (default 60)")
    parser.add_argument("--plot", metavar="F.png", help="save distances and k over time to F.png")
    args = parser.parse_args(argv)
    rows = simulate(args.steps)
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"virtual fixture, corner of three planes (G={G}, D={D}, ε={EPS} s)")
    for col in ("step", "t (s)", "k", "dist x=0", "dist y=0", "dist z=0", "fallback"):
        table.add_column(col, justify="right")
    for n, t, k, dx, dy, dz, why in rows:
        table.add_row(str(n), f"{t:.4f}", f"{k:.4f}", f"{dx:.4f}", f"{dy:.4f}", f"{dz:.4f}", why or "-")
    Console().print(table)
    worst = min(min(r[3:6]) for r in rows)
    verdict = ("never negative" if worst >= 0 else "CROSSED" if worst < -1e-9 else
               "below 0 only by the float rounding of this simulation's plant")
    print(f"smallest distance to any plane: {worst:.6g} ({verdict})")
    if args.plot:
        _plot(rows, args.plot)
        print(f"plot: {args.plot}")
    return 0 if worst >= -1e-9 else 1


def _plot(rows, path: str) -> None:
    try:
        import matplotlib
    except ImportError:
        raise SystemExit("--plot needs matplotlib: pip install 'certiloop[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = [r[1] for r in rows]
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    for col, name in zip((3, 4, 5), ("x = 0", "y = 0", "z = 0")):
        top.plot(t, [r[col] for r in rows], label=f"distance to {name}")
    top.axhline(D, color="0.6", linestyle=":", label="slow zone D")
    top.axhline(0, color="red", linewidth=1)
    top.set_ylabel("distance")
    top.legend(fontsize=8)
    bottom.step(t, [r[2] for r in rows], where="post")
    bottom.set_ylabel("gain k")
    bottom.set_xlabel("time (s)")
    fig.suptitle("certiloop kernel: tool pushed into a corner of three planes")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
