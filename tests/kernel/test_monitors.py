"""ModelPlex-style monitors generated from the models (issue 19, item 3;
certiloop/kernel/extract/modelplex.py).

Controller monitor, checked against an independent oracle: the model's control step run by the
interpreter (certiloop.falsify) in exact rationals (floats where a square root is pinned), every
run of it — every order of every choice, enumerated by a
scripted chooser — with the nondeterministic values of the outputs fixed by the command. A
command some run ends on (within 1e-9) must pass; a command every run misses by more than 1e-5
must fail. The commands are the extracted controller's, every run's, and mutations of them
(each output moved by small and large amounts: k beyond the bound of sbs.ctrl2, a wrong
acceleration, a force past saturation ...). For the switched plant of sbs.ctrl1 the oracle is
every mode whose domain holds (the interpreter's compiler evaluates domain and rates); for a
step over several boundaries (sbs.ctrl2) it is the model's `k := min(k, kt)` over the values
the interpreter finds at each boundary alone.

Plant monitor: a trajectory integrated by scipy's solve_ivp (not the monitor's closed form or
enclosure) from a state the controller leaves is accepted; the same end state moved by 1e-2 in
one evolved variable is rejected.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from certiloop.falsify.evaluate import Blocked, Compiler, Table
from certiloop.falsify.interpreter import Interpreter
from certiloop.kernel.extract import ExtractError
from certiloop.kernel.extract.modelplex import monitors
from certiloop.models import library
from certiloop.models.lang.programs import ODE
from certiloop.models.lang.terms import ModelError
from kernel.test_extract import (
    Known,
    _ctrl2_state,
    _predictive_state,
    _scene,
    call,
    step_theorem,
)
from kernel.test_extract_coverage import stop_3d_scene

CLOSE, FAR, TOL = 1e-9, 1e-5, 1e-7
SQRT_PINS = {"sbs.predictive", "raven.haptic_force"}  # roots of x*x = q: the oracle runs in floats
DELTAS = (1e-3, -1e-3, 0.1, -0.1, 1.0, -1.0)
SEED = 1919
rng = np.random.default_rng(SEED)


@pytest.fixture(autouse=True)
def _same_draws_in_any_order():
    """Every test draws from the seed's start, whatever ran before it (the tiers, -k and -m
    change which tests run first; a free-command test's count of accepted runs follows the draws)."""
    rng.bit_generator.state = np.random.default_rng(SEED).bit_generator.state
_NS: dict[str, dict] = {}


def mon(name: str) -> dict:
    if name not in _NS:
        ns: dict = {}
        exec(compile(monitors(library.get(name)), f"<monitors {name}>", "exec"), ns)
        _NS[name] = ns
    return _NS[name]


class Script(Known):
    """First enabled, except that the k-th choice met starts at script[k]; records how many
    alternatives each choice had, so that every order can be enumerated."""

    def __init__(self, values: dict, script: list[int]) -> None:
        super().__init__(values)
        self.script, self.made = script, []

    def pick_label(self, labels):
        k = len(self.made)
        self.made.append(len(labels))
        return self.script[k] if k < len(self.script) else 0


def all_finals(theorem, state: dict, values: dict, limit: int = 20000, exact: bool = True) -> list[dict]:
    """The final states of every run of theorem's program from state (the interpreter, in exact
    rationals unless a value it is given is an irrational root known only as a float)."""
    finals, todo, count = [], [[]], 0
    interpreter = Interpreter(theorem, exact=exact)  # one for all runs: its compiled terms are reused
    while todo:
        script = todo.pop()
        chooser = Script(values, script)
        try:
            finals.append(interpreter.run(chooser, dict(state), checked=True).final)
        except Blocked:
            pass
        for p in range(len(script), len(chooser.made)):
            prefix = script + [0] * (p - len(script))
            todo.extend(prefix + [c] for c in range(1, chooser.made[p]))
        count += 1
        assert count < limit, "too many runs to enumerate"
    return finals


