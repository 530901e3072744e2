"""The trusted core's own guarantees, each checked against an independent witness."""


import pytest
import sympy

from certiloop.models import (
    And,
    ForAll,
    Int,
    ModelError,
    Not,
    Real,
    Reals,
    Theorem,
    assign,
    branch,
    choice,
    havoc,
    ode,
    seq,
)
from certiloop.models import test as guard
from certiloop.proofs.core.odes import check_solution, polynomial_solution
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.core.verdicts import ObligationResult, RunEvidence, decide_theorem
from certiloop.proofs.engine import Prover, discharge_one

x, y, b, c, v, a, q, t = Reals("x y b c v a q t")


def _prove(theorem):
    with Prover(jobs=1) as p:
        return p.prove(theorem)


# --------------------------------------------------------------------------- ODE solutions


def test_closed_forms_of_long_chains_match_hand_integration():
    """A chain of 12 integrators (names chosen so that internal symbol order differs from
    the chain order): x_k(s) = s^k / k! from rest, with the last one driven by 1."""
    names = [f"z{k}" for k in range(12)]  # z10, z11 sort before z2 as text
    zs = [Real(n) for n in names]
    eqs = {zs[k]: zs[k + 1] for k in range(11)}
    eqs[zs[11]] = 1
    sol = polynomial_solution(ode(eqs), Real("s@flow"))
    s = sympy.Symbol("s")
    for k, n in enumerate(names):
        expr = sympy.sympify(str(sol[n]).replace("s@flow", "s").replace("^", "**"),
                             locals={m: sympy.Symbol(m) for m in names})
        at_rest = expr.subs({sympy.Symbol(m): 0 for m in names})
        assert sympy.expand(at_rest - s ** (12 - k) / sympy.factorial(12 - k)) == 0, n


def test_the_solution_check_rejects_a_wrong_closed_form():
    s, p0, v0 = sympy.symbols("s p0 v0")
    rhs = {"p": v0, "v": sympy.Integer(1)}  # p' = v, v' = 1, written over the start values
    start = {"p": p0, "v": v0}
    right = {"p": p0 + v0 * s + s**2 / 2, "v": v0 + s}
    wrong = {"p": p0 + v0 * s + s**2, "v": v0 + s}
    assert check_solution(rhs, start, right, s)
    assert not check_solution(rhs, start, wrong, s)


def test_accumulator_in_three_dimensions_is_judged_right():
    """The trust issue's first defect: a 3-D double integrator at rest with az = 1 and
    q' = pz + vz. Exactly, q(t) = t^3/6 + t^2/2, so 2q >= t^3 is false at t = 2 and
    6q <= t^3 + 3t^2 is true (with equality)."""
    px, py, pz, vx, vy, vz, ax, ay, az = Reals("px py pz vx vy vz ax ay az")
    start = And(px == 0, py == 0, pz == 0, vx == 0, vy == 0, vz == 0, ax == 0, ay == 0, az == 1,
                q == 0, t == 0)
    flow = ode({px: vx, py: vy, pz: vz, vx: ax, vy: ay, vz: az, q: pz + vz, t: 1})
    false_claim = _prove(Theorem("u.false", start, flow, 2 * q >= t**3))
    true_claim = _prove(Theorem("u.true", start, flow, 6 * q <= t**3 + 3 * t**2))
    assert false_claim.verdict == "refuted" and true_claim.verdict == "proved"
    tau = false_claim.refutation.trace[-1].value
    assert 2 * (tau**3 / 6 + tau**2 / 2) < tau**3  # the witness, by hand


# --------------------------------------------------------------------------- sorts and names


def test_an_integer_cannot_evolve_continuously():
    with pytest.raises(ModelError, match="cannot evolve"):
        ode({Int("n"): 1})


