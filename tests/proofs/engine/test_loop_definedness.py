"""A division that can be by zero inside a loop: ill-defined (exit 2) when a run of the
loop's first iterations divides by zero, `unknown` when only the invariant is too weak.

By hand: from x >= 0, `v := *; x := x + 1/v` divides by v = 0 on the first iteration. From
x >= 1, `x := 1/x + 1` keeps x >= 1, so x is never 0 — the invariant `true` is merely too
weak to show it, and the model is not ill-defined.
"""

from certiloop.models.lang.programs import assign, havoc, loop, seq
from certiloop.models.lang.terms import And, Real
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.engine.early_iterations import unrolled
from certiloop.proofs.engine.prover import Prover

x, v, y = Real("x"), Real("v"), Real("y")


def _prove(theorem):
    with Prover(jobs=1) as prover:
        return prover.prove(theorem)


def test_a_division_by_zero_on_the_first_iteration_is_ill_defined():
    body = seq(havoc(v), assign(x, x + 1 / v))
    result = _prove(Theorem("user.divides", x >= 0, loop(body, x >= 0), x >= 0))
    assert result.ill_defined and result.verdict == "unknown"
    assert "ill-defined" in result.reason and "v@1 = 0" in result.reason


def test_a_division_by_zero_on_the_second_iteration_is_ill_defined():
    # y is 1 on the first iteration (1/y fine), 0 on the second
    body = seq(assign(x, x + 1 / y), assign(y, y - 1))
    result = _prove(Theorem("user.second", And(x >= 0, y == 1), loop(body, x >= 0), x >= 0))
    assert result.ill_defined


def test_a_weak_invariant_alone_is_not_ill_defined():
    result = _prove(Theorem("user.weak", x >= 1, loop(assign(x, 1 / x + 1), True), x >= 1))
    assert not result.ill_defined and result.verdict == "unknown"


def test_unrolling_keeps_every_early_run():
    body = seq(havoc(v), assign(x, x + v))
    text = str(unrolled(loop(body, x >= 0)))
    assert text.count("x := x + v") == 3  # one iteration and two: 1 + 2 copies of the body



def test_the_command_says_ill_defined_on_one_line_and_exits_2(tmp_path, capsys):
    from certiloop.cli import main

    model = tmp_path / "div_model.py"
    model.write_text("from certiloop.models.lang.programs import assign, havoc, loop, seq\n"
                     "from certiloop.models.lang.terms import Real\n"
                     "from certiloop.models.lang.theorem import Theorem\n"
                     "x, v = Real('x'), Real('v')\n"
                     "step = seq(havoc(v), assign(x, x + 1 / v))\n"
                     "thm = Theorem('user.divides', x >= 0, loop(step, x >= 0), x >= 0)\n")
    assert main(["prove", f"{model}:thm", "--jobs", "1", "-q"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("certiloop: error: user.divides is ill-defined")
