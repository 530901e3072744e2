"""`certiloop extract` on every proved library model: the generated module imports and runs,
and its entry function computes what the model's own control step computes.

The oracle is the model itself: its control step run by the interpreter (first enabled
alternative, as the kernel; `Blocked` means the model has no run there, and then the code
must say so with enabled = False), and for the simple models also a value computed by hand.
States are built per model, inside each model's assumptions: hand-picked ones that hit
every alternative and the edges between them, plus seeded random ones.
"""

import math
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest

from certiloop.falsify.choosers import FirstEnabled
from certiloop.falsify.evaluate import Blocked, Compiler, Table
from certiloop.falsify.interpreter import Interpreter
from certiloop.kernel.extract import ExtractError, controller, extract
from certiloop.models import library
from certiloop.models.lang.conveniences import if_
from certiloop.models.lang.programs import ODE, Havoc, assign, branch, choice, havoc, loop, ode, seq
from certiloop.models.lang.programs import test as check
from certiloop.models.lang.terms import TRUE, And, Reals
from certiloop.models.lang.theorem import Theorem

PROVED = ["sbs.ctrl1", "sbs.predictive", "sbs.ctrl2_2d", "sbs.ctrl2", "sbs.ctrl2_dynamic", "cfmpa.builtdr",
          "textbook.bouncing_ball", "textbook.train", "textbook.water_tank", "textbook.cart_forward"]
# same tolerance as tests/studies/sbs/test_kernel.py: the generated code evaluates the model's own terms
# (a pinned x·A = B as B/A, a pinned x²·A = B as sqrt(B/A)), the interpreter too
REL, ABS = 1e-9, 1e-12
_MODULES: dict[str, dict] = {}


def module(name: str) -> dict:
    """The generated module of a library model, executed."""
    if name not in _MODULES:
        namespace: dict = {}
        exec(compile(extract(library.get(name)), f"<extracted {name}>", "exec"), namespace)
        _MODULES[name] = namespace
    return _MODULES[name]


def step_theorem(name: str, drop: tuple[str, ...] = ()) -> Theorem:
    """The model's control step as a program of its own, without the statements that
    choose its inputs (the test gives them in the state)."""
    t = library.get(name)
    program = controller(t, inputs=False)
    if drop:
        parts = program.parts if hasattr(program, "parts") else (program,)
        program = seq(*[q for q in parts if not (isinstance(q, Havoc) and q.target.payload in drop)])
    return Theorem(f"{name}.step", t.assumptions, program, TRUE)


class Known(FirstEnabled):
    """The kernel's policy (first enabled alternative), with values for `x := *` that no
    linear equation pins down (the interpreter solves only linear ones)."""

    def __init__(self, values: dict) -> None:
        self.values = values

    def havoc_value(self, target):
        return self.values.get(target)


TAKEN: list[tuple[str, ...]] = []  # the alternatives of the last run_step's run


def run_step(theorem: Theorem, state: dict, chooser=None) -> dict | None:
    """The final state of the model's step from `state`, or None if the model has no run."""
    try:
        run = Interpreter(theorem).run(chooser or FirstEnabled(), dict(state), checked=True)
    except Blocked:
        return None
    TAKEN[:] = [tuple(c.choices) for c in run.checkpoints]
    return run.final


def call(name: str, values: dict):
    ns = module(name)
    args = [values[p] for p in ns["INPUTS"] + ns["FAMILIES"]]
    return ns["controller"](*args)


def agree(got, want) -> bool:
    return got == pytest.approx(want, rel=REL, abs=ABS)


def check_scalar(name: str, state: dict, outputs: list[str], chooser=None, step=None) -> tuple:
    """The generated function against the interpreter's run of the model's step."""
    final = run_step(step or step_theorem(name), state, chooser)
    *values, enabled = call(name, state)
    if final is None:
        assert enabled is False, f"{name}: the model has no run from {state}, the code says it has"
        return None, enabled
    assert enabled is True, f"{name}: the model has a run from {state}, the code says none"
    for out, value in zip(outputs, values):
        assert math.isfinite(value), f"{name}: {out} = {value} for finite inputs"
        assert agree(value, float(final[out])), f"{name}: {out} = {value}, the model gives {final[out]}"
    return tuple(values), enabled


