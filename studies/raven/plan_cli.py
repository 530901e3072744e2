"""`certiloop plan` (FMT* through OMPL, certified paths) and `certiloop check-path`.

plan exits 0 when at least one run returned a certified path, 1 when none did, 2 on bad
input (unknown scene, bad flag, OMPL missing: a one-line install hint). check-path exits 0
when every successful run's certificate re-checks, 1 naming the first run and segment that
does not (or when the file holds no certified path), 2 on a malformed file.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from types import SimpleNamespace

MAX_SEED = 2**31 - 2  # OMPL's seed is a 32-bit unsigned integer, and run i uses seed + i + 1
MAX_RUNS = 10_000
MAX_SAMPLES = 200_000


class PlanInputError(ValueError):
    """Bad input for plan / check-path (exit 2)."""


def parse_eta(text: str) -> tuple[float, float]:
    try:
        parts = [float(p) for p in text.split(",")]
    except ValueError:
        raise PlanInputError(f"--eta must be two numbers 'eta1,eta2' (eq 1's weights), "
                             f"got {text!r}") from None
    if len(parts) != 2 or any(not (p >= 0 and p < float("inf")) for p in parts) or sum(parts) == 0:
        raise PlanInputError(f"--eta must be two finite weights >= 0, not both 0, as 'eta1,eta2'; "
                             f"got {text!r}")
    return parts[0], parts[1]


def _median(values):
    import statistics

    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def summary(scene_name: str, samples: int, eta, seed: int, runs: list[dict]) -> dict:
    import platform

    ok = [r for r in runs if r["success"]]
    return {"scenario": scene_name, "samples": samples, "eta": list(eta), "seed": seed,
            "runs_total": len(runs), "successes": len(ok), "success_rate": len(ok) / len(runs),
            "median_planning_s": _median([r["planning_s"] for r in runs]),
            "median_cost": _median([r["cost"] for r in ok]),
            "median_waypoints": _median([len(r["waypoints"]) for r in ok]),
            "machine": f"{platform.machine()} {platform.system()}, Python {platform.python_version()}",
            "runs": runs}


def cmd_plan(args, out, progress) -> int:
    from certiloop.studies.raven.plan.scenes import SCENES

    scene = SCENES.get(args.scenario)
    if scene is None:
        raise PlanInputError(f"unknown scenario {args.scenario!r}; choose among {', '.join(SCENES)}")
    if not 2 <= args.samples <= MAX_SAMPLES:
        raise PlanInputError(f"--samples must be between 2 and {MAX_SAMPLES:,}, got {args.samples}")
    if not 1 <= args.runs <= MAX_RUNS:
        raise PlanInputError(f"--runs must be between 1 and {MAX_RUNS:,}, got {args.runs}")
    if not 0 <= args.seed <= MAX_SEED - MAX_RUNS:
        raise PlanInputError(f"--seed must be between 0 and {MAX_SEED - MAX_RUNS}, got {args.seed}")
    if args.radius_multiplier is not None and not args.radius_multiplier > 0:
        raise PlanInputError(f"--radius-multiplier must be positive, got {args.radius_multiplier:g}")
    if not args.wall_cap > 0:
        raise PlanInputError(f"--wall-cap must be positive, got {args.wall_cap:g}")
    eta = parse_eta(args.eta)
    from certiloop.studies.raven.plan.planner import free_fraction, load_ompl, plan_once

    load_ompl()  # ImportError with the install hint -> exit 2
    from certiloop.cli import ui

    free = free_fraction(scene)
    runs = []
    progress.model(scene.name)
    progress.steps(args.runs)
    for i in range(args.runs):
        run = plan_once(scene, args.samples, args.seed + i, eta, args.radius_multiplier, args.wall_cap, free)
        runs.append(run.to_json())
        progress.step()
        if not args.quiet:
            what = (f"certified, {len(run.waypoints)} waypoints, cost {run.cost:.4g}" if run.success
                    else f"no path: {run.reason}")
            ui.say(out, f"  run {i} (seed {run.seed}): {run.planning_s:.2f} s, {what}")
    doc = summary(scene.name, args.samples, eta, args.seed, runs)
    if args.json:
        text = json.dumps(doc, indent=1)
        if args.json == "-":
            print(text)
        else:
            Path(args.json).write_text(text + "\n")
    med = doc["median_planning_s"]
    cost = "" if doc["median_cost"] is None else f", median cost {doc['median_cost']:.4g}"
    ui.say(out, f"{scene.name}: {doc['successes']} of {len(runs)} runs certified "
                f"({100 * doc['success_rate']:.0f} %), median planning {med:.2f} s at "
                f"n = {args.samples}{cost}")
    return 0 if doc["successes"] else 1


def load_plan_file(name: str) -> list[dict]:
    try:
        doc = json.loads(Path(name).read_text())
    except FileNotFoundError:
        raise PlanInputError(f"{name}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanInputError(f"{name}: cannot read it ({exc})") from None
    except json.JSONDecodeError as exc:
        raise PlanInputError(f"{name}: not JSON ({exc.msg} at line {exc.lineno})") from None
    runs = doc.get("runs") if isinstance(doc, dict) else None
    if not isinstance(runs, list) or not all(isinstance(r, dict) for r in runs):
        raise PlanInputError(f"{name}: expected a `certiloop plan --json` file with a 'runs' list")
    return runs


def cmd_check_path(args, out) -> int:
    from certiloop.cli import ui
    from certiloop.studies.raven.plan.check import check_run
    from certiloop.studies.raven.plan.scenes import SCENES

    runs = load_plan_file(args.file)
    start, checked, pieces = time.perf_counter(), 0, 0
    for i, run in enumerate(runs):
        if not run.get("success"):
            continue
        try:
            result = check_run(run, SCENES)
        except (ValueError, KeyError, IndexError, TypeError, ZeroDivisionError) as exc:
            raise PlanInputError(f"{args.file}: run {i}: malformed certificate ({exc}); re-create the file "
                                 "with `certiloop plan --json`") from None
        checked += 1
        pieces += result.pieces
        if not result.ok:
            ui.say(out, f"{args.file}: run {i}: REJECTED: {result.reason}")
            return 1
    if not checked:
        ui.say(out, f"{args.file}: no certified path to check (no run succeeded)")
        return 1
    ui.say(out, f"{args.file}: {checked} certified path{'s' * (checked != 1)} re-checked, every segment "
                f"clear ({pieces} pieces, mpmath intervals, {time.perf_counter() - start:.2f} s)")
    return 0


def add_plan_parser(sub) -> None:
    plan = sub.add_parser(
        "plan", help="plan Raven-II motions with FMT* (OMPL) and certify every returned path",
        description="Run FMT* (OMPL's og.FMT; needs certiloop[plan]) R times on SCENARIO with N "
        "samples, seeds S, S+1, ...; every returned path is proved clear segment by segment with "
        "interval arithmetic and re-checked independently before it counts as a success. Exit 0 "
        "if some run returned a certified path, 1 if none did.")
    plan.add_argument("scenario", metavar="SCENARIO", help="raven.frs_box (the paper's FRS-dome scene)")
    plan.add_argument("--samples", metavar="N", type=int, required=True, help="FMT* samples per run")
    plan.add_argument("--runs", metavar="R", type=int, default=1, help="runs (default 1)")
    plan.add_argument("--eta", metavar="ETA1,ETA2", default="0.1,0.5",
                      help="eq 1's weights of path length and tip acceleration (default 0.1,0.5, Table 2's)")
    plan.add_argument("--seed", metavar="S", type=int, default=0, help="seed of run 0 (default 0)")
    plan.add_argument("--radius-multiplier", metavar="X", type=float,
                      help="FMT*'s radius multiplier on eq 2's r_n (default OMPL's 1.1)")
    plan.add_argument("--wall-cap", metavar="S", type=float, default=600.0,
                      help="wall-clock guard per run (default 600 s): reaching it is a failure that "
                      "says so; the verdict otherwise depends only on samples and seed")
    plan.add_argument("--json", metavar="F", help="write {\"runs\": [...], ...} to F ('-' for stdout)")
    plan.add_argument("-q", "--quiet", action="store_true", help="print only the summary line")


def add_check_path_parser(sub) -> None:
    check_path = sub.add_parser(
        "check-path", help="re-check the certificates of a `certiloop plan --json` file",
        description="Re-check every certified path in FILE independently (mpmath interval "
        "arithmetic over the Raven-II DH chain): exit 0 if every segment is proved clear of "
        "the scene, 1 naming the first bad segment.")
    check_path.add_argument("file", metavar="FILE", help="a `certiloop plan --json` output")


def run(args) -> int:
    from certiloop.cli import options, ui
    from certiloop.cli.errors import BadInput

    try:
        if args.command == "check-path":
            return cmd_check_path(args, options.console())
        options.check_outputs(("--json", args.json, "file or -"))
        with ui.ModelProgress("planning", 1, not args.quiet) as progress:
            return cmd_plan(args, options.console(stderr=args.json == "-"), progress)
    except PlanInputError as exc:
        raise BadInput(str(exc)) from None


PLAN = SimpleNamespace(add_parser=add_plan_parser, run=run)
CHECK_PATH = SimpleNamespace(add_parser=add_check_path_parser, run=run)