def distance(final: dict, command: dict) -> float:
    worst = 0.0
    for k, want in command.items():
        gap = abs(float(final[k]) - float(want))
        worst = math.inf if math.isnan(gap) else max(worst, gap)
    return worst


# ------------------------------------------------------------------ states per model


def _scalar_states(name: str):
    """(state, known values for the interpreter) inside the model's assumptions."""
    for _ in range(8):
        if name == "textbook.train":
            A, b, m, eps = 1.0, 2.0, 100.0, 0.5
            vt = rng.uniform(0, 20)
            p = m - vt**2 / (2 * b) - rng.choice([0.0, rng.uniform(0, 30)])
            yield {"p": p, "vt": vt, "A": A, "b": b, "m": m, "eps": eps}, {}
        elif name == "textbook.water_tank":
            yield {"x": rng.uniform(0, 10), "r": 1.0, "eps": 0.5, "lo": 0.0, "hi": 10.0}, {}
        elif name == "textbook.cart_forward":
            yield {}, {}
        elif name == "textbook.bouncing_ball":
            h = rng.choice([0.0, rng.uniform(0, 5)])
            v = -math.sqrt(2 * 9.81 * (5 - h)) * rng.uniform(0, 1)
            yield {"h": h, "v": v, "c": rng.uniform(0, 1), "g": 9.81, "H": 5.0}, {}
        elif name == "sbs.predictive":
            angle = rng.uniform(0, 2 * math.pi)
            n = (math.cos(angle), math.sin(angle))
            d0 = rng.choice([0.0, rng.uniform(0, 3)])
            p = (d0 * n[0], d0 * n[1])
            f, fp = tuple(rng.uniform(-3, 3, 2)), tuple(rng.uniform(-3, 3, 2))
            G, e = rng.uniform(0.1, 3), rng.uniform(0.01, 2)
            state, chooser = _predictive_state(p, (0.0, 0.0), n, f, fp, G, e)
            yield state, chooser.values
        elif name == "rcm.axial_guard":
            m, eps = rng.uniform(0.001, 0.01), rng.uniform(0.001, 0.1)
            gap = m + rng.choice([0.0, rng.uniform(0, 0.02)])
            yield {"gap": gap, "m": m, "eps": eps, "wcmd": rng.uniform(-1, 1)}, {}
        elif name == "rcm.barrier_continuous":
            yield {}, {}
        elif name == "rcm.damping_bounds":
            yield dict(zip(["ev1", "er1", "ev2", "er2"], rng.uniform(1e-6, 1, 4))), {}
        elif name == "rcm.decoupling":
            A1, A2 = rng.normal(size=2)
            W1, W2 = rng.uniform(0.1, 5, 2)
            yield {"A1": A1, "A2": A2, "W1": W1, "W2": W2, "Z1": -A2, "Z2": A1}, {}
        elif name == "rcm.nullspace":
            n = rng.normal(size=3)
            vecs = [v - (v @ n) / (n @ n) * n for v in rng.normal(size=(2, 3))]
            r = rng.normal(size=3)
            yield {f"{s}{i + 1}": float(x[i]) for s, x in (("a", vecs[0]), ("o", vecs[1]), ("n", n), ("r", r))
                   for i in range(3)}, {}
        elif name == "raven.deviation_stop":
            tol, U, eps = rng.uniform(1e-3, 5e-3), rng.uniform(0, 0.05), rng.uniform(1e-3, 0.02)
            m = tol + U * eps + rng.choice([0.0, 0.01])
            dm = m + rng.choice([0.0, rng.uniform(0, 0.02)])
            dr = max(0.0, dm + rng.uniform(-2 * tol, 2 * tol))
            yield {"tol": tol, "U": U, "eps": eps, "m": m, "dm": dm, "dr": dr,
                   "stopped": float(rng.choice([0.0, 1.0], p=[0.8, 0.2]))}, {}
        elif name == "raven.haptic_force":
            tol = rng.uniform(1e-3, 5e-3)
            dp = rng.normal(size=3) * rng.choice([tol / 4, 3 * tol])
            dv = rng.normal(size=3) * rng.choice([0.0, 0.01])
            state = {"tol": tol, "Kp": rng.uniform(0, 500), "Kd": rng.uniform(0, 10),
                     "Fsat": rng.uniform(0.5, 3),
                     **{f"dp{x}": dp[i] for i, x in enumerate("xyz")},
                     **{f"dv{x}": dv[i] for i, x in enumerate("xyz")}}
            yield state, {"nrm": math.sqrt(float(dp @ dp)), "nv": math.sqrt(float(dv @ dv))}
        elif name == "raven.deviation_stop_3d":
            yield stop_3d_scene(int(rng.integers(0, 4)))[0], {}
        else:
            raise AssertionError(name)


