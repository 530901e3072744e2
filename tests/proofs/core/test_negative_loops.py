"""Loops in negative places of a guarantee: under `!`, on the left of `->`, in `<->`, in
several disjuncts (models/lang/nesting.py `positive_form`, proofs/core/bounded.py).

Each verdict has an independent witness: the loops here are `x := x + c`, whose runs from x0
reach exactly x0 + k*c for k = 0, 1, 2, ..., so each claim's truth is computed by hand in
Python over the first 2,000 iterations (more than any bound the claims name). A claim the
oracle calls false is never proved, and each false twin below would be proved by the mutant
of the rule it targets (noted at the test)."""

from __future__ import annotations

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from certiloop.models.kyx import KyxError, read_entries
from certiloop.models.lang.nesting import positive_form
from certiloop.models.lang.terms import (
    And,
    Exists,
    ForAll,
    Iff,
    Implies,
    Node,
    Not,
    Or,
    Real,
    cmp,
    const,
    div,
)
from certiloop.proofs.core.solver import check_here
from certiloop.proofs.core.wd import defined
from certiloop.proofs.engine import Prover

K = range(2000)


def reach(x0, c):
    """The values of x along the runs of {x := x + c}* from x0 (the first 2,000)."""
    return [x0 + k * c for k in K]


def entry(problem: str):
    (e,) = read_entries(f'ArchiveEntry "e" ProgramVariables Real x, y, z; End. Problem {problem} End. End.')
    if e.error:
        raise KyxError(e.error)
    return e.theorem


def verdict(problem: str) -> str:
    with Prover(jobs=1) as p:
        return p.prove(entry(problem)).verdict


UP, DOWN, TWO = "{x := x + 1;}*", "{x := x - 1;}*", "{x := x + 2;}*"

# (claim at x = 0 or for every x, oracle for the claim at x0, whether certiloop proves it)
CLAIMS = [
    (f"x >= 0 -> !<{UP}> x < 0", lambda x0: x0 < 0 or not any(v < 0 for v in reach(x0, 1)), True),
    (f"[{UP}] x >= 0 -> x >= 0 & x + 1 >= 0",
     lambda x0: not all(v >= 0 for v in reach(x0, 1)) or (x0 >= 0 and x0 + 1 >= 0), True),
    (f"x = 0 -> !([{UP}] x <= 2)", lambda x0: x0 != 0 or not all(v <= 2 for v in reach(x0, 1)), True),
    (f"x >= 0 -> ([{UP}] x >= 0 <-> x >= 0)",
     lambda x0: x0 < 0 or (all(v >= 0 for v in reach(x0, 1)) == (x0 >= 0)), True),
    (f"[{UP}] x >= 0 -> [{TWO}] x >= 0",
     lambda x0: not all(v >= 0 for v in reach(x0, 1)) or all(v >= 0 for v in reach(x0, 2)), True),
    (f"x = 0 -> ([{UP}] x <= 2 -> false)", lambda x0: x0 != 0 or not all(v <= 2 for v in reach(x0, 1)), True),
    (f"x = 0 -> !(!<{UP}> x > 2)", lambda x0: x0 != 0 or any(v > 2 for v in reach(x0, 1)), True),
    (f"x = 0 -> ([{UP}] x <= 2 | [{DOWN}] x <= 0)",
     lambda x0: x0 != 0 or all(v <= 2 for v in reach(x0, 1)) or all(v <= 0 for v in reach(x0, -1)), True),
    # true, but only beyond the 3 iterations a bounded assumption keeps: unknown
    (f"x = 0 -> !([{UP}] x <= 5)", lambda x0: x0 != 0 or not all(v <= 5 for v in reach(x0, 1)), False),
    (f"[{UP}] x <= 10 -> x <= 5", lambda x0: not all(v <= 10 for v in reach(x0, 1)) or x0 <= 5, False),
    # false
    (f"[{UP}] x > 0 <-> x = 1", lambda x0: all(v > 0 for v in reach(x0, 1)) == (x0 == 1), False),
    (f"x = 0 -> !<{UP}> x > 2", lambda x0: x0 != 0 or not any(v > 2 for v in reach(x0, 1)), False),
    (f"x = 0 -> ([{UP}] x >= 0 -> false)",
     lambda x0: x0 != 0 or not all(v >= 0 for v in reach(x0, 1)), False),
    (f"[{UP}] x >= 0 -> [{DOWN}] x >= 0",
     lambda x0: not all(v >= 0 for v in reach(x0, 1)) or all(v >= 0 for v in reach(x0, -1)), False),
    (f"x = 0 -> ([{UP}] x <= 2 | [{DOWN}] x >= -2)",
     lambda x0: x0 != 0 or all(v <= 2 for v in reach(x0, 1)) or all(v >= -2 for v in reach(x0, -1)), False),
    # mutant: assuming <a*>P as its first runs <a^{<=3}>P (stronger than the claim gives)
    (f"x = 0 -> (<{UP}> x >= 10 -> x > 5)",
     lambda x0: x0 != 0 or not any(v >= 10 for v in reach(x0, 1)), False),
    # mutants: !([a*]P) assumed as !([a^{<=3}]P), or as !true
    (f"x = 0 -> (!([{UP}] x <= 3) -> x > 5)", lambda x0: x0 != 0 or all(v <= 3 for v in reach(x0, 1)), False),
    (f"x = 0 -> (!([{UP}] x <= 100) -> x > 5)",
     lambda x0: x0 != 0 or all(v <= 100 for v in reach(x0, 1)), False),
]