rng = np.random.default_rng(20240611)


# ------------------------------------------------------------------ every model, generically


@pytest.mark.parametrize("name", PROVED)
def test_header_and_entry_function(name):
    t = library.get(name)
    ns = module(name)
    assert (ns["MODEL"], ns["MODEL_HASH"]) == (name, t.content_hash)
    import inspect

    fn = ns["controller"]
    assert list(inspect.signature(fn).parameters) == ns["INPUTS"] + ns["FAMILIES"]
    assert fn.__doc__ and ("enabled" in fn.__doc__ or "whether the model has a run" in fn.__doc__)
    src = extract(t)
    assert src == extract(t), "extraction is deterministic"
    assert src.count("\ndef controller(") == 1
    # the float-sound helpers of a vectorised step (its filtered pass and its exact pass), or
    # the one pass of a scalar step that its entry runs with each number kit
    assert src.count("\ndef ") in (2, 3)


def test_generated_modules_import_only_numpy(tmp_path):
    """numpy, the standard library and the runtime kernel's float-sound helpers
    (certiloop.kernel.filtered): no prover, no test library, nothing of the tooling."""
    for name in PROVED:
        (tmp_path / f"m_{name.replace('.', '_')}.py").write_text(extract(library.get(name)))
    code = ("import importlib, sys; sys.path.insert(0, %r); "
            "[importlib.import_module(m) for m in %r]; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('z3', 'sympy', 'hypothesis', "
            "'scipy') or (m.startswith('certiloop.') and m.split('.')[1] != 'kernel')))"
            % (str(tmp_path), [f"m_{n.replace('.', '_')}" for n in PROVED]))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


# ------------------------------------------------------------------ scalar controllers


def test_train():
    A, b, m, eps = 1.0, 2.0, 100.0, 0.5
    states = [(0.0, 0.0), (m, 0.0), (90.0, 5.0), (99.0, 1.0), (50.0, 10.0)]
    states += [(p, v) for p, v in zip(rng.uniform(-50, 100, 60), rng.uniform(0, 20, 60))]
    seen = set()
    for p, vt in states:
        if vt * vt > 2 * b * (m - p):
            continue  # outside the assumptions
        state = {"p": p, "vt": vt, "A": A, "b": b, "m": m, "eps": eps}
        (a,), _ = check_scalar("textbook.train", state, ["a"])
        brake = m - p <= vt**2 / (2 * b) + (A / b + 1) * (A / 2 * eps**2 + eps * vt)
        assert a == (-b if brake else A)  # by hand
        seen.add(a)
    assert seen == {-b, A}


def test_water_tank():
    r, eps, lo, hi = 1.0, 0.5, 0.0, 10.0
    cases = {0.0: r, 9.5: r, 9.6: -r, 10.0: -r, 5.0: r}  # by hand: fill, else drain, else hold
    for x, want in cases.items():
        (f,), _ = check_scalar("textbook.water_tank", {"x": x, "r": r, "eps": eps, "lo": lo, "hi": hi}, ["f"])
        assert f == want
    # a tank narrower than one period's flow: neither fill nor drain, so hold
    narrow = {"x": 0.2, "r": 1.0, "eps": 0.5, "lo": 0.0, "hi": 0.4}
    (f,), _ = check_scalar("textbook.water_tank", narrow, ["f"])
    assert f == 0.0
    for x in rng.uniform(lo, hi, 40):
        check_scalar("textbook.water_tank", {"x": x, "r": r, "eps": eps, "lo": lo, "hi": hi}, ["f"])