def _interpreter_state(state: dict) -> dict:
    """The interpreter's form of a state: families (numpy arrays) as Tables with a universe."""
    arrays = {k: v for k, v in state.items() if isinstance(v, np.ndarray)}
    if not arrays:
        return state
    m = len(next(iter(arrays.values())))
    return {**state, **{k: Table({(j,): float(x) for j, x in enumerate(v)}) for k, v in arrays.items()},
            "#universe:B": range(m)}


SCALAR = ["textbook.train", "textbook.water_tank", "textbook.cart_forward", "textbook.bouncing_ball",
          "sbs.predictive", "rcm.axial_guard", "rcm.barrier_continuous", "rcm.damping_bounds",
          "rcm.decoupling", "rcm.nullspace", "raven.deviation_stop", "raven.deviation_stop_3d",
          "raven.haptic_force"]
# a command the controller does not fix: drawn (the state holds the rest)
FREE = {"textbook.cart_forward": {"acc": (-2, 5)}, "rcm.barrier_continuous": {"dmp": (-2, 5)},
        "raven.deviation_stop": {"v": (-1, 1), "u": (-0.05, 0.05)},
        "raven.deviation_stop_3d": {**{f"v{x}": (-0.02, 0.02) for x in "xyz"},
                                    **{f"u{x}": (-0.03, 0.03) for x in "xyz"}}}


def _commands(name: str, state: dict, ns: dict):
    """The extracted controller's command (where it has one), drawn free commands."""
    out = []
    if name not in FREE:
        *values, enabled = call(name, state)
        if enabled:
            out.append(dict(zip(ns["COMMAND"], map(float, values))))
    else:
        for _ in range(3):
            cmd = {k: float(rng.uniform(*FREE[name][k])) if k in FREE[name] else None for k in ns["COMMAND"]}
            if any(v is None for v in cmd.values()):  # deviation_stop's latch: the controller's, else kept
                *values, enabled = call(name, {**state, **{k: v for k, v in cmd.items() if v is not None}})
                cmd.update({k: float(v) if enabled else float(state[k])
                            for k, v in zip(ns["COMMAND"], values) if cmd[k] is None})
            out.append(cmd)
    return out


def _oracle(name: str, state: dict, known: dict, command: dict) -> float:
    """How far the command is from the nearest run of the model's step (the interpreter)."""
    ns = mon(name)
    havocs = {k: v for k, v in command.items()}  # `o := *` of an output: the command fixes it
    start = _interpreter_state({**{k: v for k, v in command.items() if k not in ns["STATE"]}, **state})
    finals = all_finals(step_theorem(name), start, {**havocs, **known}, exact=name not in SQRT_PINS)
    return min((distance(f, command) for f in finals), default=math.inf)


@pytest.mark.parametrize("name", SCALAR)
def test_controller_monitor_agrees_with_every_run_of_the_model(name):
    ns = mon(name)
    checked = {"accepted": 0, "rejected": 0}
    for state, known in _scalar_states(name):
        for command in _commands(name, state, ns):
            moved = [str(o) for o in rng.permutation(ns["COMMAND"])[:3]]  # at most 3 outputs per command
            candidates = [command] + [{**command, o: command[o] + d * (1 + abs(command[o]))}
                                      for o in moved for d in DELTAS]
            for cmd in candidates:
                gap = _oracle(name, state, known, cmd)
                got = ns["controller_monitor"](state, cmd, TOL)
                if gap <= CLOSE:
                    assert got is True, f"{name}: a run ends on {cmd} from {state}; the monitor says no"
                    checked["accepted"] += 1
                elif gap > FAR:
                    assert got is False, f"{name}: no run near {cmd} (by {gap}) from {state}; monitor: yes"
                    checked["rejected"] += 1
    assert checked["accepted"] >= 5 and checked["rejected"] >= 30, checked