@pytest.mark.parametrize("build", [
    lambda: Theorem("s.two", Int("n") >= 0, assign(Real("n"), 1), Real("n") >= 0),
    lambda: Theorem("s.two", And(Int("n") >= 0, Real("n") <= 1), assign(x, 1), x >= 0),
    lambda: Theorem("s.two", x >= 0, assign(x, 1), ForAll(Int("x"), Int("x") >= 0)),
])
def test_one_symbol_has_one_sort(build):
    with pytest.raises(ModelError, match="two sorts"):
        build()


@pytest.mark.parametrize("name", ["x@1", "F[i]", "B!1", "#universe:B", "a|b", "1x", "a b"])
def test_names_that_could_clash_with_internal_ones_are_refused(name):
    with pytest.raises(ModelError, match="not an identifier"):
        Theorem("s.name", Real(name) >= 0, assign(x, 1), x >= 0)


# --------------------------------------------------------------------------- well-definedness


def _defined_obligations(theorem):
    return [o for o in generate(theorem) if o.kind == "defined"]


def test_guarded_division_is_defined_and_unguarded_is_not():
    ok = Theorem("d.ok", And(b > 0, c > 0), assign(x, 1 / (b + c)), x > 0)
    assert all(discharge_one(o).verdict == "proved" for o in _defined_obligations(ok))
    assert _prove(ok).verdict == "proved"
    bad = _prove(Theorem("d.bad", True, assign(x, 1 / y), x >= 0))
    assert bad.verdict == "unknown" and bad.ill_defined and "1/y" in bad.reason
    # written after the assumptions: b > 0 no longer holds
    written = _prove(Theorem("d.written", b > 0, seq(havoc(b), assign(x, 1 / b)), True))
    assert written.ill_defined


def test_a_quantified_division_in_the_assumptions_proves_nothing():
    # \forall b (b * (1/b) = 1) is false at b = 0 whatever 1/0 means, so it is ill-defined
    result = _prove(Theorem("d.q", ForAll(b, b * (1 / b) == 1), assign(x, 1), x == 2))
    assert result.verdict != "proved" and result.ill_defined


def test_short_circuit_guards_make_divisions_defined():
    guarded = Theorem("d.sc", True, seq(havoc(y), guard(And(y != 0, 1 / y > 1)), assign(x, 1 / y)), x < 1)
    assert all(discharge_one(o).verdict == "proved" for o in _defined_obligations(guarded))


def test_a_differential_invariant_with_a_division_needs_its_denominator():
    # x*(1/x) = 1 "holds" along x' = -1 from 1 only until x = 0 at t = 1
    result = _prove(Theorem("d.dI", x == 1, ode({x: -1}, invariants=[x * (1 / x) == 1]), x != 0))
    assert result.verdict == "refuted"
    assert result.refutation.trace[-1].value == 1  # the flow reaches x = 0 after exactly 1 s


# --------------------------------------------------------------------------- the verdict


def _ob(verdict, kind="safety"):
    return ObligationResult("o1", "p", verdict, 0.0, kind=kind)


@pytest.mark.parametrize("obligations, run, verdict", [
    ([_ob("proved")], None, "proved"),
    ([_ob("proved"), _ob("unknown")], None, "unknown"),
    ([_ob("refuted")], None, "unknown"),  # a failed obligation alone refutes nothing
    ([_ob("refuted")], RunEvidence(True, True, True), "refuted"),
    ([_ob("refuted")], RunEvidence(True, False, True), "unknown"),  # did not replay
    ([_ob("refuted")], RunEvidence(True, True, False), "unknown"),  # a flow did not check
    ([_ob("refuted", "defined")], RunEvidence(True, True, True), "unknown"),  # ill-defined claim
])
def test_the_theorem_verdict_is_decided_in_one_place(obligations, run, verdict):
    assert decide_theorem(obligations, run).verdict == verdict


def test_proofs_and_a_confirmed_run_that_disagree_are_an_internal_inconsistency():
    decision = decide_theorem([_ob("proved")], RunEvidence(True, True, True, "replayed"))
    assert decision.inconsistent and decision.verdict == "unknown" and "INCONSISTENCY" in decision.reason


