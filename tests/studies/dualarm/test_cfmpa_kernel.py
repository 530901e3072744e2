"""The dual-arm kernel (the dual-arm paper): enclosures and builtDR against shapely, the planner against
brute force, the checker against the path definition.

shapely is an independent oracle (test extra only): it never runs in the kernel.
"""

from __future__ import annotations

import itertools
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.studies.dualarm.arms import (
    Arm,
    Scene,
    arm_enclosures,
    builtdr,
    reference_scene,
    static_arm,
    sweep_points,
)
from certiloop.studies.dualarm.planner import check_path, costs, plan

shapely = pytest.importorskip("shapely")
from shapely.geometry import MultiPoint, Polygon  # noqa: E402


def _hull(points) -> Polygon:
    return MultiPoint([tuple(p) for p in np.asarray(points).reshape(-1, 2)]).convex_hull


# --------------------------------------------------------------------------- enclosures


@given(st.floats(-math.pi, math.pi), st.floats(0.01, 1.5), st.floats(0, 1), st.floats(0.2, 2.0))
def test_sweep_encloses_every_intermediate_pose(lo, span, frac, length):
    """A link rotated by any angle in [lo, lo + span] lies inside the 12-point enclosure; the
    end poses alone (no apex) do not always contain it (the arc bulge)."""
    rect = np.array([[0.0, -0.05], [length, -0.05], [length, 0.05], [0.0, 0.05]])
    hull = _hull(sweep_points(rect, lo, lo + span))
    a = lo + frac * span
    c, s = math.cos(a), math.sin(a)
    posed = Polygon(rect @ np.array([[c, s], [-s, c]]))
    assert hull.buffer(1e-9).contains(posed)


def test_end_poses_alone_miss_the_bulge():
    """The hull of the end poses misses the middle pose by r (1 - cos(α/2)): 9 mm at 1.8 m, 0.2 rad."""
    rect = np.array([[0.0, 0.0], [1.8, 0.0]])
    ends = _hull(np.vstack([sweep_points(rect, 0.0, 0.2)[:4]]))
    middle = np.array([1.8 * math.cos(0.1), 1.8 * math.sin(0.1)])
    gap = ends.distance(shapely.geometry.Point(middle))
    assert gap == pytest.approx(1.8 * (1 - math.cos(0.1)), rel=1e-6)


@given(st.lists(st.floats(-math.pi, math.pi), min_size=2, max_size=2), st.floats(0.01, 0.6),
       st.floats(0.01, 0.6), st.floats(0, 1), st.floats(0, 1))
def test_arm_enclosure_contains_every_pose_of_the_box(start, w1, w2, f1, f2):
    """Both links at any joint pose of the box [θ1, θ1 + w1] x [θ2, θ2 + w2] lie in their
    enclosures (link 2 through its two-stage sweep)."""
    arm = Arm(base=(0.3, -0.2), l1=1.0, l2=0.8, width=0.1)
    box1, box2 = np.array([start[0], start[0] + w1]), np.array([start[1], start[1] + w2])
    e1, e2 = arm_enclosures(arm, box1, box2)
    pose = (start[0] + f1 * w1, start[1] + f2 * w2)
    link1, link2 = static_arm(arm, pose)
    assert _hull(e1).buffer(1e-9).contains(Polygon(link1))
    assert _hull(e2).buffer(1e-9).contains(Polygon(link2))


# --------------------------------------------------------------------------- builtDR


@pytest.fixture(scope="module")
def r1_coarse():
    scene = reference_scene(0.2)
    return scene, builtdr(scene, "original"), builtdr(scene, "modified")


def test_reference_scene_shape_and_monotonicity(r1_coarse):
    """N = ⌈2/0.2⌉ = 10 layers, m = n = ⌈2π/0.2⌉ = 32; the modified database is cellwise <= the
    original (Property 8b) and frees strictly more cells (the paper's claim)."""
    scene, orig, mod = r1_coarse
    assert orig.shape == mod.shape == (10, 32, 32)
    assert (mod <= orig).all()
    assert (mod == 0).sum() > (orig == 0).sum()