def test_controller_monitor_exact_for_the_controllers_own_command():
    """tol = 0: what the extracted controller returns passes bit for bit."""
    for name in SCALAR:
        if name in FREE:
            continue
        ns = mon(name)
        for state, _ in _scalar_states(name):
            *values, enabled = call(name, state)
            if enabled:
                assert ns["controller_monitor"](state, dict(zip(ns["COMMAND"], values))) is True, name


def test_train_monitor_rejects_acceleration_in_the_brake_zone():
    ns = mon("textbook.train")
    A, b, m, eps = 1.0, 2.0, 100.0, 0.5
    state = {"p": 99.0, "vt": 1.0, "A": A, "b": b, "m": m, "eps": eps}  # well inside the brake zone
    assert ns["controller_monitor"](state, {"a": -b}) is True
    assert ns["controller_monitor"](state, {"a": A}) is False
    assert ns["controller_monitor"](state, {"a": float("nan")}) is False
    assert ns["controller_monitor"](state, {"a": -b + 1e-6}, tol=1e-5) is True
    assert ns["controller_monitor"](state, {"a": -b}, tol=-1.0) is False


def test_switched_plant_monitor_sbs_ctrl1():
    """The command is the rates; the oracle: every mode whose domain holds (interpreter's compiler)."""
    name = "sbs.ctrl1"
    ns = mon(name)
    t = library.get(name)
    modes = t.program.body.parts[-1]
    c = Compiler()
    hits = 0
    for _ in range(80):
        py = float(rng.choice([0.0, 1.0, rng.uniform(0, 3)]))
        fy = float(rng.choice([0.0, rng.uniform(-3, 3)]))
        state = {"px": 0.3, "py": py, "fx": rng.uniform(-3, 3), "fy": fy, "fxp": 0.1, "fyp": -0.2, "G": 2.0,
                 "D": 1.0}
        allowed = []
        for ode_ in modes.alternatives:
            assert isinstance(ode_, ODE)
            if c(ode_.domain)(state):
                rhs = {v.payload: c(f)(state) for v, f in ode_.eqs}
                allowed.append({"px_dot": rhs["px"], "py_dot": rhs["py"]})
        for cmd in allowed:
            assert ns["controller_monitor"](state, cmd, TOL) is True
            hits += 1
        for cmd in allowed:
            for d in DELTAS:
                moved = {**cmd, "py_dot": cmd["py_dot"] + d}
                if all(max(abs(moved[k] - a[k]) for k in a) > FAR for a in allowed):
                    assert ns["controller_monitor"](state, moved, TOL) is False
    assert hits >= 80


# ------------------------------------------------------------------ steps over a family of boundaries


def _boundary_values(name, state_one):
    """The values kt takes at one boundary alone: every run of the step with one boundary."""
    return {float(f["k"]) for f in all_finals(step_theorem(name), state_one, {})}