def test_cart_forward_admits_only_forward_acceleration():
    for acc in [0.0, 2.5, 1e-300, 7.0]:
        (got,), enabled = check_scalar("textbook.cart_forward", {"acc": acc}, ["acc"])
        assert (got, enabled) == (acc, True)
    for acc in [-1.0, -1e-300]:
        got, enabled = call("textbook.cart_forward", {"acc": acc})
        assert enabled is False and run_step(step_theorem("textbook.cart_forward"), {"acc": acc}) is None


def test_bouncing_ball_discrete_step_after_the_flight():
    g, H = 9.81, 5.0
    for h, v, c in [(0.0, -3.0, 0.8), (0.0, -9.9, 1.0), (0.0, 0.0, 0.0), (2.0, -3.0, 0.8), (H, 0.0, 0.5),
                    (1.0, 4.0, 1.0)]:
        state = {"h": h, "v": v, "c": c, "g": g, "H": H}
        (got,), _ = check_scalar("textbook.bouncing_ball", state, ["v"])
        # by hand: bounce on the ground only; a real output is a float <= its real value, within a
        # few ulps
        want = -Fraction(c) * Fraction(v) if h == 0 else Fraction(v)
        assert Fraction(got) <= want and got == pytest.approx(float(want), rel=1e-14, abs=0)
    for h, c in zip(rng.uniform(0, H, 30), rng.uniform(0, 1, 30)):
        v = -math.sqrt(2 * g * (H - h)) * rng.uniform(0, 1)  # within the energy invariant
        check_scalar("textbook.bouncing_ball", {"h": h, "v": v, "c": c, "g": g, "H": H}, ["v"])


def _ctrl1_expected(state):
    """The rates of the mode the interpreter runs (first enabled domain), from the model's
    own ODE right-hand sides."""
    t = library.get("sbs.ctrl1")
    run = Interpreter(step_theorem("sbs.ctrl1")).run(FirstEnabled(), dict(state), checked=True)
    label = run.checkpoints[-1].choices[0]
    modes = t.program.body.parts[-1]
    ode_ = modes.alternatives[modes.labels.index(label)]
    assert isinstance(ode_, ODE)
    c = Compiler()
    return label, {v.payload: c(f)(state) for v, f in ode_.eqs}


def test_ctrl1_picks_the_first_mode_whose_domain_holds():
    G, D = 2.0, 1.0
    labels = set()
    cases = [(py, fy) for py in (0.0, 0.5, D, 3.0) for fy in (-1.5, 0.0, 2.0)]
    cases += list(zip(rng.uniform(0, 3, 40), rng.uniform(-3, 3, 40)))
    for py, fy in cases:
        state = {"px": 0.3, "py": py, "fx": 0.7, "fy": fy, "fxp": 0.1, "fyp": -0.2, "G": G, "D": D}
        label, rates = _ctrl1_expected(state)
        px_dot, py_dot, enabled = call("sbs.ctrl1", state)
        assert enabled is True
        assert agree(px_dot, rates["px"]) and agree(py_dot, rates["py"]), (state, label)
        # by hand: full speed outside the slow zone or away from the boundary, scaled by py/D towards it
        towards = 0 <= py <= D and fy <= 0 and not py >= D
        assert agree(py_dot, G * py / D * fy if towards else G * fy)
        labels.add(label)
    assert labels == {"free zone", "slow zone, towards", "slow zone, away"}
    # past the boundary (outside the assumptions, but the model still has runs): stopped
    assert call("sbs.ctrl1", {"py": -0.5, "fx": 1.0, "fy": -1.0, "G": G, "D": D}) == (0.0, 0.0, True)


