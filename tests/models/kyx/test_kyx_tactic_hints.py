"""The invariants a KeYmaera X Tactic names, read as hints (tactic_hints.py, hint_placement.py).

A hint is attached like an `@invariant` annotation where the entry has none, and the prover
proves it before using it: a wrong hint can only cost the proof. Independent witnesses: each
theorem read with a tactic hint is compared with the same entry written with the annotation
by hand; verdicts are checked against hand mathematics (an induction argument written in the
test, or a concrete violating run computed with exact rationals)."""

from fractions import Fraction

import pytest

from certiloop.models.kyx import read_entries
from certiloop.models.kyx.tactic_hints import tactic_hints
from certiloop.proofs.engine.prover import Prover

# x grows by y each step, and y by 1. With y >= 0, x >= 0 is kept, but x >= 0 alone is not
# inductive (x := x + y may go negative if y < 0): the loop needs `x >= 0 & y >= 0`.
ENTRY = """ArchiveEntry "{name}"
  ProgramVariables Real x; Real y; End.
  Problem x >= 0 & y >= {low} -> [{{ x := x + y; y := y + 1; }}*{annotation}] x >= 0
  End.
  Tactic "by hand"
    implyR(1); loop({invariant}, 1); <( QE, QE, QE )
  End.
End."""


def entry(invariant: str = '"x>=0 & y>=0"', low: str = "0", annotation: str = "", name: str = "e"):
    (e,) = read_entries(ENTRY.format(name=name, invariant=invariant, low=low, annotation=annotation))
    assert e.error is None, e.error
    return e


def prove(e):
    with Prover(jobs=1) as prover:
        return prover.prove(e.theorem)


# ---------------------------------------------------------------------------- reading


def test_calls_found_in_order_with_both_quotings():
    text = """implyR(1); loop({`v>=0`}, 1); <( QE, QE,
      /* dC("commented out", 1) */
      dC("t>=old(t)", 'R=="[{x'=v,t'=1&v>=0}]x<=m"); diffInvariant("v=old(v)", 1); dI(1);
      dG("y'=-y", "x*y=1", 1); dG("{t'=1}", "x>0", 1); print("loop(\\"no\\", 1)") )"""
    found = [(h.kind, h.tactic, h.text) for h in tactic_hints(text)]
    assert found == [("loop", "loop", "v>=0"), ("ode", "dC", "t>=old(t)"),
                     ("ode", "diffInvariant", "v=old(v)"), ("ode", "dG", "x*y=1"), ("ode", "dG", "x>0")]
    assert tactic_hints(text)[1].locator.startswith("x'=v,t'=1")


def test_a_loop_hint_reads_as_the_same_annotation_written_by_hand():
    hinted = entry()
    by_hand = entry(invariant="1", annotation="@invariant(x >= 0 & y >= 0)")
    assert hinted.theorem.program.key == by_hand.theorem.program.key
    assert any("tactic hint used" in n for n in hinted.notes)


def test_backtick_formulas_read_the_same():
    assert entry(invariant="{`x>=0 & y>=0`}").theorem.program.key == entry().theorem.program.key


def test_the_annotation_wins_over_the_tactic():
    e = entry(invariant='"x>=0 & y>=0 & x<=1000"', annotation="@invariant(x >= 0 & y >= 0)")
    by_hand = entry(invariant="1", annotation="@invariant(x >= 0 & y >= 0)")
    assert e.theorem.program.key == by_hand.theorem.program.key
    assert any("has its own @invariant" in n for n in e.notes)


@pytest.mark.parametrize("bad, why", [('"x>=0 & z>=0"', "`z` is not a name"),
                                      ('"x>=0 &"', "does not parse"),
                                      ('"x+1"', "does not read as an invariant")])
def test_a_bad_hint_is_left_out_with_a_note_and_the_entry_still_reads(bad, why):
    e = entry(invariant=bad)
    plain = entry(invariant="1")  # loop(1, 1): no formula, so no hint
    assert e.theorem.program.key == plain.theorem.program.key
    assert any(why in n for n in e.notes), e.notes


