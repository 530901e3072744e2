"""Declared roles (`Theorem(roles=Roles(environment=(al,), controls=(a,)))`, issue 43 item 4;
certiloop/kernel/extract/environment.py, modelplex_environment.py).

Witnesses, all independent of the generated code:
  * the adaptive cruise control's step written by hand below in exact rationals (Fractions of
    the float inputs): the extracted controller's command is exactly the model's, on random
    states, on exact ties of the accelerate guard and ±1 to 2^16 ulps around them, on a speed
    of ±0 or ±one subnormal, and at magnitudes up to 1e300;
  * the environment monitor against -B <= al <= A checked by hand in Fractions (non-finite
    values outside the model);
  * the controller monitor against the model's three alternatives by hand, the plant monitor
    against the ODE's closed-form solution by hand;
  * canonical texts of library theorems recorded before roles existed (unchanged byte for byte).
"""

import hashlib
import math
from fractions import Fraction

import numpy as np
import pytest

from certiloop.kernel.extract import ExtractError, extract
from certiloop.kernel.extract.c.build import compiler, load
from certiloop.kernel.extract.c.emit import extract_c
from certiloop.kernel.extract.modelplex import monitors
from certiloop.models import (
    And,
    Int,
    Real,
    Reals,
    Roles,
    Theorem,
    assign,
    branch,
    choice,
    havoc,
    library,
    loop,
    ode,
    seq,
)
from certiloop.models import test as check
from certiloop.models.lang.terms import ModelError
from certiloop.proofs.checker import keys

ACC = "textbook.adaptive_cruise"
rng = np.random.default_rng(43)

# (content_hash, sha256 of the canonical text) of library theorems, recorded before Theorem had roles
PINNED = {
    "textbook.train": ("15cb64a9f2561263",
                       "15cb64a9f2561263737214b9030f96bb2e3ae3c59fcffdd62c2d67509828ac76"),
    "textbook.cart_forward": ("1bfc79b9fe25aa7d",
                              "1bfc79b9fe25aa7d2c454a2ba7787404e29054506d24b1731cf2942d649ddadb"),
    "sbs.ctrl1": ("4d99e2e1c41a8ea7", "4d99e2e1c41a8ea74322ce5fffb993b8816eac0dd24bb50d9c8ff633bdf4ae70"),
    "sbs.ctrl2": ("f854f1205e36dea0", "f854f1205e36dea008c52fd6dec38c05beaea1f49869027fdf36295ac06c5706"),
    "cfmpa.builtdr": ("0877a2f6fdff762c", "0877a2f6fdff762cd32a17ccf11124e41fd57155a0d024084bf68d86dbf1f550"),
    "raven.deviation_stop": ("affb3e7fc9672a64",
                             "affb3e7fc9672a642a443197ff0d1f84b6598f6c27264effbdcfaa7f5226a3a5"),
    "rcm.axial_guard": ("5c28000957856f8e",
                        "5c28000957856f8e593efaf9c75008ddc41b01700b17b7fdb1b89431784d37a3"),
    "rcm.passivity": ("2425d31c0bdc154a", "2425d31c0bdc154a788461d4e1be28441a1ea9ab3ecf66e5da3eb214e24d4ef0"),
}


@pytest.mark.parametrize("name", sorted(PINNED))
def test_theorems_without_roles_keep_their_canonical_text(name):
    t = library.get(name)
    assert t.roles is None
    assert (t.content_hash, hashlib.sha256(t.canonical.encode()).hexdigest()) == PINNED[name]


def test_roles_are_part_of_the_canonical_text_and_read_back_by_the_checker():
    t = library.get(ACC)
    bare = Theorem(t.name, t.assumptions, t.program, t.guarantee, constants=t.constants,
                   description=t.description)
    assert "roles" not in bare.canonical and "roles" in t.canonical
    assert bare.content_hash != t.content_hash
    back = keys.theorem(t.canonical)  # the certificate checker's reader
    assert back.canonical == t.canonical
    assert back.roles.environment_names == ("al",) and back.roles.control_names == ("a",)


# ------------------------------------------------------------------ the adaptive cruise control by hand

ACC_KEYS = ("p", "v", "pl", "vl", "A", "B", "eps")


def safe_by_hand(state: dict) -> bool:
    """The accelerate guard: a period at A keeps the follower's stopping point behind the leader's
    (p + v²/2B + (A/B + 1)(A ε²/2 + ε v) < pl + vl²/2B, written times 2B)."""
    p, v, pl, vl, A, B, eps = (Fraction(state[k]) for k in ACC_KEYS)
    return 2 * B * p + v * v + (A + B) * (A * eps * eps + 2 * eps * v) < 2 * B * pl + vl * vl