def _predictive_state(p, r, n, f, fp, G, e):
    state = {"px": p[0], "py": p[1], "rx": r[0], "ry": r[1], "nx": n[0], "ny": n[1], "fx": f[0], "fy": f[1],
             "fxp": fp[0], "fyp": fp[1], "G": G, "e": e}
    F = Fraction
    d0 = (F(p[0]) - F(r[0])) * F(n[0]) + (F(p[1]) - F(r[1])) * F(n[1])
    fnp = F(fp[0]) * F(n[0]) + F(fp[1]) * F(n[1])
    # the interpreter solves linear pins only: the root of root²·G = 2·d0·fnp is given, from the
    # exact radicand (d0 in floats may cancel to a few correct digits)
    q = 2 * d0 * fnp / F(G)
    return state, Known({"root": math.isqrt(q.numerator * 4 ** 80 // q.denominator) / 2.0 ** 80}
                        if q >= 0 else {})


def test_predictive():
    n = (0.0, 1.0)
    hand = {  # (d0, fn, fnp, G, e): the alternative by hand
        (1.0, 1.0, 1.0, 1.0, 1.0): 0.0,  # a away
        (5.0, -1.0, 1.0, 1.0, 1.0): 0.0,  # b turns before the plane (disc < 0)
        (3.0, -1.0, 0.0, 1.0, 1.0): 0.0,  # d: fnp = 0, clear at the end
        (0.5, -1.0, -1.0, 1.0, 1.0): -1.0 + (0.5 - 0.5),  # e: k = fn + (d0 + G fnp e²/2)/(G e)
        (0.2, -1.0, 2.0, 1.0, 1.0): -1.0 - math.sqrt(0.8),  # f: k = fn - sqrt(2 d0 fnp / G)
        (1.0, -2.0, 1.0, 1.0, 1.0): -0.5,  # g2: k = kt
        (0.0, 0.0, 0.0, 1.0, 1.0): 0.0,  # on the plane, at rest
    }
    for (d0, fn, fnp, G, e), want in hand.items():
        state, chooser = _predictive_state((0.0, d0), (0.0, 0.0), n, (0.0, fn), (0.0, fnp), G, e)
        (k,), _ = check_scalar("sbs.predictive", state, ["k"], chooser)
        assert agree(k, want), ((d0, fn, fnp), k, want)
    blocked, taken = 0, set()
    for _ in range(300):
        angle = rng.uniform(0, 2 * math.pi)
        n = (math.cos(angle), math.sin(angle))
        r = tuple(rng.uniform(-2, 2, 2))
        d0 = rng.choice([0.0, rng.uniform(0, 3)])
        u = rng.uniform(-1, 1)  # along the plane
        p = (r[0] + d0 * n[0] - u * n[1], r[1] + d0 * n[1] + u * n[0])
        nudge = 1e-16
        # rounding: back inside the assumptions (in the reals: the code decides as the real model)
        while sum((Fraction(p[a]) - Fraction(r[a])) * Fraction(n[a]) for a in range(2)) < 0:
            p, nudge = (p[0] + nudge * n[0], p[1] + nudge * n[1]), 2 * nudge
        f = tuple(rng.choice([0.0, rng.uniform(-3, 3)]) for _ in range(2))
        fp = tuple(rng.choice([0.0, rng.uniform(-3, 3)]) for _ in range(2))
        G, e = rng.uniform(0.1, 3), rng.uniform(0.01, 2)
        state, chooser = _predictive_state(p, r, n, f, fp, G, e)
        _, enabled = check_scalar("sbs.predictive", state, ["k"], chooser)
        blocked += not enabled
        taken.update(label.split()[0] for label in TAKEN[-1])
    assert blocked == 0  # the model's cases cover every state the assumptions allow
    assert taken >= {"a", "b", "c", "d", "e", "f", "g", "g1"}  # the quadratic roots included


# ------------------------------------------------------------------ controllers over families


def _ctrl2_state(p, f, fp, points, normals, G, D, e, dims="xyz"):
    m = len(points)
    state = {"#universe:B": range(m), "G": G, "D": D, "e": e}
    values = {"G": G, "D": D, "e": e}
    for a, x in enumerate(dims):
        state[f"p{x}"] = values[f"p{x}"] = p[a]
        state[f"f{x}"] = values[f"f{x}"] = f[a]
        state[f"f{x}p"] = values[f"f{x}p"] = fp[a]
        values[f"n{x}"] = np.array([float(nv[a]) for nv in normals])
        values[f"r{x}"] = np.array([float(pt[a]) for pt in points])
        state[f"n{x}"] = Table({(j,): float(normals[j][a]) for j in range(m)})
        state[f"r{x}"] = Table({(j,): float(points[j][a]) for j in range(m)})
    return state, values


def _scene(dim, m):
    p = rng.uniform(-3, 3, dim)
    normals = [v / np.linalg.norm(v) for v in rng.normal(size=(m, dim))]
    if m > 1 and rng.random() < 0.3:
        normals[1] = normals[0]  # duplicate planes
    dists = [rng.choice([0.0, rng.uniform(0, 3)]) for _ in range(m)]  # 0: the tool on the plane
    points = [p - d * nv for d, nv in zip(dists, normals)]
    f = rng.choice([np.zeros(dim), rng.uniform(-3, 3, dim)])
    fp = rng.choice([np.zeros(dim), rng.uniform(-3, 3, dim)])
    G, D, e = rng.uniform(0.1, 3, 3)
    return p, f, fp, points, normals, G, D, e


@pytest.mark.parametrize("name,dims", [("sbs.ctrl2_2d", "xy"), ("sbs.ctrl2", "xyz")])
def test_ctrl2_family_gain_equals_the_model(name, dims):
    step = step_theorem(name)
    for _ in range(60):
        state, values = _ctrl2_state(*_scene(len(dims), int(rng.integers(1, 8))), dims=dims)
        final = run_step(step, state)
        k, enabled = call(name, values)
        if final is None:
            assert enabled is False
            continue
        assert enabled is True and math.isfinite(k) and 0 <= k <= 1
        assert agree(float(k), float(final["k"]))


def test_ctrl2_dynamic_activation_and_gain():
    name = "sbs.ctrl2_dynamic"
    step = step_theorem(name, drop=("active_next",))  # the requested set is the test's input
    outcomes = set()
    for trial in range(80):
        p, f, fp, points, normals, G, D, e = _scene(3, int(rng.integers(1, 7)))
        m = len(points)
        active = rng.random(m) < 0.6
        if trial % 4 == 0:  # an inactive boundary the tool is already past
            points[0] = p + 0.5 * normals[0]
            active[0] = False
        active_next = active.copy() if trial % 3 else rng.random(m) < 0.5
        state, values = _ctrl2_state(p, f, fp, points, normals, G, D, e)
        state["active"] = Table({(j,): bool(active[j]) for j in range(m)})
        state["active_next"] = Table({(j,): bool(active_next[j]) for j in range(m)})
        values["active"], values["active_next"] = active, active_next
        final = run_step(step, state)
        k, new_active, enabled = call(name, values)
        if final is None:
            assert enabled is False
            outcomes.add("refused")
            continue
        assert enabled is True and math.isfinite(k) and 0 <= k <= 1
        assert agree(float(k), float(final["k"]))
        assert new_active.tolist() == [bool(final["active"].read((j,))) for j in range(m)]
        assert new_active.tolist() == active_next.tolist()
        outcomes.add("ran")
    assert outcomes == {"ran", "refused"}
    # by hand: activating a boundary the tool is past is refused; deactivating it is fine
    p, normals, points = np.zeros(3), [np.array([0, 0, 1.0])], [np.array([0, 0, 1.0])]
    _, values = _ctrl2_state(p, np.zeros(3), np.zeros(3), points, normals, 1.0, 1.0, 0.1)
    values["active"], values["active_next"] = np.array([False]), np.array([True])
    assert call(name, values)[-1] is False
    values["active_next"] = np.array([False])
    assert call(name, values) == (1.0, pytest.approx([False]), True)


# ------------------------------------------------------------------ an algorithm (Hoare triple)


def test_builtdr_fills_the_state_database():
    name = "cfmpa.builtdr"
    step = step_theorem(name)
    for N, m, n in [(0, 0, 0), (1, 1, 1), (2, 3, 4), (3, 0, 2), (1, 4, 1)]:
        overlap = rng.random((N, m, n)) < 0.5
        P, enabled = call(name, {"N": N, "m": m, "n": n, "overlap": overlap})
        assert enabled is True and P.shape == (N, m, n)
        assert P.tolist() == overlap.astype(int).tolist()  # by hand: the guarantee
        cells = Table({idx: bool(v) for idx, v in np.ndenumerate(overlap)})
        state = {"N": N, "m": m, "n": n, "overlap": cells}
        final = run_step(step, state)
        for idx, v in np.ndenumerate(P):
            assert final["P"].read(idx) == v
    # a larger overlap array is fine: the algorithm reads only [0, N) x [0, m) x [0, n)
    P, enabled = call(name, {"N": 1, "m": 1, "n": 2, "overlap": np.ones((2, 2, 3), dtype=bool)})
    assert P.tolist() == [[[1, 1]]] and enabled


# ------------------------------------------------------------------ what is refused, and why


x, y, z, G = Reals("x y z G")


def _refused(program, match: str, assumptions=TRUE, guarantee=None):
    t = Theorem("tests.shape", assumptions, program, guarantee if guarantee is not None else x >= 0)
    with pytest.raises(ExtractError, match=match) as info:
        extract(t)
    message = str(info.value)
    assert "\n" not in message and message.startswith("tests.shape: ")
    return message


def test_unsupported_shapes_are_refused_with_one_line_reasons():
    plant = ode({x: y})
    # a nondeterministic value nothing pins down or checks, read later
    msg = _refused(loop(seq(choice(branch("a", havoc(y)), branch("b", assign(y, 1))), plant)),
                   "never pinned down but read later")
    assert "`" in msg
    # a new value for y after the step set it: the caller's y is not that value
    _refused(loop(seq(assign(y, 2), choice(branch("a", havoc(y), check(y >= 0)), branch("b", assign(y, 1))),
                      plant)), "must be pinned by an equation")
    # a cubic equation
    _refused(loop(seq(choice(branch("a", havoc(y), check(y**3 == x)), branch("b", assign(y, 0))), plant)),
             "degree 3")
    # discrete statements on both sides of the plant
    _refused(loop(seq(assign(y, 1), plant, assign(y, 2))), "both before and after")
    # the plant ODE inside an if
    _refused(loop(seq(if_(x >= 0, plant, assign(y, 0)))), "nested in this statement")
    # a discrete loop with no plant and no exit test
    _refused(loop(assign(x, x + 1)), "repeats any number of times")
    # a step that computes nothing the plant, the invariant or the guarantee reads
    _refused(loop(seq(assign(z, 1), ode({x: G}))), "computes nothing")
    # a quadratic pin outside a choice: which root depends on what follows
    _refused(loop(seq(havoc(y), check(And(y * y == x)), ode({x: y}))), "quadratic")


def test_library_shapes_that_are_refused():
    with pytest.raises(ExtractError, match="last one wins") as info:
        extract(library.get("sbs.ctrl2_last_wins"))
    assert "\n" not in str(info.value)


def test_whether_the_model_is_proved_is_not_extracts_business():
    """extract() is a syntactic translation: it does not look at `expected` (the CLI refuses
    unproved models before calling it). A refuted model of a supported shape extracts, and
    its code shows the flaw the refutation found."""
    t = library.get("textbook.train_no_lookahead")
    assert t.expected == "refuted"
    ns: dict = {}
    exec(compile(extract(t), "<refuted>", "exec"), ns)
    # one period of full acceleration from just outside the (too short) brake zone overruns m
    A, b, m, eps = 1.0, 1.0, 10.0, 1.0
    vt = 2.0
    p = m - vt**2 / (2 * b) - 1e-6
    values = {"m": m, "p": p, "vt": vt, "b": b, "A": A, "eps": eps}
    a, enabled = ns["controller"](*[values[v] for v in ns["INPUTS"]])
    assert (a, enabled) == (A, True)
    assert vt**2 + 2 * A * eps * vt > 2 * b * (m - p)  # the stopping distance no longer fits