def test_odes_get_the_cut_chain_in_order():
    text = """ArchiveEntry "brake"
      Definitions Real b; End.
      ProgramVariables Real x; Real v; Real t; End.
      Problem b > 0 & v >= 0 -> [{{x' = v, v' = -b*v, t' = 1 & v >= 0}}{annotation}] v <= old_v
      End.
      Tactic "t"
        implyR(1); dC("t>=0", 1); diffInvariant("v <= old(v)", 1); dW(1); QE
      End.
    End."""
    (hinted,) = read_entries(text.format(annotation=""))
    (by_hand,) = read_entries(text.replace("dC(", "skip(").replace("diffInvariant(", "skip(")
                              .format(annotation="@invariant(t >= 0, v <= old(v))"))
    assert hinted.error is None and by_hand.error is None
    assert hinted.theorem.program.key == by_hand.theorem.program.key


def test_a_flow_with_a_polynomial_solution_keeps_it():
    text = """ArchiveEntry "solved"
      Definitions Real b; End.
      ProgramVariables Real x; Real v; End.
      Problem b > 0 & v >= 0 -> [{x' = v, v' = -b & v >= 0}] v >= 0 End.
      Tactic "t" implyR(1); dC("v>=0", 1); dW(1); QE End.
    End."""
    (e,) = read_entries(text)
    (ode,) = [p for p in _flatten(e.theorem.program) if type(p).__name__ == "ODE"]
    assert ode.invariants == ()
    assert any("polynomial solution" in n for n in e.notes)


def test_a_condition_that_changes_along_the_flow_is_left_out():
    # the prover refuses `C -> a` where the flow moves C's variables: the entry must still read
    (e,) = read_entries("""ArchiveEntry "g"
      ProgramVariables Real x; End.
      Problem x > 0 -> [{x' = -x}] x > 0 End.
      Tactic "t" dC("x>=1 -> x>0", 1) End.
    End.""")
    (ode,) = [p for p in _flatten(e.theorem.program) if type(p).__name__ == "ODE"]
    assert ode.invariants == ()
    assert any("not used" in n for n in e.notes)


def test_a_differential_ghost_is_not_used_but_its_ghost_free_postcondition_is():
    text = """ArchiveEntry "g"
      ProgramVariables Real x; End.
      Problem x > 0 -> [{x' = -x}] x > 0
      End.
      Tactic "t" implyR(1); dG("y'=1/2*y", "x*y^2=1", 1); dG("{t'=1}", "x>0", 1); QE End.
    End."""
    (e,) = read_entries(text)
    (ode,) = [p for p in _flatten(e.theorem.program) if type(p).__name__ == "ODE"]
    assert [str(i) for i in ode.invariants] == [str(i) for i in _annotated_ode_invariants("x > 0")]
    assert any("differential ghost" in n for n in e.notes)


def _annotated_ode_invariants(text: str):
    (e,) = read_entries(f"""ArchiveEntry "g" ProgramVariables Real x; End.
      Problem x > 0 -> [{{x' = -x}}@invariant({text})] x > 0 End. End.""")
    (ode,) = [p for p in _flatten(e.theorem.program) if type(p).__name__ == "ODE"]
    return ode.invariants


def _flatten(p):
    from certiloop.models.lang.programs import children

    yield p
    for q in children(p):
        yield from _flatten(q)


# ---------------------------------------------------------------------------- soundness


def test_by_hand_the_right_invariant_is_inductive_and_the_guarantee_alone_is_not():
    """The witness for the verdicts below: x >= 0 & y >= 0 holds at the start, is kept by
    x := x + y (a sum of two numbers >= 0) and y := y + 1, and gives x >= 0. x >= 0 alone is not kept: from
    x = 0, y = -1 (allowed by it) one step gives -1."""
    x, y = Fraction(0), Fraction(-1)
    assert x >= 0 and x + y < 0


def test_the_right_tactic_invariant_proves_and_without_it_the_entry_does_not():
    assert prove(entry()).verdict == "proved"
    assert prove(entry(invariant="1")).verdict != "proved"  # the guarantee is not inductive


