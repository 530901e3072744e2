import pytest

from certiloop.models import (
    INT,
    And,
    Array,
    Int,
    ModelError,
    Real,
    Reals,
    Theorem,
    assign,
    loop,
    ode,
    seq,
)
from certiloop.models import test as guard
from certiloop.models.lang.programs import written
from certiloop.studies.sbs.models import ctrl1

x, y, G, D = Reals("x y G D")


def theorem(program, assumptions=True, guarantee=None, **kw):
    return Theorem("t", assumptions, program, guarantee if guarantee is not None else x >= 0, **kw)


def test_ode_rejects_the_same_variable_twice():
    with pytest.raises(ModelError, match="x' twice"):
        ode([(x, 1), (x, 2)])


def test_assigning_to_a_declared_constant_is_rejected():
    with pytest.raises(ModelError, match="`G` is declared constant"):
        theorem(seq(assign(G, 1), assign(x, G)), G > 0, constants=(G,))


def test_unknown_symbol_in_guarantee_is_rejected():
    with pytest.raises(ModelError, match="unknown symbol `zz`"):
        theorem(assign(x, 1), guarantee=Real("zz") >= 0)


def test_sort_mismatch_in_assignment():
    k = Int("k")
    with pytest.raises(ModelError, match="real term"):
        assign(k, x)
    P = Array("P", INT, INT)
    with pytest.raises(ModelError, match="whole array"):
        assign(P, 1)


def test_ctrl1_is_table_1():
    t = ctrl1()
    text = t.text
    for mode in ("free zone", "slow zone, towards", "slow zone, away", "past boundary, towards",
                 "past boundary, away"):
        assert mode in text
    assert "py' = G*py/D*fy" in text
    assert set(written(t.program)) == {"fxp", "fyp", "px", "py", "fx", "fy"}


def test_content_hash_is_stable_and_sensitive():
    assert ctrl1().content_hash == ctrl1().content_hash
    other = theorem(loop(assign(x, x + 1), x >= 0), x >= 0)
    changed = theorem(loop(assign(x, x + 2), x >= 0), x >= 0)
    assert other.content_hash != changed.content_hash


def test_content_hash_covers_the_whole_claim():
    """Sorts, invariants, dI annotations, expected verdict, flags and the name all count:
    an Int model proved once must not vouch for its Real twin (a cache key or a kernel pin)."""
    from dataclasses import replace

    from certiloop.models import Int, Real, ode

    def claim(n, inv=None, dI=()):
        return Theorem("h.claim", n >= 0, loop(seq(assign(n, n + 1)), n >= 0 if inv is None else inv), n >= 0)

    base = claim(Int("n"))
    variants = [
        claim(Real("n")),  # same text, another sort
        claim(Int("n"), inv=Int("n") >= -1),  # another invariant
        replace(base, expected="refuted"),
        replace(base, check_nonblocking=True),
        replace(base, name="h.other"),
        replace(base, unroll=5),
        replace(base, scenarios=(Int("n") >= 1,)),
        Theorem("h.claim", Real("x") >= 0, ode({Real("x"): 1}), Real("x") >= 0),
        Theorem("h.claim", Real("x") >= 0, ode({Real("x"): 1}, invariants=[Real("x") >= 0]), Real("x") >= 0),
    ]
    hashes = {v.content_hash for v in variants} | {base.content_hash}
    assert len(hashes) == len(variants) + 1
    assert base.text == claim(Real("n")).text  # the printed text alone cannot tell them apart


def test_expected_verdict_is_validated():
    with pytest.raises(ModelError, match="expected must be"):
        theorem(assign(x, 1), expected="safe")


def test_tests_must_be_formulas():
    with pytest.raises(ModelError, match="expected a formula"):
        guard(x + 1)
    assert And(x > 0, y > 0).op == "and"


def test_a_choice_of_nothing_is_refused():
    """`choice()` has no run, so `[choice()] P` held for every P and `prove` called it proved
    without the vacuity warning (its check generated no obligation)."""
    from certiloop.models import choice

    with pytest.raises(ModelError, match="at least one alternative"):
        choice()


def test_an_empty_sequence_does_nothing():
    """`seq()` was an empty Seq that the refuter indexed ("internal error: IndexError")."""
    from certiloop.models.lang.programs import Test

    assert isinstance(seq(), Test) and seq().cond.op == "true"


def test_a_program_with_a_part_that_is_no_program_is_refused():
    from certiloop.models.lang.programs import Loop, Seq

    with pytest.raises(ModelError, match="body of a loop"):
        loop(x)
    with pytest.raises(ModelError, match="inside Loop"):  # the class itself, not the constructor
        theorem(Loop(x))
    with pytest.raises(ModelError, match="empty sequence"):
        theorem(Seq(()))


@pytest.mark.parametrize("argument, value", [
    ("constants", x), ("scenarios", x >= 0), ("well_defined", (x >= 0,)), ("witnesses", ("del", x)),
    ("ghosts", (("l",),))])
def test_a_collection_argument_given_one_bare_item_names_the_argument(argument, value):
    with pytest.raises(ModelError, match=f"{argument} must be a tuple of"):
        theorem(assign(x, 1), **{argument: value})


@pytest.mark.parametrize("build", [lambda: x % 2, lambda: x // 2, lambda: 2 ** x, lambda: divmod(x, 2),
                                   lambda: 2 % x])
def test_operators_outside_the_arithmetic_are_one_model_error(build):
    with pytest.raises(ModelError, match="not part of the models' arithmetic"):
        build()


def test_a_huge_exponent_is_a_model_error():
    with pytest.raises(ModelError, match="larger than the 10,000 supported"):
        x ** 99_999_999_999
    assert (x ** 10_000).payload == 10_000
