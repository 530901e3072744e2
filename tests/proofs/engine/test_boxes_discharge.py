"""Exact interval arithmetic over boxes (proofs/core/boxes.py) inside discharge: obligations
about a small ball are decided without z3, the report names the backend, and a false claim of
the same shape is never proved. Fixture: tests/fixtures/kyx_boxes.kyx (certiloop's own claims,
in the shape of KeYmaera X's Yang Wu Lin benchmarks, where z3 spent 25-30 s a check).

The witnesses are independent of the module: explicit points, evaluated exactly."""

from fractions import Fraction
from pathlib import Path

import pytest

from certiloop.models.kyx import read_entries
from certiloop.proofs.core import boxes
from certiloop.proofs.core.exact import evaluate
from certiloop.proofs.core.vcgen import generate
from certiloop.proofs.engine import discharge as discharge_module
from certiloop.proofs.engine.discharge import discharge_one
from certiloop.proofs.engine.prover import Prover

FIXTURE = Path(__file__).resolve().parents[2] / "fixtures" / "kyx_boxes.kyx"


def entries() -> dict:
    return {e.name: e.theorem for e in read_entries(FIXTURE.read_text(), str(FIXTURE))}


def obligation(entry: str, path_part: str):
    return next(ob for ob in generate(entries()[entry]) if path_part in ob.path)


def point(**values) -> dict:
    return {k: Fraction(v) for k, v in values.items()}


def test_ball_obligations_are_decided_without_z3(monkeypatch):
    def no_z3(*args, **kwargs):
        raise AssertionError("z3 was asked")

    monkeypatch.setattr(discharge_module, "check_valid", no_z3)
    for part in ("holds initially", "postcondition"):
        result = discharge_one(obligation("start ball inside, unsafe ball outside", part))
        assert (result.verdict, result.backend) == ("proved", "intervals"), part


def test_the_report_names_the_backend():
    with Prover(jobs=1) as prover:
        result = prover.prove(entries()["start ball inside, unsafe ball outside"])
    by_path = {o.path: o for o in result.obligations}
    init = next(o for p, o in by_path.items() if "holds initially" in p)
    assert init.verdict == "proved" and init.backend == "intervals"


@pytest.mark.parametrize("entry, part, witness", [
    # the unsafe ball's centre lies where the invariant holds: the postcondition is false there
    ("unsafe ball inside the invariant", "postcondition",
     point(u="0.95", x="3.05", y="3.05", z="3.05", **{"x@1": "3.55", "y@1": "3.05", "z@1": "2.95"})),
    # a point of the big start ball outside the invariant: "holds initially" is false there
    ("start ball too big for the invariant", "holds initially",
     point(u="0.95", x="4.55", y="3.05", z="3.05")),
])
def test_false_claims_of_the_same_shape_are_not_proved(entry, part, witness):
    ob = obligation(entry, part)
    assert evaluate(ob.formula, witness) is False  # the independent witness: the claim is false
    assert not boxes.proves(ob.formula)
    assert discharge_one(ob).verdict != "proved"
    with Prover(jobs=1) as prover:
        assert prover.prove(entries()[entry]).verdict != "proved"
