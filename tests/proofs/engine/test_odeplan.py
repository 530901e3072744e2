"""The ODE planner's candidate atoms (proofs/engine/odeplan.py): a guarantee written as the
unsafe set it excludes, `!(x <= -1 | y <= -1)` (KeYmaera X's archives write most of theirs so),
gives the links `x > -1` and `y > -1`, after the author's invariants and without any.

The planner is search: the core checks every link, so a wrong atom can only fail to prove.
Each proof here is witnessed by scipy integrating the flow; each false twin must not prove and
is shown false by integration."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from certiloop.models import And, ForAll, Iff, Implies, Not, Or, Reals, Theorem, ode, seq, test
from certiloop.models.lang.terms import cmp
from certiloop.proofs.core.instantiate import has_quantifier
from certiloop.proofs.core.solver import check_here
from certiloop.proofs.core.vcgen import Obligation, generate
from certiloop.proofs.engine import Prover
from certiloop.proofs.engine.discharge import discharge_one
from certiloop.proofs.engine.odeplan import _atoms, _for_search, plan_odes

x, y = Reals("x y")


def verdict(pre, program, post) -> str:
    with Prover(jobs=1) as p:
        return p.prove(Theorem("t", pre, program, post), search=False).verdict


def along(rhs, start, T=3.0):
    sol = solve_ivp(lambda _t, s: rhs(*s), (0.0, T), np.asarray(start, float), method="DOP853",
                    rtol=1e-10, atol=1e-12, dense_output=True)
    assert sol.success
    return sol.sol(np.linspace(0.0, T, 601))


def test_negations_are_pushed_into_comparisons():
    got = _atoms(And(Not(Or(x <= -1, Not(y < 2), Or(x > 3, y >= x))), x * y >= 0))
    assert [a.key for a in got] == [a.key for a in (x > -1, y < 2, x <= 3, y < x, x * y >= 0)]
    # a negated conjunction is a disjunction: no atom of it holds alone
    assert [a.key for a in _atoms(Not(And(x > 0, y > 0)))] == [Not(And(x > 0, y > 0)).key]


def _formulas():
    comparisons = st.builds(lambda op, a, b, c: cmp(op, a * x + b * y, c),
                            st.sampled_from(["<", "<=", ">", ">=", "==", "!="]),
                            st.integers(-2, 2), st.integers(-2, 2), st.integers(-2, 2))
    return st.recursive(comparisons, lambda inner: st.one_of(
        st.builds(Not, inner), st.lists(inner, min_size=2, max_size=3).map(lambda fs: And(*fs)),
        st.lists(inner, min_size=2, max_size=3).map(lambda fs: Or(*fs))), max_leaves=6)


@given(_formulas())
def test_the_atoms_together_mean_the_formula(f):
    # z3 decides it: a wrong negated operator or a disjunct taken as a conjunct fails here
    atoms = _atoms(f)
    assert check_here(Iff(And(*atoms), f), 1_000_000, 60.0).status == "unsat", (f, atoms)


# x' = 1 + y^2 only grows x; y' = -y keeps y's sign (a Darboux identity)
GROWS = {x: 1 + y**2, y: -y}
SHRINKS = {x: -1 - y**2, y: -y}  # x falls below -1 before t = 1
EXCLUDED = Not(Or(x <= -1, y <= -1))


def test_the_excluded_set_after_an_annotation_is_proved_and_witnessed():
    # y > 0 alone does not give x > -1: the guarantee's own atom must join the chain
    assert verdict(And(x == 0, y == 1), ode(GROWS, invariants=[y > 0]), EXCLUDED) == "proved"
    path = along(lambda x, y: [1 + y**2, -y], [0.0, 1.0])
    assert path[0].min() > -1 and path[1].min() > -1


def test_the_excluded_set_without_an_annotation_is_proved_and_witnessed():
    assert verdict(And(x == 0, y == 1), ode(GROWS), Not(Or(x <= -1, y <= 0))) == "proved"
    path = along(lambda x, y: [1 + y**2, -y], [0.0, 1.0])
    assert path[0].min() > -1 and path[1].min() > 0


def test_an_excluded_set_the_flow_reaches_is_not_proved():
    for program in (ode(SHRINKS, invariants=[y > 0]), ode(SHRINKS)):
        assert verdict(And(x == 0, y == 1), program, EXCLUDED) != "proved"
    assert along(lambda x, y: [-1 - y**2, -y], [0.0, 1.0])[0].min() < -1


# ---- a link's trial leaves out quantified hypotheses (z3's qsat can stall on them, 53 s on
# ModelPlex's Planar Flight Motion Safety with Intruder Velocity Uncertainty); only a weaker
# claim is tried, so a link it proves holds, and the planned proof keeps every hypothesis
c, z = Reals("c z")
QUANTIFIED_FACT = ForAll([z], Implies(z >= c, z * z * x >= 0))  # says nothing about the flow


def test_a_links_trial_has_no_quantified_hypothesis():
    ob = Obligation("o1", "p", Implies(And(x > 0, QUANTIFIED_FACT, y > 1), x * y > 0))
    weaker = _for_search(ob).formula
    assert weaker.key == Implies(And(x > 0, y > 1), x * y > 0).key
    assert check_here(Implies(weaker, ob.formula), 1_000_000, 60.0).status == "unsat"
    assert _for_search(Obligation("o2", "p", x > 0)).formula.key == (x > 0).key


def test_the_planner_tries_no_quantified_formula_and_the_proof_keeps_its_facts():
    # y' = -x*y keeps y's sign (Darboux); the test's quantified fact only rides along
    theorem = Theorem("t", And(x == 1, y == 1, c >= 0), seq(test(QUANTIFIED_FACT), ode({x: y, y: -x * y})),
                      y > 0)
    tried = []

    def spy(ob):
        tried.append(ob.formula)
        return discharge_one(ob)

    plan = plan_odes(theorem, spy)
    assert plan and tried and not any(has_quantifier(f) for f in tried)
    obligations = generate(theorem, plan)
    assert any(has_quantifier(ob.formula) for ob in obligations)  # the proof itself keeps the fact
    with Prover(jobs=1) as p:
        assert p.prove(theorem, search=False).verdict == "proved"
    path = along(lambda x, y: [y, -x * y], [1.0, 1.0])
    assert path[1].min() > 0


def test_a_chain_listed_backwards_is_reordered():
    """p >= 0 needs q >= 0, which needs r >= 0, which needs s >= 0 (each the next one's rate),
    but the assumptions list them p, q, r, s: a failing link moves to the chain's end again
    after the links moved behind it (essential.kyx's triple integrator)."""
    p, q, r, s = Reals("p q r s")
    flow = ode({p: q, q: r, r: s, s: s ** 2 + 1})
    start = And(p >= 0, q >= 0, r >= 0, s >= 0)
    assert verdict(start, flow, p >= 0) == "proved"
    rng = np.random.default_rng(3)
    for _ in range(20):  # witness: nonnegative starts keep p >= 0 (short horizon: s blows up)
        path = along(lambda p, q, r, s: [q, r, s, s * s + 1], rng.uniform(0, 1, 4), T=0.5)
        assert path[0].min() >= -1e-12
    # the false twin: r may start negative, and p goes below 0
    assert verdict(And(p >= 0, q >= 0, r >= -1, s >= 0), flow, p >= 0) != "proved"
    assert along(lambda p, q, r, s: [q, r, s, s * s + 1], [0, 0, -1, 0], T=0.5)[0].min() < 0