@pytest.mark.parametrize("name,dims", [("sbs.ctrl2_2d", "xy"), ("sbs.ctrl2", "xyz")])
def test_family_monitor_k_beyond_the_bound_fails(name, dims):
    ns = mon(name)
    beyond = 0
    for trial in range(8):
        m = 1 + trial % 3
        p, f, fp, points, normals, G, D, e = _scene(len(dims), m)
        state, values = _ctrl2_state(p, f, fp, points, normals, G, D, e, dims=dims)
        # the oracle: at each boundary alone, every value the interpreter finds; k = min(1, one per boundary)
        per = [_boundary_values(name, _ctrl2_state(p, f, fp, [points[j]], [normals[j]], G, D, e,
                                                   dims=dims)[0]) for j in range(m)]
        if any(not s for s in per):
            continue  # some boundary has no run: the step has none
        reachable = {1.0}
        for s in per:
            reachable = {min(r, v) for r in reachable for v in s}
        k, enabled = call(name, values)
        assert enabled and min(abs(k - r) for r in reachable) <= CLOSE
        for r in reachable:
            assert ns["controller_monitor"](values, {"k": r}, TOL) is True
        for d in DELTAS:
            cmd = k + d * (1 + abs(k))
            far = min(abs(cmd - r) for r in reachable) > FAR
            if far:
                assert ns["controller_monitor"](values, {"k": cmd}, TOL) is False, (cmd, reachable)
                beyond += cmd > k
    assert beyond >= 5  # commands above the gain the proof allows were rejected


def test_family_monitor_dynamic_activation():
    name = "sbs.ctrl2_dynamic"
    ns = mon(name)
    checked = 0
    for _ in range(6):
        p, f, fp, points, normals, G, D, e = _scene(3, 1)
        state, values = _ctrl2_state(p, f, fp, points, normals, G, D, e)
        for active, nxt in [(True, True), (False, True), (True, False)]:
            values["active"], values["active_next"] = np.array([active]), np.array([nxt])
            istate = {**state, "active": _table([active]), "active_next": _table([nxt])}
            # floats, as the code: a tool put on a plane in floats can be a hair past it in exact
            # rationals, and the join test d0 >= 0 is decided on that hair (issue 19 item 1)
            finals = all_finals(step_theorem(name, drop=("active_next",)), istate, {}, exact=False)
            k, act, enabled = call(name, values)
            assert enabled == bool(finals)
            for fin in finals:
                cmd = {"k": float(fin["k"]), "active": np.array([bool(fin["active"].read((0,)))])}
                assert ns["controller_monitor"](values, cmd, TOL) is True
                flipped = {**cmd, "active": ~cmd["active"]}
                assert ns["controller_monitor"](values, flipped, TOL) is False  # the active set is pinned
                checked += 1
            if finals:
                ks = [float(fin["k"]) for fin in finals]
                cmd = max(ks) + 0.5
                assert ns["controller_monitor"](values, {"k": cmd, "active": np.array([nxt])}, TOL) is False
    assert checked >= 6


def _table(cells):
    from certiloop.falsify.evaluate import Table

    return Table({(j,): bool(v) for j, v in enumerate(cells)})


def test_algorithm_monitor_builtdr():
    ns = mon("cfmpa.builtdr")
    for N, m, n in [(1, 1, 1), (2, 3, 4), (3, 1, 2)]:
        overlap = rng.random((N, m, n)) < 0.5
        state = {"N": N, "m": m, "n": n, "overlap": overlap}
        want = overlap.astype(int)  # the guarantee, by hand
        assert ns["controller_monitor"](state, {"P": want}) is True
        wrong = want.copy()
        wrong[0, 0, 0] = 1 - wrong[0, 0, 0]
        assert ns["controller_monitor"](state, {"P": wrong}) is False


# ------------------------------------------------------------------ plant monitors


def _rhs(ode_: ODE):
    c = Compiler()
    names = [v.payload for v in ode_.variables]
    fns = [c(f) for _, f in ode_.eqs]

    def f(_t, y, params):
        s = {**params, **dict(zip(names, y))}
        return [fn(s) for fn in fns]

    return names, f, c(ode_.domain)