FIRST_FALSE = 10


@pytest.mark.parametrize("claim, oracle, proved", CLAIMS, ids=[c for c, _, _ in CLAIMS])
def test_a_negative_loop_is_proved_only_where_the_runs_say_so(claim, oracle, proved):
    starts = [n / 2 for n in range(-12, 13)]
    truth = all(oracle(x0) for x0 in starts)
    got = verdict(claim)
    if got == "proved":
        assert truth, f"{claim} proved, but false at some x0 in {starts}"
    assert (got == "proved") == proved, got


def test_the_false_twins_are_false_by_the_oracle():
    # the claims marked false above really are: the tests cannot pass by calling truths false
    false = [c for c, oracle, _ in CLAIMS[FIRST_FALSE:] if not all(oracle(n / 2) for n in range(-12, 13))]
    assert len(false) == len(CLAIMS) - FIRST_FALSE


def test_a_false_negated_diamond_is_refuted_at_a_state():
    with Prover(jobs=1) as p:
        result = p.prove(entry(f"x = 0 -> !<{UP}> x > 2"))
    assert result.verdict == "refuted"


# a red team's findings: each claim evaluates a division by 0 on some run, or at some value of
# its \\exists, so it must not be proved (it was, through the runs or the value the proof kept)
@pytest.mark.parametrize("claim", [
    "x = 0 & y = 0 -> <{y:=y+1;}*>(y < 4 | 1/x > 0)",  # the 4th iteration reads 1/x
    "x = 0 & y = 0 -> <{y:=y+1; z:=1/(y-5);}*>y = 3",  # the 5th divides by 0
    "x = 0 & y = 0 -> ![{y:=y+1;}*](y>=4 & 1/x>0)",
    "\\exists y [{x:=x+1;}*](y=1 | 1/(y-2)>0)",  # y = 2 divides by 0; the proof tried y = 1
])
def test_every_run_and_every_value_is_checked_defined(claim):
    result = verdict(claim)
    assert result != "proved"