def test_a_wrong_tactic_invariant_does_not_prove():
    # x >= 0 & x*y >= 0 holds initially and gives x >= 0, but is not kept: x = 0, y = -1
    x, y = Fraction(0), Fraction(-1)
    assert x >= 0 and x * y >= 0 and not (x + y >= 0)
    assert prove(entry(invariant='"x>=0 & x*y>=0"')).verdict != "proved"


def test_a_hint_on_a_false_entry_does_not_make_it_prove():
    # y >= -1 allows x = 0, y = -1: one step reaches x = -1 < 0, so the claim is false
    x, y = Fraction(0), Fraction(-1)
    x += y
    assert x < 0
    result = prove(entry(low="-1"))
    assert result.verdict != "proved"
    assert result.verdict in ("refuted", "unknown")


def test_a_wrong_cut_on_a_false_flow_does_not_prove():
    # x' = -x from x = 1: x(t) = e^-t < 1 for t > 0, so [x' = -x] x >= 1 is false; the cut x >= 1
    # is not inductive (its derivative -x < 0 where x = 1)
    (e,) = read_entries("""ArchiveEntry "decay"
      ProgramVariables Real x; End.
      Problem x = 1 -> [{x' = -x}] x >= 1 End.
      Tactic "wrong" implyR(1); dC("x>=1", 1); dW(1); QE End.
    End.""")
    assert any("tactic hint used" in n for n in e.notes)
    assert prove(e).verdict != "proved"


# ---------------------------------------------------------------------------- placement

TWO = """ArchiveEntry "two"
  ProgramVariables Real x; Real y; End.
  Problem x >= 0 & y >= 0 -> [{{ x := x + 1; }}*{first}][{{ y := y + x; }}*{second}] y >= 0 End.
  Tactic "t" {tactic} End.
End."""


def loops_of(e):
    return [p for p in _flatten(e.theorem.program) if type(p).__name__ == "Loop"]


def test_two_loop_invariants_go_to_two_loops_in_program_order():
    (e,) = read_entries(TWO.format(first="", second="", tactic='loop("x>=0", 1); loop("x>=0 & y>=0", 1)'))
    (by_hand,) = read_entries(TWO.format(first="@invariant(x>=0)", second="@invariant(x>=0 & y>=0)",
                                         tactic="QE"))
    assert [loop.invariant.key for loop in loops_of(e)] == [loop.invariant.key for loop in loops_of(by_hand)]


def test_one_invariant_for_two_loops_is_not_guessed():
    (e,) = read_entries(TWO.format(first="", second="", tactic='loop("x>=0", 1)'))
    assert [loop.invariant for loop in loops_of(e)] == [None, None]
    assert any("not certain" in n for n in e.notes)


def test_a_cut_goes_to_the_ode_its_position_names():
    text = """ArchiveEntry "flows"
      ProgramVariables Real x; Real y; End.
      Problem x >= 0 & y >= 0 -> [{x' = -x}][{y' = -2*y}] x + y >= 0 End.
      Tactic "t" dC("x>=0", 'R=="[{x'=-x}][{y'=-2*y}]x+y>=0"); dC("y>=0", 'R=="[{y'=-2*y}]x+y>=0") End.
    End."""
    (e,) = read_entries(text)
    odes = [p for p in _flatten(e.theorem.program) if type(p).__name__ == "ODE"]
    assert [[str(i) for i in o.invariants] for o in odes] == [["x >= 0"], ["y >= 0"]]


def test_prove_shows_what_became_of_the_tactics_hints(tmp_path, capsys):
    """An entry not proved says which of its Tactic's invariants were used and which not
    (here the loop has its own annotation, so the tactic's is not used)."""
    import json

    from certiloop.cli.main import main

    path = tmp_path / "e.kyx"
    path.write_text(ENTRY.format(name="own", invariant='"x>=0 & y>=0"', low="0",
                                 annotation="@invariant(x >= 0)"))
    assert main(["prove", str(path), "--jobs", "1", "--json", str(tmp_path / "out.json")]) == 1
    out = capsys.readouterr().out
    assert "the entry's Tactic (its invariants read as hints):" in out and "has its own @invariant" in out
    row = json.loads((tmp_path / "out.json").read_text())  # one model: its object
    assert any("has its own @invariant" in n for n in row["tactic_hints"])