PLANTS = {  # model -> (prev state: evolved variables and what the ODE reads, a duration)
    "textbook.train": lambda: ({"p": 10.0, "vt": rng.uniform(0, 5), "t": 0.0,
                                "a": float(rng.choice([-2.0, 1.0])), "eps": 0.5}, rng.uniform(0, 0.5)),
    "textbook.water_tank": lambda: ({"x": 5.0, "t": 0.0, "f": float(rng.choice([-1.0, 0.0, 1.0])),
                                     "eps": 0.5},
                                    rng.uniform(0, 0.5)),
    "textbook.bouncing_ball": lambda: ({"h": rng.uniform(2, 5), "v": rng.uniform(-1, 1), "g": 9.81},
                                       rng.uniform(0, 0.3)),
    "rcm.axial_guard": lambda: ({"gap": 0.01, "t": 0.0, "wcmd": rng.uniform(-0.1, 0.1), "eps": 0.05},
                                rng.uniform(0, 0.05)),
    "sbs.ctrl2": lambda: ({**{v: rng.uniform(-1, 1) for x in "xyz" for v in (f"p{x}", f"f{x}", f"f{x}p")},
                           "t": 0.0, "k": rng.uniform(0, 1), "G": 1.5, "e": 0.2}, rng.uniform(0, 0.2)),
    "raven.deviation_stop": lambda: ({"dm": 0.02, "dr": 0.02, "t": 0.0, "v": rng.uniform(-0.1, 0.1),
                                      "u": rng.uniform(-0.01, 0.01), "eps": 0.01}, rng.uniform(0, 0.01)),
    "sbs.ctrl1": lambda: ({"px": 0.0, "py": rng.uniform(0.2, 0.8), "fx": rng.uniform(-1, 1),
                           "fy": rng.uniform(-1, -0.1), "fxp": 0.3, "fyp": -0.2, "G": 2.0, "D": 1.0},
                          rng.uniform(0, 0.05)),
    "raven.deviation_stop_3d": lambda: ({**{f"{p}{x}": rng.uniform(-0.05, 0.05) for x in "xyz" for p in "pv"},
                                         **{f"pm{x}": rng.uniform(-0.05, 0.05) for x in "xyz"},
                                         **{f"pr{x}": rng.uniform(-0.05, 0.05) for x in "xyz"},
                                         **{f"u{x}": rng.uniform(-0.01, 0.01) for x in "xyz"},
                                         "t": 0.0, "eps": 0.01}, rng.uniform(0, 0.01)),
    "rcm.barrier_continuous": lambda: ({"gap": rng.uniform(0.003, 0.008), "w": rng.uniform(-0.01, 0.01),
                                        "L": 0.0, "e": 0.0, "F": rng.uniform(-1, 1), "dmp": 1.0,
                                        "Ebar": 10.0},
                                       rng.uniform(0, 0.01)),
}


@pytest.mark.parametrize("name", sorted(PLANTS))
def test_plant_monitor_accepts_an_integrated_trajectory_and_rejects_a_perturbed_one(name):
    ns = mon(name)
    t = library.get(name)
    plant = [q for q in t.program.body.parts if isinstance(q, ODE) or hasattr(q, "alternatives")
             and all(isinstance(a, ODE) for a in q.alternatives)][0]
    modes = [plant] if isinstance(plant, ODE) else list(plant.alternatives)
    accepted = rejected = 0
    for _ in range(15):
        prev, dt = PLANTS[name]()
        assert set(ns["PLANT_STATE"]) | set(ns["PLANT_PARAMS"]) <= set(prev), ns["PLANT_PARAMS"]
        for ode_ in modes:
            names, f, domain = _rhs(ode_)
            if not domain(prev):
                continue
            sol = solve_ivp(f, (0.0, dt), [prev[v] for v in names], args=(prev,), rtol=1e-11, atol=1e-13)
            end = dict(zip(names, sol.y[:, -1]))
            if not domain({**prev, **end}):
                continue  # left the evolution domain: not a run of this mode
            observed = {v: x for v, x in end.items() if v != "t"}
            assert ns["plant_monitor"](prev, observed, dt, 1e-6) is True, (prev, observed, dt)
            accepted += 1
            var = names[int(rng.integers(0, len(names)))]
            if var == "t":
                var = names[0]
            bumped = {**observed, var: observed[var] + 1e-2}
            assert ns["plant_monitor"](prev, bumped, dt, 1e-6) is False, (var, prev, bumped, dt)
            assert ns["plant_monitor"](prev, observed, -dt - 1.0, 1e-6) is False
            rejected += 1
            break
    assert accepted >= 10 and rejected >= 10