def test_nested_loops_too_large_to_unroll_are_not_tried():
    from certiloop.proofs.core.bounded import MAX_PATHS
    from certiloop.proofs.core.wp import unrolled_paths

    nest = entry("x=0 -> <{{{{x:=x+1;}++{x:=x-1;}}*}*}*>x=27").guarantee.payload
    assert unrolled_paths(nest, 3) > MAX_PATHS  # about 10^10 paths: it used to run for ever
    assert verdict("x=0 -> <{{{{x:=x+1;}++{x:=x-1;}}*}*}*>x=27") == "unknown"
    assert verdict("x=0 -> ([{{{{x:=x+1;}++{x:=x-1;}}*}*}*]x>100 -> false)") != "proved"


@pytest.mark.parametrize("claim", [
    # at x = 0: the first two disjuncts are false, the third true
    "x = 0 -> ([{x:=x+1;}*] x <= 1 | x > 5 | [{x:=x+2;}*] x >= 0)",
    "x = 0 -> (([{x:=x+1;}*] x >= 0 -> x >= 1) -> x = 0)",
    "x = 0 -> !(<{x:=x+1;}*> x >= 2 <-> x = 1)",  # true <-> false
])
def test_loops_deeper_in_a_condition_are_read(claim):
    assert verdict(claim) == "proved"


@pytest.mark.parametrize("problem, why", [
    ("x > 0 -> <{x:=x+1;}*>[{x:=x-1;}*]x > 5", "diamond's postcondition"),
    ("x > 0 -> !([?[{x:=x+1;}*]x > 0;]x > 0)", "formula of its program"),
    ("([?[{x:=x+1;}*]x > 0;]x > 0) -> x > 0", "formula of a program"),
    ("x = 0 -> ([{x := x + 1;}*] x >= 0 | 1/x > 0)", "division among them"),
])
def test_shapes_still_refused_name_the_reason(problem, why):
    with pytest.raises(KyxError, match="1:") as caught:
        entry(problem)
    assert why in str(caught.value)


# ---- positive_form is an equivalence that keeps where the claim is defined

x, y = Real("x"), Real("y")


def _atoms():
    terms = st.sampled_from([x, y, x - y, x * y, div(x, y), div(1, x), const(1), x + 1])
    return st.tuples(st.sampled_from(["<", "<=", "==", "!="]), terms, terms).map(lambda t: cmp(*t))


def _formulas():
    def grow(inner):
        return st.one_of(
            inner.map(Not),
            st.tuples(inner, inner).map(lambda p: Node("and", p, p[0].sort)),
            st.tuples(inner, inner).map(lambda p: Node("or", p, p[0].sort)),
            st.tuples(inner, inner).map(lambda p: Node("implies", p, p[0].sort)),
            st.tuples(inner, inner).map(lambda p: Iff(*p)),
            inner.map(lambda f: ForAll(y, f)),
            inner.map(lambda f: Exists(y, f)),
        )
    return st.recursive(_atoms(), grow, max_leaves=5)


def valid(f) -> bool:
    return check_here(f, 2_000_000, 60.0).status == "unsat"


@settings(max_examples=60, deadline=None)
@given(_formulas())
@example(Not(Node("and", (cmp("!=", x, 0), cmp(">", div(1, x), 0)), Not(x > 0).sort)))
@example(Not(Node("or", (cmp("==", x, 0), cmp(">", div(1, x), 0)), Not(x > 0).sort)))
@example(Not(Node("implies", (cmp("!=", x, 0), cmp(">", div(1, x), 0)), Not(x > 0).sort)))
def test_positive_form_keeps_the_claim_and_where_it_is_defined(f):
    pushed = positive_form(f, lambda g: True)  # push every negation, not just over loops
    assert not _negation_over_connective(pushed)
    assert valid(Iff(f, pushed))
    assert valid(Iff(defined(f), defined(pushed)))


def _negation_over_connective(f) -> bool:
    if f.op == "not" and f.args[0].op not in ("cmp", "true", "false"):
        return True
    return any(_negation_over_connective(a) for a in f.args)


def test_positive_form_leaves_formulas_without_loops_alone():
    f = Not(And(x > 0, Or(y > 0, Implies(x > 1, y > 1))))
    assert positive_form(f) is f