def _cell_enclosures(scene: Scene, mode: str, k: int, i: int, j: int):
    boxes = scene.principal_boxes(mode)[k]
    p = arm_enclosures(scene.principal, boxes[0], boxes[1])
    r1, r2 = scene.cell_angles(i, j)
    wr = np.asarray(scene.w_subordinate) * scene.dt
    box1, box2 = np.array([r1 - wr[0], r1 + wr[0]]), np.array([r2 - wr[1], r2 + wr[1]])
    s = arm_enclosures(scene.subordinate, box1, box2)
    return p, s


@pytest.mark.parametrize("mode", ["original", "modified"])
def test_free_cells_have_disjoint_exact_hulls(r1_coarse, mode):
    """Every free cell: the exact (shapely) hulls of all four link pairs are disjoint. Cells
    marked occupied with disjoint exact hulls are the fixed-axis test's conservatism; count
    them (they must be few)."""
    scene, orig, mod = r1_coarse
    P = orig if mode == "original" else mod
    rng = np.random.default_rng(1)
    cells = np.argwhere(np.ones_like(P, dtype=bool))
    conservative = 0
    for k, i, j in cells[rng.choice(len(cells), 600, replace=False)]:
        (p1, p2), (s1, s2) = _cell_enclosures(scene, mode, int(k), int(i), int(j))
        meet = any(_hull(a).intersects(_hull(b)) for a in (p1, p2) for b in (s1, s2))
        if P[k, i, j] == 0:
            assert not meet, f"cell {(k, i, j)} is free but its hulls meet"
        elif not meet:
            conservative += 1
    assert conservative <= 0.05 * 600


def test_sampled_motions_through_free_cells_never_collide(r1_coarse):
    """Soundness sampling, independent of the enclosures: for free cells of the modified database,
    the principal on its planned PTP motion at a random instant of step k, and the subordinate
    anywhere on a king move out of the cell at the same instant, have disjoint link polygons."""
    scene, _, mod = r1_coarse
    N, m, n = mod.shape
    rng = np.random.default_rng(2)
    free = np.argwhere(mod == 0)
    h1, h2 = scene.steps
    for k, i, j in free[rng.choice(len(free), 800, replace=False)]:
        lam = rng.uniform()
        principal = scene.planned_pose((k + lam) * scene.dt)
        di, dj = rng.integers(-1, 2, size=2)
        r1, r2 = scene.cell_angles(i, j)
        sub = (r1 + di * h1 * lam, r2 + dj * h2 * lam)
        a = [Polygon(x) for x in static_arm(scene.principal, principal)]
        b = [Polygon(x) for x in static_arm(scene.subordinate, sub)]
        assert not any(x.intersects(y) for x in a for y in b), (k, i, j, lam)


def test_bad_scenes_are_refused():
    arm = Arm((0, 0), 1, 1, 0.1)
    with pytest.raises(ValueError, match="dt"):
        Scene(arm, arm, (0, 0), (1, 1), (1, 1), (1, 1), dt=0.0)
    with pytest.raises(ValueError, match="half a turn"):
        Scene(arm, arm, (0, 0), (1, 1), (1, 1), (1, 1), dt=2.0)
    with pytest.raises(ValueError, match="mode"):
        reference_scene(0.2).principal_boxes("sideways")


# --------------------------------------------------------------------------- planner vs brute force


