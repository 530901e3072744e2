"""Differential symbols after a flow inside a test's modality, and certiloop's renaming
metadata (a red team's findings: both gave wrong verdicts).

dL: after every run of {y' = 1}, y' = 1 holds (also after the run of duration 0), so
`[{y'=1}] y'=1` is valid and a test of it always passes; `<{y'=1}> y' != 1` never does. The
truth of each claim below follows from that alone."""

import pytest

from certiloop.models.kyx import read_entries
from certiloop.proofs.engine.prover import Prover

CLAIMS = [  # (problem, true?)
    ("x = 0 & y' = 2 -> [ ?([{y' = 1}] y' = 1); x := 1; ] x = 0", False),  # the test passes
    ("x = 0 -> [ ?([{y' = 1}] y' = 1); x := 1; ] (x = 0 | y' = 1)", False),  # y' = 2 at the start
    ("x = 0 & y' = 0 -> [ { ?(<{y' = 1 & y <= 5}> y' = 1); x := x + 1; }* ] x = 0", False),
    ("x = 0 -> [ ?(!([{y' = 1}] y' = 1)); ] x = 1", True),  # the test never passes
    ("x = 0 -> [ ?(<{y' = 1}> y' != 1); ] x = 1", True),
]


@pytest.mark.parametrize("problem, true", CLAIMS)
def test_a_differential_symbol_after_a_flow_in_a_test(problem, true):
    text = f'ArchiveEntry "t" ProgramVariables Real x; Real y; End. Problem {problem} End. End.'
    (entry,) = read_entries(text)
    with Prover(jobs=1) as prover:
        verdict = prover.prove(entry.theorem).verdict
    assert verdict == ("proved" if true else "refuted")


def test_a_renaming_that_merges_two_symbols_is_refused():
    text = """ArchiveEntry "merge" /*@certiloop {"names": {"y": "x"}} */
      ProgramVariables Real x; Real y; End.
      Problem x = 0 -> [ y := 1; ] y = x End.
    End."""
    (entry,) = read_entries(text)
    assert entry.theorem is None and "a name the entry already uses" in entry.error
    (entry,) = read_entries(text.replace('{"y": "x"}', '{"y": "z", "x": "z"}'))
    assert entry.theorem is None and "two symbols to one name" in entry.error
