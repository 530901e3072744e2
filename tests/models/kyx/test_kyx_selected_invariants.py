"""KeYmaera X's invariants selected by the flow they hold for: `@invariant((v'=f -> J), ...)`.

A loop may reach one ODE with different constants (a drag coefficient r set by a choice), and
the author writes one invariant per case, guarded by the differential equation it is meant for.
certiloop reads the guard as "the flow's right-hand side is f identically" (core/odes.py,
`annotated_atoms`): the coefficients of the difference, a condition on the constants. The
planner then tries the loop invariant's atoms under each such case too.

Independent witness for every `proved`: scipy integrates the hybrid program's runs (random
choices and durations) and checks the guarantee along them."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from certiloop.models.kyx import read_entries
from certiloop.models.lang.programs import ode
from certiloop.models.lang.terms import Implies, ModelError, Real, cmp
from certiloop.proofs.core.odes import annotated_atoms, atom_premise
from certiloop.proofs.engine.prover import Prover

# a falling body whose drag coefficient is r = a (closed) or r = 1 (open); terminal speed 2 when
# open. Closed, it may fall only while the test shows it stays above -2 for the whole step.
DRAG = """ArchiveEntry "{name}"
  Definitions Real g = 4; Real a; Real T; End.
  ProgramVariables Real v; Real r; Real t; End.
  Problem 1 > a & a > 0 & T > 0 & v < 0 & v > -2 & r = a
    -> [ {{ {{ ?(v - g*T > {slack} & r = a); ++ r := 1; }}
            t := 0;
            {{v' = -g + r*v^2, t' = 1 & t <= T & v < 0}}@invariant(
              (v' = -g + a*v^2 -> v - g*(T - t) > -2),
              (v' = -g + v^2 -> v >= old(v) - g*t))
          }}*@invariant(v < 0 & v > -2) ] v >= -2
  End.
End."""


def prove(text: str):
    (entry,) = read_entries(text)
    assert entry.error is None, entry.error
    with Prover(jobs=1) as prover:
        return prover.prove(entry.theorem)


def drag_runs(slack: float, seed: int = 0, runs: int = 60) -> float:
    """The lowest speed scipy finds on random runs of the drag program (a, T, start random)."""
    rng = np.random.default_rng(seed)
    lowest = np.inf
    for _ in range(runs):
        a, T = rng.uniform(0.05, 0.95), rng.uniform(0.1, 1.5)
        v, r = rng.uniform(-1.99, -0.01), a
        for _ in range(4):
            if rng.random() < 0.5 and v - 4 * T > slack and r == a:
                pass  # keep r = a
            else:
                r = 1.0
            span = rng.uniform(0, T)
            sol = solve_ivp(lambda _t, y, r=r: [-4 + r * y[0] ** 2], (0, span), [v], rtol=1e-10,
                            atol=1e-12, events=lambda _t, y: y[0], dense_output=True)
            v = float(sol.y[0, -1])
            lowest = min(lowest, float(sol.y[0].min()))
            if v >= 0:
                break
    return lowest


def test_invariants_selected_per_flow_prove_the_drag_model():
    result = prove(DRAG.format(name="drag", slack=-2))
    assert result.verdict == "proved", result
    assert drag_runs(slack=-2) >= -2  # the witness: no run below -2


def test_a_weaker_test_is_not_proved():
    """Closed (r = a) with a test that lets the body reach -3 within the step: false, and
    scipy finds runs below -2."""
    assert drag_runs(slack=-3) < -2
    result = prove(DRAG.format(name="drag, weak test", slack=-3))
    assert result.verdict != "proved", result


def test_the_guard_becomes_a_condition_on_the_constants():
    v, r, a, t = Real("v"), Real("r"), Real("a"), Real("t")
    flow = ode([(v, -4 + r * v ** 2), (t, 1)], t <= 1, invariants=[
        Implies(cmp("==", -4 + r * v ** 2, -4 + a * v ** 2), v > -2),  # selects r = a
        Implies(cmp("==", -4 + r * v ** 2, -4 + r * v ** 2), v < 0),  # always this flow
        Implies(cmp("==", v, 0), t >= 0),  # a guard on the state: kept, and refused by the core
    ])
    atoms = annotated_atoms(flow)
    assert [str(x) for x in atoms] == ["r + (-1)*a = 0 -> v > -2", "v < 0", "v = 0 -> t >= 0"]
    # the guard no longer moves, so the core accepts the atom, guarded
    assert atom_premise(atoms[0], flow, "dI").op == "implies"


@pytest.mark.parametrize("guard", ["v > 1", "v = 1"])
def test_a_guard_on_the_state_is_refused_naming_it(guard):
    """Not a choice of flow: `v > 1` is no equation, and `v = 1` never holds identically."""
    v, t = Real("v"), Real("t")
    flow = ode([(v, -v), (t, 1)], t <= 1, invariants=[Implies(v > 1 if guard == "v > 1" else cmp("==", v, 1),
                                                              v > 0)])
    (atom,) = annotated_atoms(flow)
    with pytest.raises(ModelError, match="must stay constant along the flow"):
        atom_premise(atom, flow, "dI")


def test_a_velocity_selected_invariant_holds_the_position():
    """IJRR's robot style: x' = v*dx, and `(x' = 0*dx -> x = old(x))` is meant for the stop
    branch v := 0, which the guard reads as v = 0 (dx moves with the heading)."""
    text = """ArchiveEntry "stop or turn"
      ProgramVariables Real x; Real y; Real v; Real dx; Real dy; Real w; Real t; End.
      Problem dx^2 + dy^2 = 1 & x = 0 & v >= 0
        -> [ { { v := 0; ++ ?x <= -v; }
               t := 0;
               {x' = v*dx, y' = v*dy, dx' = -w*dy, dy' = w*dx, t' = 1 & t <= 1}@invariant(
                 (x' = 0*dx -> x = old(x)),
                 (x' = v*dx -> dx^2 + dy^2 = 1),
                 (x' = v*dx -> x - old(x) <= v*t))
             }*@invariant(dx^2 + dy^2 = 1 & x <= 0 & v >= 0) ] x <= 0
      End.
    End."""
    result = prove(text)
    assert result.verdict == "proved", result
    # witness: heading dx only in [-1, 1], so x moves by at most v*t per step
    rng = np.random.default_rng(1)
    for _ in range(40):
        x, v, th = 0.0, rng.uniform(0, 2), rng.uniform(0, 2 * np.pi)
        for _ in range(3):
            if rng.random() < 0.5 or not x <= -v:
                v = 0.0
            w, span = rng.uniform(-3, 3), rng.uniform(0, 1)
            sol = solve_ivp(lambda _t, s, v=v, w=w: [v * s[2], v * s[3], -w * s[3], w * s[2]],
                            (0, span), [x, 0.0, np.cos(th), np.sin(th)], rtol=1e-10, atol=1e-12)
            assert sol.y[0].max() <= 1e-9
            x, th = float(sol.y[0, -1]), float(np.arctan2(sol.y[3, -1], sol.y[2, -1]))
