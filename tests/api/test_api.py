"""The Python API (`certiloop.api`) is what the command line calls: the same verdicts, and a
counterexample that holds up when its guarantee is evaluated independently here."""

from fractions import Fraction

from certiloop import api
from certiloop.api.gate_run import GateEntry
from certiloop.models.lang.theorem import Theorem


def test_prove_takes_a_name_or_a_theorem_and_proves_the_train():
    by_name = api.prove("textbook.train")
    theorem = api.load("textbook.train")
    assert isinstance(theorem, Theorem)
    by_theorem = api.prove(theorem)
    assert by_name.verdict == by_theorem.verdict == "proved"
    assert all(o.verdict == "proved" for o in by_name.obligations)


def test_falsify_finds_a_run_that_really_violates_the_guarantee():
    found = api.falsify("textbook.train_no_lookahead", max_examples=300, seed=0)
    assert found.found
    end = found.run.checkpoints[-1].state
    # the guarantee p <= m, evaluated here in exact rationals from the run's own end state
    p, m = Fraction(end["p"]), Fraction(end["m"])
    assert p > m


def test_gate_checks_each_model_against_its_expectation():
    entries = api.gate(["textbook.train", "textbook.train_no_lookahead"], falsify_examples=50)
    assert [type(e) for e in entries] == [GateEntry, GateEntry]
    assert [(e.model, e.verdict) for e in entries] == [("textbook.train", "proved"),
                                                        ("textbook.train_no_lookahead", "refuted")]
    assert all(e.passed for e in entries)