def test_algorithms_have_no_plant_monitor():
    ns = mon("cfmpa.builtdr")
    assert ns["PLANT_STATE"] == []
    with pytest.raises(NotImplementedError):
        ns["plant_monitor"]({}, {}, 0.1, 1e-6)


# extracted models with no monitor, and why (a substring of the one-line refusal)
NO_MONITOR = {"cfmpa.property8": "the step is not deterministic"}  # an array output chosen by `:= *`


def test_models_without_monitors_are_refused_with_the_reason():
    for name, why in NO_MONITOR.items():
        with pytest.raises(ModelError, match=why) as info:
            monitors(library.get(name))
        assert str(info.value).startswith(f"{name}: ") and "\n" not in str(info.value)


def test_every_extracted_model_has_monitors():
    from kernel.test_extract_coverage import EXTRACTS

    for name in (n for n in EXTRACTS if n not in NO_MONITOR):
        try:
            ns = mon(name)
        except ExtractError as exc:  # pragma: no cover - the message says which model
            raise AssertionError(f"{name}: no monitors: {exc}") from None
        assert ns["MODEL"] == name and ns["MODEL_HASH"] == library.get(name).content_hash
        assert callable(ns["controller_monitor"]) and callable(ns["plant_monitor"])


def test_monitor_modules_import_only_numpy(tmp_path):
    import subprocess
    import sys

    from kernel.test_extract_coverage import EXTRACTS

    EXTRACTS = [n for n in EXTRACTS if n not in NO_MONITOR]
    for name in EXTRACTS:
        (tmp_path / f"m_{name.replace('.', '_')}.py").write_text(monitors(library.get(name)))
    code = ("import importlib, sys; sys.path.insert(0, %r); "
            "[importlib.import_module(m) for m in %r]; "
            "print(sorted(m for m in ('z3', 'sympy', 'hypothesis', 'scipy', 'certiloop') "
            "if m in sys.modules))"
            % (str(tmp_path), [f"m_{n.replace('.', '_')}" for n in EXTRACTS]))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_cli_extract_monitors(tmp_path, capsys):
    from certiloop.cli.main import main

    out = tmp_path / "train_monitors.py"
    args = ["extract", "textbook.train", "--monitors", "-o", str(out), "--cache", str(tmp_path / "c")]
    assert main(args) == 0
    ns: dict = {}
    exec(compile(out.read_text(), str(out), "exec"), ns)
    assert ns["MODEL"] == "textbook.train" and ns["COMMAND"] == ["a"]
    # a shape with no control step: refused with one line naming the model, nothing written
    bad = tmp_path / "none.py"
    assert main(["extract", "rcm.constraint_set_invariant", "--monitors", "-o", str(bad),
                 "--cache", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("certiloop: error: rcm.constraint_set_invariant: ") and not bad.exists()


def test_int_command_must_be_an_integer_and_overlapping_guards_admit_both():
    """An Int output compares exactly (1.5 is no command, nor is a Bool); where both guards hold
    (x = 0) both alternatives are runs of the model, so both commands pass."""
    from certiloop.models.lang.programs import assign, branch, choice, loop, ode, seq
    from certiloop.models.lang.programs import test as check
    from certiloop.models.lang.terms import TRUE, Int, Real
    from certiloop.models.lang.theorem import Theorem

    x, n = Real("x"), Int("n")
    step = choice(branch("a", check(x >= 0), assign(n, 1)), branch("b", check(x <= 0), assign(n, 2)))
    t = Theorem("tests.intcmd", TRUE, loop(seq(step, ode({x: n}))), TRUE)
    ns: dict = {}
    exec(compile(monitors(t), "<intcmd>", "exec"), ns)
    assert (ns["STATE"], ns["COMMAND"]) == (["x"], ["n"])
    assert [ns["controller_monitor"]({"x": 1.0}, {"n": v}) for v in (1, 1.0, 1.5, 2, True)] == \
        [True, True, False, False, False]
    assert [ns["controller_monitor"]({"x": 0.0}, {"n": v}) for v in (1, 2, 3)] == [True, True, False]
