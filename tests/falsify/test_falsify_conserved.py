"""A flow's domain equality that the flow conserves (falsify/flows.py `conserved_apart`) is
checked where the flow starts and not watched along it: rounding breaks an equality at once,
so before, no float run left the start and no enclosure could certify it. A lifted root's pin
s*s = e (models/kyx/lifting.py) is one.

Witnesses are closed forms (the circle), never the falsifier's own runs."""

from __future__ import annotations

import math

from certiloop.falsify.flows import conserved_apart
from certiloop.falsify.search import Options, falsify
from certiloop.models.kyx import read_entries


def entry(problem: str):
    (e,) = read_entries(f'ArchiveEntry "e" ProgramVariables Real x, y; End. Problem {problem} End. End.')
    assert e.theorem is not None, e.error
    return e.theorem


def search(problem: str):
    return falsify(entry(problem), Options(max_examples=300, seed=0, database=None))


def on_circle(t: float) -> float:
    """x(t) on x' = -y, y' = x from (3, 4): 5 cos(atan2(4, 3) + t)."""
    return 5 * math.cos(math.atan2(4, 3) + t)


def test_only_the_equalities_the_flow_conserves_are_set_apart():
    flow = entry("x = 3 & y = 4 -> [{x' = -y, y' = x & x^2 + y^2 = 25 & x > -5 & x = y}] true").program
    along, conserved = conserved_apart(flow)
    assert [str(c) for c in conserved] == ["x^2 + y^2 = 25"]
    assert "x > -5" in str(along) and "x = y" in str(along)


def test_a_run_along_a_conserved_domain_equality_is_confirmed_by_enclosures():
    found = search("x = 3 & y = 4 -> [{x' = -y, y' = x & x^2 + y^2 = 25}] x >= -4")
    assert found.found and found.validated and "enclosures" in found.check, found.check
    assert on_circle(float(found.run.checkpoints[-1].time)) < -4


def test_an_equality_the_flow_leaves_still_stops_it():
    # d/dt (x^2 + y^2) = 2y = 8 at the start: only the run of duration 0 stays in the domain, and
    # the claim is true. Setting every equality apart finds a "validated" counterexample here.
    assert not search("x = 3 & y = 4 -> [{x' = -y, y' = x + 1 & x^2 + y^2 = 25}] x >= -4").found


def test_a_lifted_root_flow_is_followed_past_its_start():
    # the circle at speed 1/5: the lifted root of x^2 + y^2 is pinned by s*s = x^2 + y^2, and the
    # lifted flow divides by s (enclosure.py makes 1/s a variable of its own)
    found = search("x = 3 & y = 4 -> [{x' = -y/(x^2+y^2)^(1/2), y' = x/(x^2+y^2)^(1/2) & x^2 + y^2 > 0}] "
                   "x >= -4")
    assert found.found and found.validated and "enclosures" in found.check, found.check
    assert on_circle(float(found.run.checkpoints[-1].time) / 5) < -4


def test_the_search_takes_the_root_a_lifted_pin_asks_for():
    # x' = -sqrt(x) from 9: x = (3 - t/2)^2 falls below 1/2. The lifted root starts with
    # s := *; ?(s > 0 & s*s = x): the interpreter takes s = 3, which no draw hits by chance
    theorem = entry("x = 9 -> [{x' = -(x^(1/2)) & x > 0}] x >= 1/2")
    found = falsify(theorem, Options(max_examples=300, seed=0, database=None, batch_runs=0))
    assert found.found and found.validated and "exact" in found.check, found.check
    t = float(found.run.checkpoints[-1].time)
    assert t < 6 and (3 - t / 2) ** 2 < 1 / 2