def acc_by_hand(state: dict) -> Fraction:
    """The model's control step on the exact values of the float inputs: the follower's command,
    the first enabled of accelerate, stopped, brake."""
    if safe_by_hand(state):
        return Fraction(state["A"])
    return Fraction(0) if state["v"] == 0 else -Fraction(state["B"])


_NS: dict = {}


def namespace(what: str, theorem=None) -> dict:
    if what not in _NS:
        source = (monitors if what.endswith("monitors") else extract)(theorem or library.get(ACC))
        ns: dict = {}
        exec(compile(source, f"<{what}>", "exec"), ns)
        _NS[what] = ns
    return _NS[what]


def controller(state: dict):
    ns = namespace("controller")
    return ns["controller"](*(state[k] for k in ns["INPUTS"]))


def _float(scale: float) -> float:
    return float(rng.uniform(-1, 1) * scale)


def random_state(scale: float = 100.0) -> dict:
    s = {k: _float(scale) for k in ACC_KEYS}
    s.update(v=abs(s["v"]), vl=abs(s["vl"]), A=abs(s["A"]), B=abs(s["B"]) or 1.0, eps=abs(s["eps"]) or 0.5)
    return s


def ulps(x: float, k: int) -> float:
    for _ in range(abs(k)):
        x = math.nextafter(x, math.inf if k > 0 else -math.inf)
    return x


def tie_states():
    """The accelerate guard at an exact tie (dyadic values, vl = 0: the leader's stopping point is
    pl) and its nearest floats to a random real tie, each nudged 0, ±1, ±2, ±16, ±2^16 ulps."""
    nudges = (0, 1, -1, 2, -2, 16, -16, 2 ** 16, -(2 ** 16))
    for _ in range(30):
        s = {"p": float(rng.integers(-64, 64)) / 8, "v": float(rng.integers(0, 64)) / 4,
             "A": float(rng.integers(0, 16)) / 4, "B": 2.0 ** int(rng.integers(-3, 4)),
             "eps": 2.0 ** int(rng.integers(-4, 1)), "vl": 0.0}
        p, v, A, B, eps = (Fraction(s[k]) for k in ("p", "v", "A", "B", "eps"))
        tie = p + (v * v + (A + B) * (A * eps * eps + 2 * eps * v)) / (2 * B)  # the pl where 2B·pl ties
        assert Fraction(float(tie)) == tie  # dyadic with few bits: the tie is a float
        for k in (0, 1, -1, 2, -2, 16, -16):
            yield {**s, "pl": ulps(float(tie), k)}
    for _ in range(60):
        s = random_state(float(rng.choice([1e-3, 1.0, 1e3, 1e8])))
        p, v, vl, A, B, eps = (Fraction(s[k]) for k in ("p", "v", "vl", "A", "B", "eps"))
        tie = p + (v * v + (A + B) * (A * eps * eps + 2 * eps * v) - vl * vl) / (2 * B)
        for k in nudges:
            yield {**s, "pl": ulps(float(tie), k)}


def test_acc_controller_senses_the_leader_and_outputs_only_the_acceleration():
    ns = namespace("controller")
    assert sorted(ns["INPUTS"]) == sorted(["p", "v", "B", "A", "eps", "pl", "vl"])  # al is not among them
    assert "Returns (a, enabled)" in ns["controller"].__doc__
    assert "the environment chooses al, which the controller does not read" in " ".join(
        ns["controller"].__doc__.split())


@pytest.mark.parametrize("states", ["random", "ties", "extreme"])
def test_acc_controller_is_the_exact_model(states):
    if states == "random":
        cases = [random_state(float(s)) for s in rng.choice([1e-6, 1.0, 1e3, 1e9], 400)]
    elif states == "ties":
        cases = list(tie_states())
    else:  # magnitudes up to 1e300, zero and subnormal speeds
        cases = [random_state(float(s)) for s in rng.choice([1e-300, 1e150, 1e300], 120)]
        cases += [{**random_state(), "v": v} for v in (0.0, -0.0, 5e-324, -5e-324) for _ in range(10)]
    for state in cases:
        want = acc_by_hand(state)
        a, enabled = controller(state)
        assert enabled is True, state
        assert Fraction(a) == want, (state, a, want)  # A, 0 and -B are floats: exactly the model's


