"""The subterm abstraction (proofs/core/abstraction.py), checked by substituting the
definitions back and asking z3 whether the result is equivalent to the original formula."""

from certiloop.models import And, Implies, Reals
from certiloop.models.lang.terms import Var, cmp, substitute
from certiloop.proofs.core.abstraction import Instance, abstract
from certiloop.proofs.core.solver import check_valid

p, r, n, q, s = Reals("p r n q s")
d = Var("d@abs0")
D = Instance(d, (p - r) * n)


def _equivalent_once_defined(original, abstracted, inst):
    back = substitute(abstracted, {i.symbol.payload: i.definition for i in inst})
    both = And(Implies(original, back), Implies(back, original))
    return check_valid(both, 200_000).status == "unsat"


def test_a_verbatim_definition_becomes_its_symbol():
    f = Implies(And((p - r) * n >= 0, q > 0), (p - r) * n + q > 0)
    out = abstract(f, [D])
    assert out is not None and "d@abs0" in str(out)
    assert "p" not in str(out.args[1])  # the goal is now over d and q only
    assert _equivalent_once_defined(f, out, [D])


def test_an_atom_without_the_definitions_symbols_is_left_alone():
    f = Implies(And((p - r) * n >= 0, q * s > 1), q * s > 0)
    out = abstract(f, [D])
    assert out is not None
    assert out.args[1].same(f.args[1])  # no p, r, n in the goal: untouched
    assert _equivalent_once_defined(f, out, [D])


def test_an_atom_that_reduces_modulo_the_definition_is_rewritten():
    # p*n - r*n is the definition expanded: found by division, not verbatim
    f = Implies(p * n - r * n >= 1, p * n - r * n + s * s >= 1)
    out = abstract(f, [D])
    assert out is not None and "p" not in str(out)
    assert _equivalent_once_defined(f, out, [D])


def test_no_instance_or_no_fit_gives_none():
    f = Implies(q > 0, q * q > 0)
    assert abstract(f, []) is None
    assert abstract(f, [D]) is None  # nothing to rewrite


def test_abstracted_proof_implies_the_original():
    # valid only through the definition's sign: the abstraction keeps that link
    f = Implies(cmp(">=", (p - r) * n, 0), (p - r) * n * ((p - r) * n) + (p - r) * n >= 0)
    out = abstract(f, [D])
    assert out is not None
    assert check_valid(out, 200_000).status == "unsat"
    assert check_valid(f, 200_000).status == "unsat"