def _brute_force(P, start, goal, horizon):
    """Every walk of king moves through free cells with N <= len <= horizon, by depth-first
    enumeration with branch and bound (a walk's (J1, J2) never decreases as it grows, so a
    prefix already no cheaper than the best complete walk is cut): the lexicographically least
    (J1, J2), or None. Costs are summed here move by move, independently of `costs`."""
    N, m, n = P.shape
    best = None
    moves = sorted(itertools.product((-1, 0, 1), repeat=2), key=lambda d: abs(d[0]) + abs(d[1]))  # stay first

    def go(length, cell, last, j1, j2):
        nonlocal best
        if P[min(length - 1, N - 1), cell[0], cell[1]] or (best is not None and (j1, j2) >= best):
            return
        if length >= N and cell == tuple(goal):
            best = (j1, j2)
        if length == horizon:
            return
        for di, dj in moves:
            ni, nj = cell[0] + di, cell[1] + dj
            if 0 <= ni < m and 0 <= nj < n:
                go(length + 1, (ni, nj), (di, dj), j1 + abs(di) + abs(dj),
                   j2 + abs(di - last[0]) + abs(dj - last[1]))

    if P[N - 1, goal[0], goal[1]]:  # the last element of a walk with len >= N is checked in layer N - 1
        return None
    go(1, tuple(start), (0, 0), 0, 0)
    return best


# the spec's grids and instances: m, n, N <= 4 with horizon N + 6, >= 500 instances (3,000 in the slow set)
@settings(max_examples=500)
@given(st.integers(1, 4), st.integers(1, 4), st.integers(1, 4), st.floats(0, 0.6), st.integers(0, 2**32 - 1))
def test_planner_matches_brute_force(N, m, n, density, seed):
    _planner_matches_brute_force(N, m, n, density, seed)


@pytest.mark.slow
@settings(max_examples=3000)
@given(st.integers(1, 4), st.integers(1, 4), st.integers(1, 4), st.floats(0, 0.6), st.integers(0, 2**32 - 1))
def test_planner_matches_brute_force_3000(N, m, n, density, seed):
    _planner_matches_brute_force(N, m, n, density, seed)


def _planner_matches_brute_force(N, m, n, density, seed):
    rng = np.random.default_rng(seed)
    P = (rng.uniform(size=(N, m, n)) < density).astype(np.uint8)
    start = (int(rng.integers(m)), int(rng.integers(n)))
    goal = (int(rng.integers(m)), int(rng.integers(n)))
    horizon = N + 6
    brute = _brute_force(P, start, goal, horizon)
    got = plan(P, start, goal)
    if got.ok:
        assert check_path(P, got.path, start, goal)[0]
        assert costs(got.path) == (got.j1, got.j2)
        if brute is not None:
            assert (got.j1, got.j2) <= brute
        if len(got.path) <= horizon:
            assert brute == (got.j1, got.j2)
    else:
        assert brute is None


def test_checker_rejects_each_defect():
    P = np.zeros((3, 4, 4), np.uint8)
    P[2, 3, 3] = 1
    good = [(0, 0), (1, 1), (2, 2)]
    assert check_path(P, good, (0, 0), (2, 2)) == (True, "")
    assert "fewer than N" in check_path(P, [(0, 0), (1, 1)], (0, 0), (1, 1))[1]  # early arrival
    assert "neighbours" in check_path(P, [(0, 0), (2, 2), (2, 2)], (0, 0), (2, 2))[1]
    assert "off the grid" in check_path(P, [(0, 0), (-1, 0), (0, 0)], (0, 0), (0, 0))[1]
    assert "blocked" in check_path(P, [(1, 1), (2, 2), (3, 3)], (1, 1), (3, 3))[1]
    assert "start" in check_path(P, good, (1, 0), (2, 2))[1]


def test_early_arrival_is_not_a_plan():
    """start = goal with the goal blocked only in the last layer: the paper's [start] would be
    optimal (J1 = 0), the planner must dodge or refuse."""
    P = np.zeros((3, 3, 3), np.uint8)
    P[2, 1, 1] = 1  # the principal ends up where the subordinate parks
    got = plan(P, (1, 1), (1, 1))
    assert not got.ok


def test_planner_refuses_bad_input():
    with pytest.raises(ValueError, match="start"):
        plan(np.zeros((2, 3, 3), np.uint8), (5, 0), (0, 0))
    with pytest.raises(ValueError, match="shape"):
        plan(np.zeros((3, 3), np.uint8), (0, 0), (0, 0))