def test_acc_controller_outside_the_assumptions_is_still_the_model():
    # B <= 0, A < 0, eps < 0: outside the assumptions, but the step's guard has no division, so
    # the model has a run everywhere and the controller gives it
    for _ in range(200):
        state = {k: _float(10.0) for k in ACC_KEYS}
        state["B"] = float(rng.choice([0.0, -0.0, state["B"]]))
        a, enabled = controller(state)
        assert enabled is True and Fraction(a) == acc_by_hand(state), state
    a, enabled = controller({**random_state(), "p": math.inf})  # not a real number: no run
    assert enabled is False and math.isnan(a)


# ------------------------------------------------------------------ the environment monitor


def environment_by_hand(state: dict) -> bool:
    values = [state[k] for k in ("al", "A", "B")]
    if not all(math.isfinite(x) for x in values):
        return False
    al, A, B = (Fraction(x) for x in values)
    return -B <= al <= A


def environment_states():
    for _ in range(300):
        scale = float(rng.choice([1e-300, 1e-3, 1.0, 1e3, 1e300]))
        yield {"al": _float(scale), "A": _float(scale), "B": _float(scale)}
    for _ in range(100):
        A, B = abs(_float(10.0)), abs(_float(10.0))
        for edge in (A, -B):
            for k in (0, 1, -1, 2, -2, 2 ** 16, -(2 ** 16)):
                yield {"al": ulps(edge, k), "A": A, "B": B}
    for bad in (math.inf, -math.inf, math.nan):
        yield {"al": bad, "A": 1.0, "B": 1.0}
        yield {"al": 0.0, "A": bad, "B": 1.0}


def test_environment_monitor_checks_the_leaders_acceleration_exactly():
    ns = namespace("monitors")
    assert ns["ENVIRONMENT"] == ["al"] and sorted(ns["ENVIRONMENT_STATE"]) == ["A", "B", "al"]
    assert ns["ENVIRONMENT_ASSUMPTIONS"] == "-B <= al & al <= A"
    checked = held = 0
    for state in environment_states():
        want = environment_by_hand(state)
        assert ns["environment_monitor"](state) is want, state
        checked, held = checked + 1, held + want
    assert 0 < held < checked  # both answers occur


def test_environment_monitor_at_its_edges_at_every_magnitude():
    # al = A exactly: held; the next float above: not held (subnormal to 1e300)
    ns = namespace("monitors")
    for A in (1e-310, 0.1, 3.0, 1e300):
        assert ns["environment_monitor"]({"al": A, "A": A, "B": A}) is True
        assert ns["environment_monitor"]({"al": math.nextafter(A, math.inf), "A": A, "B": A}) is False
        assert ns["environment_monitor"]({"al": -A, "A": A, "B": A}) is True
        assert ns["environment_monitor"]({"al": math.nextafter(-A, -math.inf), "A": A, "B": A}) is False


# ------------------------------------------------------------------ the controller and plant monitors


def test_controller_monitor_admits_exactly_the_models_commands():
    ns = namespace("monitors")
    assert ns["COMMAND"] == ["a"] and "al" not in ns["STATE"]
    for state in [*tie_states(), *(random_state() for _ in range(100))]:
        A, B, v, safe = Fraction(state["A"]), Fraction(state["B"]), state["v"], safe_by_hand(state)
        for cmd in (state["A"], 0.0, -state["B"]):
            c = Fraction(cmd)
            want = (c == A and safe) or (c == 0 and v == 0) or c == -B
            assert ns["controller_monitor"]({k: state[k] for k in ns["STATE"]}, {"a": cmd}) is want, state


def test_plant_monitor_reads_the_leaders_acceleration():
    ns = namespace("monitors")
    assert "al" in ns["PLANT_PARAMS"]
    p, v, pl, vl, a, al, eps, dt = 0.0, 2.0, 30.0, 3.0, -1.0, 0.5, 1.0, 0.75
    prev = {"p": p, "v": v, "pl": pl, "vl": vl, "t": 0.0, "a": a, "al": al, "eps": eps}
    end = {"p": p + v * dt + a * dt * dt / 2, "v": v + a * dt, "pl": pl + vl * dt + al * dt * dt / 2,
           "vl": vl + al * dt}
    assert ns["plant_monitor"](prev, end, dt, 1e-9) is True
    assert ns["plant_monitor"](prev, {**end, "vl": end["vl"] + 1e-2}, dt, 1e-9) is False
    assert ns["plant_monitor"](prev, end, eps + 0.25, 1e-9) is False  # past the period


