"""Vacuity: existentials are only ever strengthened, and a step with no run is caught."""

from fractions import Fraction

from certiloop.models import And, Reals, Theorem, assign, havoc, loop, ode, seq
from certiloop.models import test as guard
from certiloop.models.lang.terms import Exists, ForAll, Implies, Or, Var, free_vars
from certiloop.proofs.core.exact import truth
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.vacuity import nonblocking_obligations, witnessed
from certiloop.proofs.core.vcgen import Names
from certiloop.proofs.engine.prover import discharge_one

x, y, u, D, d, t, e = Reals("x y u D d t e")


def _implies_everywhere(w, f) -> bool:
    """w (its new symbols read as ∀) implies f: z3 on the closed claim."""
    fresh = [Var(n) for n in free_vars(w) if n not in free_vars(f)]
    claim = Implies(ForAll(fresh, w) if fresh else w, f)
    return check_valid(claim, rlimit=1_000_000).status == "unsat"


def test_a_linear_equation_becomes_a_solvable_hypothesis():
    f = Exists(u, And(u * D == d, u >= 0))
    w = witnessed(f, Names())
    assert "exists" not in str(w).lower()
    assert _implies_everywhere(w, f)
    # and it is not vacuous: D = 2, d = 1 satisfies it for the solution u' = 1/2
    sole = [n for n in free_vars(w) if n not in free_vars(f)]
    assert len(sole) == 1 and truth(w, {"D": 2, "d": 1, sole[0]: Fraction(1, 2)})


def test_existentials_distribute_over_branches():
    f = Exists(u, Or(And(u == 1, x >= 0), And(u * 2 == x, x < 0)))
    w = witnessed(f, Names())
    assert w.op == "or" and "exists" not in str(w).lower()
    assert _implies_everywhere(w, f)


def test_a_step_that_can_block_is_not_proved_to_run():
    step = seq(havoc(y), guard(y * y == x), assign(x, y), assign(t, 0), ode({t: 1}, t <= e))
    blocking = Theorem("t.sqrt", And(x >= -1, e > 0), loop(step, x >= -1), x >= -1, check_nonblocking=True)
    (ob,) = nonblocking_obligations(blocking)
    assert discharge_one(ob).verdict != "proved"  # x = -1: no y with y² = x
    fine = Theorem("t.fine", And(x >= 0, e > 0), loop(seq(havoc(y), guard(y * 2 == x), assign(x, y),
                                                          assign(t, 0), ode({t: 1}, t <= e)), x >= 0), x >= 0)
    (ob,) = nonblocking_obligations(fine)
    assert discharge_one(ob).verdict == "proved"