def test_kernel_imports_numpy_only():
    """Also after a database is built and planned (the extracted code's hash pins read the
    model library, which must not pull in a prover)."""
    code = ("import sys, certiloop.studies.dualarm.arms as d, certiloop.studies.dualarm.planner as p; "
            "p.plan(d.builtdr(d.reference_scene(0.4)), (0, 0), (1, 1)); "
            "heavy = ('z3', 'sympy', 'hypothesis', 'scipy', 'cvxpy', 'shapely'); "
            "print([m for m in heavy if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# --------------------------------------------------------------------------- checker vs the model


def _interpret_check_path(P, path, start, goal) -> bool:
    """ok after running the proved model `cfmpa.check_path` in the interpreter on this input."""
    from certiloop.falsify.choosers import FirstEnabled
    from certiloop.falsify.evaluate import Table
    from certiloop.falsify.interpreter import Interpreter
    from certiloop.models import library

    N, m, n = P.shape
    cells = {(k, i, j): int(P[k, i, j]) for k in range(N) for i in range(m) for j in range(n)}
    state = {"N": N, "m": m, "n": n, "ln": len(path), "si": start[0], "sj": start[1], "gi": goal[0],
             "gj": goal[1], "P": Table(cells, default=1),
             "Li": Table({(k,): c[0] for k, c in enumerate(path)}, default=-1),
             "Lj": Table({(k,): c[1] for k, c in enumerate(path)}, default=-1)}
    run = Interpreter(library.get("cfmpa.check_path"), exact=True).run(FirstEnabled(), initial=state)
    return int(run.final["ok"]) == 1


@settings(max_examples=200)
@given(st.integers(1, 3), st.integers(1, 3), st.integers(1, 3), st.floats(0, 0.5), st.integers(0, 2**32 - 1),
       st.integers(1, 6))
def test_checker_agrees_with_the_proved_model(N, m, n, density, seed, length):
    """The kernel's checker and the interpreter running `cfmpa.check_path` (proved: ok = 1 iff
    the list is a repaired-Def-4 path with len >= N) agree on random databases and lists,
    including off-grid elements, jumps, and lists shorter than N."""
    rng = np.random.default_rng(seed)
    P = (rng.uniform(size=(N, m, n)) < density).astype(np.uint8)
    path = [(int(rng.integers(-1, m + 1)), int(rng.integers(-1, n + 1)))]
    for _ in range(length - 1):  # mostly king moves, sometimes a jump
        i, j = path[-1]
        step = rng.integers(-1, 2, size=2) * (3 if rng.uniform() < 0.1 else 1)
        path.append((int(i + step[0]), int(j + step[1])))
    start, goal = path[0], path[-1]
    if rng.uniform() < 0.2:
        goal = (int(rng.integers(m)), int(rng.integers(n)))
    assert check_path(P, path, start, goal)[0] == _interpret_check_path(P, path, start, goal)


def test_every_plan_passes_the_proved_model():
    """Every plan the planner returns on random 3 x 3 x 3 databases is accepted by the
    interpreter running `cfmpa.check_path`; moving its last element off the grid is not."""
    rng = np.random.default_rng(0)
    planned = 0
    for _ in range(60):
        P = (rng.uniform(size=(3, 3, 3)) < 0.3).astype(np.uint8)
        start, goal = [(int(rng.integers(3)), int(rng.integers(3))) for _ in range(2)]
        got = plan(P, start, goal)
        if got.ok:
            planned += 1
            assert _interpret_check_path(P, got.path, start, goal)
            bad = [*got.path[:-1], (got.path[-1][0], -1)]
            assert not _interpret_check_path(P, bad, start, goal)
    assert planned >= 20


# --------------------------------------------------------------------------- the extracted kernels


def test_shipped_kernels_are_fresh_extractions_of_their_models():
    """studies/dualarm/generated/builtdr.py and studies/dualarm/generated/check_path.py are byte-for-byte
    what `certiloop extract` makes of the proved models today, and carry the models' current hashes."""
    from certiloop.kernel.extract import shipped, shipped_drift
    from certiloop.models import library
    from certiloop.studies.dualarm.generated import builtdr as cfmpa_builtdr
    from certiloop.studies.dualarm.generated import check_path as cfmpa_check

    for name, module in (("cfmpa.builtdr", cfmpa_builtdr), ("cfmpa.check_path", cfmpa_check)):
        assert name in shipped()
        assert shipped_drift(name) == ""
        assert (module.MODEL, module.MODEL_HASH) == (name, library.get(name).content_hash)


def test_a_changed_model_is_refused_at_run_time(monkeypatch):
    import certiloop.studies.dualarm.pins as pins
    from certiloop.studies.dualarm.generated import check_path as cfmpa_check
    monkeypatch.setattr(cfmpa_check, "MODEL_HASH", "0000000000000000")
    monkeypatch.setattr(pins, "_checked", False)
    with pytest.raises(RuntimeError, match="older cfmpa.check_path.*certiloop.studies regenerate"):
        check_path(np.zeros((1, 2, 2), np.uint8), [(0, 0)], (0, 0), (0, 0))


def _interpret_builtdr(overlap: np.ndarray) -> np.ndarray:
    """P after running the proved model `cfmpa.builtdr` in the interpreter on this overlap array."""
    from certiloop.falsify.choosers import FirstEnabled
    from certiloop.falsify.evaluate import Table
    from certiloop.falsify.interpreter import Interpreter
    from certiloop.models import library

    N, m, n = overlap.shape
    cells = {key: bool(overlap[key]) for key in itertools.product(range(N), range(m), range(n))}
    state = {"N": N, "m": m, "n": n, "overlap": Table(cells, default=False), "P": Table({}, default=7)}
    run = Interpreter(library.get("cfmpa.builtdr"), exact=True).run(FirstEnabled(), initial=state)
    table = run.final["P"]
    return np.array([table.read(key) for key in itertools.product(range(N), range(m), range(n))]
                    ).reshape(N, m, n) if overlap.size else np.zeros(overlap.shape, int)


@settings(max_examples=200)
@given(st.integers(0, 4), st.integers(0, 4), st.integers(0, 4), st.floats(0, 1), st.integers(0, 2**32 - 1))
def test_extracted_builtdr_agrees_with_the_interpreter(N, m, n, density, seed):
    """The shipped builtDR and the interpreter running `cfmpa.builtdr` leave the same database
    on random overlap arrays (including empty grids), and it is the overlap predicate."""
    from certiloop.studies.dualarm.generated.builtdr import controller

    overlap = np.random.default_rng(seed).uniform(size=(N, m, n)) < density
    P, enabled = controller(N, m, n, overlap)
    assert enabled
    assert np.array_equal(P, _interpret_builtdr(overlap))
    assert np.array_equal(P, overlap.astype(int))  # independent of both: Theorem 1's post


def test_reference_database_is_filled_in_every_cell(r1_coarse):
    """dualarm.builtdr's database (filled by the extracted code) is 0/1 everywhere, with both
    values present on the reference scene."""
    P = r1_coarse[1]
    assert P.dtype == np.uint8 and set(np.unique(P)) <= {0, 1}
    assert 0 < P.sum() < P.size


@settings(max_examples=200)
@given(st.integers(1, 3), st.integers(1, 3), st.integers(1, 3), st.floats(0, 0.5), st.integers(0, 2**32 - 1),
       st.integers(0, 6))
def test_reasons_agree_with_the_extracted_verdict(N, m, n, density, seed, length):
    """The hand-written reason finder says "" exactly when the extracted checker accepts: a
    rejection always comes with its real defect, an acceptance never hides one."""
    from certiloop.studies.dualarm.planner import _why_not

    rng = np.random.default_rng(seed)
    P = (rng.uniform(size=(N, m, n)) < density).astype(np.uint8)
    path = [(int(rng.integers(-1, m + 1)), int(rng.integers(-1, n + 1))) for _ in range(length)]
    start = path[0] if path and rng.uniform() < 0.8 else (0, 0)
    goal = path[-1] if path and rng.uniform() < 0.8 else (0, 0)
    ok, why = check_path(P, path, start, goal)
    assert ok == (_why_not(P, path, start, goal) == "")
    assert ok == (why == "")