# ------------------------------------------------------------------ plant modes in the branches

p, v, a, pl, vl, al, A, B, eps, t, d = Reals("p v a pl vl al A B eps t d")


def switched(roles=None) -> Theorem:
    """The cruise control with the plant inside each branch and a driver's demand d (also the
    environment's): the controller follows d where a period of A is safe."""
    safe = p + v**2 / (2 * B) + (A / B + 1) * (A / 2 * eps**2 + eps * v) < pl + vl**2 / (2 * B)
    gap = p + v**2 / (2 * B) < pl + vl**2 / (2 * B)

    def flow():
        return seq(assign(t, 0), ode({p: v, v: a, pl: vl, vl: al, t: 1}, And(v >= 0, vl >= 0, t <= eps)))

    step = seq(havoc(al), check(And(-B <= al, al <= A)), havoc(d), check(And(-B <= d, d <= A)),
               choice(branch("follow", check(safe), assign(a, d), flow()),
                      branch("stopped", check(v == 0), assign(a, 0), flow()),
                      branch("brake", assign(a, -B), flow())))
    inv = And(p < pl, gap, v >= 0, vl >= 0)
    return Theorem("roles.switched", And(B > 0, A >= 0, eps > 0, inv), loop(step, invariant=inv), p < pl,
                   constants=(A, B, eps), roles=roles)


def test_without_roles_plant_modes_still_give_rates():
    ns: dict = {}
    exec(extract(switched()), ns)
    assert "al" in ns["INPUTS"] and "Returns (p_dot, v_dot" in ns["controller"].__doc__


def switched_by_hand(state: dict) -> Fraction | None:
    """The switched model's controller: the first branch whose test and domain (after t := 0)
    hold; None if none (B != 0 here)."""
    p_, v_, pl_, vl_, A_, B_, eps_, d_ = (Fraction(state[k]) for k in (*ACC_KEYS, "d"))
    if not (v_ >= 0 and vl_ >= 0 and 0 <= eps_):  # every mode has this domain
        return None
    follower = p_ + v_ * v_ / (2 * B_) + (A_ / B_ + 1) * (A_ / 2 * eps_ * eps_ + eps_ * v_)
    if follower < pl_ + vl_ * vl_ / (2 * B_):
        return d_
    return Fraction(0) if v_ == 0 else -B_


def test_with_roles_plant_modes_give_the_controls_and_test_the_domain_at_the_start():
    ns = namespace("switched", switched(Roles(environment=(al, d), controls=(a,))))
    assert "al" not in ns["INPUTS"] and "d" in ns["INPUTS"]
    assert "Returns (a, enabled)" in ns["controller"].__doc__
    for state in [*(random_state() for _ in range(200)), *tie_states()]:
        state = {**state, "d": _float(3.0)}
        if rng.random() < 0.2:
            state["vl"] = -state["vl"] or -1.0  # no mode's domain holds at the start: no run
        want = switched_by_hand(state)
        got, enabled = ns["controller"](*(state[k] for k in ns["INPUTS"]))
        assert enabled is (want is not None), state
        if want is not None:
            assert Fraction(got) == want, state


def test_switched_monitors_with_roles():
    ns = namespace("switched monitors", switched(Roles(environment=(al, d), controls=(a,))))
    assert ns["ENVIRONMENT"] == ["al", "d"]
    assert ns["environment_monitor"]({"al": 0.5, "d": -2.0, "A": 1.0, "B": 2.0}) is True
    assert ns["environment_monitor"]({"al": 0.5, "d": math.nextafter(-2.0, -3), "A": 1.0, "B": 2.0}) is False
    prev = {"p": 0.0, "v": 1.0, "pl": 10.0, "vl": 1.0, "t": 5.0, "a": 0.0, "al": 0.0, "eps": 1.0}
    assert ns["plant_monitor"](prev, {"p": 0.5, "v": 1.0, "pl": 10.5, "vl": 1.0}, 0.5, 1e-9) is True


# ------------------------------------------------------------------ refusals

def acc(roles, *step) -> Theorem:
    t_ = library.get(ACC)
    if not step:
        return Theorem("roles.acc", t_.assumptions, t_.program, t_.guarantee, constants=t_.constants,
                       roles=roles)
    plant = seq(assign(t, 0), ode({p: v, v: a, pl: vl, vl: al, t: 1}, And(v >= 0, vl >= 0, t <= eps)))
    return Theorem("roles.acc", t_.assumptions, loop(seq(*step, plant), invariant=t_.program.invariant),
                   t_.guarantee, constants=t_.constants, roles=roles)