# --------------------------------------------------------------------------- budgets


def test_verdicts_depend_on_the_resource_budget_not_the_clock():
    from certiloop.proofs.engine import Budget

    # no literal bounds x or y, so exact intervals over a box (proofs/core/boxes.py) cannot decide it
    # either: only z3 can, given the units
    hard = Theorem("b.hard", And(x * x * y - 3 * y * y * x > 1, x * y < -2), assign(q, 1), x * x * y * y > 4)
    starved = Prover(jobs=1, budget=Budget(rlimit=50))
    with starved:
        result = starved.prove(hard)
    assert result.verdict == "unknown" and "resource budget" in result.obligations[0].reason
    assert _prove(hard).verdict == "proved"


# --------------------------------------------------------------------------- crash classes (item 10)


def test_falsify_with_unsatisfiable_assumptions_says_no_run_could_start():
    from certiloop.falsify.search import Options, falsify

    x, y = Reals("x y")
    theorem = Theorem("u.unsat", And(x > 1, x < 0), assign(y, x), y > 5)
    found = falsify(theorem, Options(max_examples=50, database=None))
    assert not found.found and "assumptions satisfiable" in found.note


def test_falsify_names_the_test_that_stops_every_run():
    # [flow](t >= 2 -> P) reads as [flow; ?t >= 2]P, and the domain keeps t below ln 2: every run
    # stops at the test. The note used to blame the assumptions, which hold at x = -1, t = 0.
    from certiloop.falsify.search import Options, falsify

    x, t = Reals("x t")
    theorem = Theorem("u.test", And(x == -1, t == 0), ode({x: 1 - x, t: 1}, x < 0) >> guard(t >= 2), x >= 1)
    found = falsify(theorem, Options(max_examples=50, database=None))
    assert not found.found and "test t >= 2 failed" in found.note and "assumptions" not in found.note


def test_falsify_follows_a_flow_up_to_its_finite_escape_time():
    from certiloop.falsify.search import Options, falsify

    x, t = Reals("x t")
    theorem = Theorem("u.escape", And(x == 1, t == 0), ode({x: x * x, t: 1}), x <= 100, expected="refuted")
    found = falsify(theorem, Options(max_examples=50, database=None))
    assert found.found  # x = 1/(1 - t) passes 100 before it escapes at t = 1
    last = found.run.checkpoints[-1].state
    # independent: the exact solution 1/(1-t) reaches 100 at t = 0.99 and escapes at t = 1
    assert last["x"] > 100 and 0.99 < last["t"] < 1 + 1e-6


def test_gate_fails_a_model_whose_assumptions_no_run_can_meet(tmp_path, capsys):
    from certiloop.cli.main import main

    model = tmp_path / "vacuous_models.py"
    model.write_text("from certiloop.models import And, Reals, Theorem, assign\n"
                     "x, y = Reals('x y')\n"
                     "vacuous = Theorem('u.vacuous', And(x > 1, x < 0), assign(y, x), y > 5)\n")
    assert main(["gate", f"{model}:vacuous", "--no-cache", "--falsify-examples", "50"]) == 1
    assert "assumptions satisfiable" in capsys.readouterr().out


def test_a_real_variable_set_to_an_integer_literal_in_one_branch_stays_real():
    """The run search once gave `x` the sort of its first branch's value: after `x := 0` it
    became an integer, and the run through `x := y/3` could not be found (unknown)."""
    x, y = Reals("x y")
    program = choice(branch("zero", assign(x, 0)), branch("third", assign(x, y / 3)))
    theorem = Theorem(name="choice_sort", assumptions=y == 1, program=program,
                      guarantee=Not(x == y / 3), expected="refuted")
    with Prover(jobs=1) as prover:
        result = prover.prove(theorem)
    assert result.verdict == "refuted" and result.run.confirmed
    assert result.refutation.raw_initial["y"] == 1