LEADER = seq(havoc(al), check(And(-B <= al, al <= A)))
FOLLOWER = choice(branch("accelerate", check(v <= 1), assign(a, A)), branch("brake", assign(a, -B)))
ROLES = Roles(environment=(al,), controls=(a,))

REFUSALS = [  # (model, what the one line must say)
    (lambda: acc(Roles(environment=(Real("alx"),), controls=(a,))),
     ["`alx`", "does not mention", "correct the name or remove it"]),
    (lambda: acc(Roles(environment=(Int("al"),), controls=(a,))), ["`al` as Int", "is Real"]),
    (lambda: acc(Roles(environment=(al, A), controls=(a,))), ["the constant `A`", "remove it from Roles"]),
    (lambda: acc(Roles(environment=(al, vl), controls=(a,))),
     ["`vl` in environment", "never chooses it", "remove it from environment"]),
    (lambda: acc(Roles(environment=(al,), controls=(a, pl))),
     ["`pl` in controls", "never sets it", "remove it from controls"]),
    (lambda: acc(Roles(controls=(a,))), ["`al := *`", "plant reads", "add `al` to environment"]),
    (lambda: acc(ROLES, LEADER, choice(branch("x", assign(al, 0), assign(a, A)), branch("y", assign(a, -B)))),
     ["sets the environment's `al`", "remove `al` from environment"]),
    (lambda: acc(ROLES, choice(branch("x", LEADER, assign(a, A)), branch("y", assign(a, -B)))),
     ["`al := *` is inside a statement of the controller", "at the top of the step"]),
    (lambda: acc(ROLES, FOLLOWER, LEADER, check(al <= a)),
     ["`al <= a`", "reads `a`", "which the controller"]),
    (lambda: acc(ROLES, check(al <= A), LEADER, FOLLOWER), ["tests the environment's `al` before"]),
    (lambda: acc(ROLES, choice(branch("x", check(al <= 0), assign(a, A)), branch("y", assign(a, -B))),
                 LEADER),
     ["reads `al` before the environment chooses it", "put the environment's choice before"]),
    (lambda: acc(Roles(environment=(al,), controls=(a,)), LEADER, FOLLOWER, assign(d, a)),
     None),  # an intermediate nobody reads is allowed
]


@pytest.mark.parametrize("k", range(len(REFUSALS)))
def test_a_declaration_that_does_not_fit_is_refused_in_one_line(k):
    build, says = REFUSALS[k]
    if says is None:
        ns: dict = {}
        exec(extract(build()), ns)
        assert "d" not in ns["INPUTS"]
        return
    for generate in (extract, monitors, extract_c):
        with pytest.raises(ExtractError) as info:
            generate(build())
        message = str(info.value)
        assert "\n" not in message and message.startswith("roles.acc: "), message
        for part in says:
            assert part in message, message


@pytest.mark.parametrize("roles, says", [
    (Roles(environment=(al,), controls=(a, al)), "`al` in both environment and controls"),
    (Roles(environment=(al, al), controls=(a,)), "`al` twice"),
    (Roles(environment=(al,)), "no controls"),
    (Roles(environment=(al + 1,), controls=(a,)), "must be symbols"),
    ((al,), "roles must be Roles("),
])
def test_an_ill_formed_declaration_is_refused_when_the_model_is_built(roles, says):
    with pytest.raises(ModelError) as info:
        acc(roles)
    assert says in str(info.value) and "\n" not in str(info.value)


def test_the_controller_setting_what_the_plant_reads_must_declare_it():
    b2 = Real("b2")
    plant = seq(assign(t, 0), ode({p: v, v: a - b2, pl: vl, vl: al, t: 1}, And(v >= 0, t <= eps)))
    model = Theorem("roles.drag", And(B > 0), loop(seq(LEADER, FOLLOWER, assign(b2, 0), plant)), p < pl,
                    roles=ROLES)
    with pytest.raises(ExtractError, match=r"sets `b2`, which the plant reads.*add `b2` to controls"):
        extract(model)
    ns: dict = {}
    exec(extract(Theorem("roles.drag", And(B > 0), loop(seq(LEADER, FOLLOWER, assign(b2, 0), plant)), p < pl,
                         roles=Roles(environment=(al,), controls=(a, b2)))), ns)
    assert ns["controller"].__doc__.startswith("Returns (a, b2, enabled)")


def test_names_the_generated_code_cannot_use_are_renamed_in_the_roles_too():
    lam, out = Reals("lambda int")  # a Python keyword and a builtin: u_lambda, u_int in the code
    follower = choice(branch("accelerate", check(v <= 1), assign(out, A)), branch("brake", assign(out, -B)))
    plant = seq(assign(t, 0), ode({p: v, v: out, pl: vl, vl: lam, t: 1}, And(v >= 0, t <= eps)))
    step = seq(havoc(lam), check(lam <= A), follower, plant)
    model = Theorem("roles.renamed", And(B > 0), loop(step), p < pl,
                    roles=Roles(environment=(lam,), controls=(out,)))
    ns: dict = {}
    exec(extract(model), ns)
    assert ns["controller"].__doc__.startswith("Returns (u_int, enabled)") and "u_lambda" not in ns["INPUTS"]
    mon: dict = {}
    exec(monitors(model), mon)
    assert mon["ENVIRONMENT"] == ["u_lambda"]
    assert mon["environment_monitor"]({"u_lambda": 1.0, "A": 1.0}) is True
    assert mon["environment_monitor"]({"u_lambda": 1.5, "A": 1.0}) is False


# ------------------------------------------------------------------ C


@pytest.mark.skipif(compiler() is None, reason="no C compiler (cc, gcc or $CC) on this machine")
def test_c_controller_senses_the_leader_and_decides_as_the_exact_model(tmp_path):
    kernel = load(extract_c(library.get(ACC)), tmp_path / "acc")
    assert kernel.outputs == ["a"] and "al" not in kernel.inputs
    decided = 0
    for state in [*(random_state() for _ in range(300)), *tie_states()]:
        a_, enabled = kernel(*(state[k] for k in kernel.inputs))
        if kernel.undecided:  # a near tie C leaves to the Python kernel
            continue
        decided += 1
        assert enabled and Fraction(a_) == acc_by_hand(state), state
    assert decided > 300


def latch(controls) -> Theorem:
    """A stop latch: once x reaches X the controller sets stopped and commands 0 from then on."""
    x, X, stopped = Reals("x X stopped")
    step = choice(branch("stopped", check(stopped >= 1), assign(a, 0)),
                  branch("running", check(stopped < 1),
                         choice(branch("reach", check(x >= X), assign(stopped, 1), assign(a, 0)),
                                branch("go", check(x < X), assign(a, 1)))))
    plant = seq(assign(t, 0), ode({x: a, t: 1}, t <= eps))
    return Theorem("roles.latch", And(x <= X, stopped == 0), loop(seq(step, plant)), x <= X + eps,
                   roles=Roles(controls=tuple(Real(c) for c in controls)))


def test_a_control_only_the_next_step_reads_is_an_output_in_python_and_c():
    with pytest.raises(ExtractError, match=r"sets `stopped`, which the next step reads.*add `stopped` to"):
        extract(latch(["a"]))
    ns: dict = {}
    exec(extract(latch(["a", "stopped"])), ns)
    assert ns["controller"].__doc__.startswith("Returns (a, stopped, enabled)")
    call = lambda **s: ns["controller"](*(s[k] for k in ns["INPUTS"]))  # noqa: E731
    assert call(x=0.5, X=1.0, stopped=0.0) == (1.0, 0.0, True)
    assert call(x=1.0, X=1.0, stopped=0.0) == (0.0, 1.0, True)  # reaches X: latched
    assert call(x=0.0, X=1.0, stopped=1.0) == (0.0, 1.0, True)  # stays stopped
    header = extract_c(latch(["a", "stopped"]))["roles_latch.h"]
    assert '#define ROLES_LATCH_OUTPUTS "a stopped"' in header


@pytest.mark.skipif(compiler() is None, reason="no C compiler (cc, gcc or $CC) on this machine")
def test_c_switched_controller_gives_the_controls(tmp_path):
    model = switched(Roles(environment=(al, d), controls=(a,)))
    kernel = load(extract_c(model), tmp_path / "switched")
    assert kernel.outputs == ["a"] and "d" in kernel.inputs and "al" not in kernel.inputs
    decided = 0
    for state in [*(random_state() for _ in range(200)), *tie_states()]:
        state = {**state, "d": _float(3.0)}
        got, enabled = kernel(*(state[k] for k in kernel.inputs))
        if not kernel.undecided:
            decided += 1
            want = switched_by_hand(state)
            assert enabled is (want is not None) and (want is None or Fraction(got) == want), state
    assert decided > 200
