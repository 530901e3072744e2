"""Two deterministic bounds of proofs/engine/budget.py: the nonlinear size (polysize.py,
MAX_NONLINEAR_SIZE: a formula whose nonlinear arithmetic is too large is left `unknown` without
asking z3) and the obligation count (MAX_OBLIGATIONS: a proof with more obligations is not
tried). Both are pure functions of the claim, so the verdicts do not depend on the clock; and
both only withhold proofs: where one triggers the verdict is `unknown` (or `refuted` by a
confirmed run), never `proved`. Fixture: tests/fixtures/kyx_nonlinear_size.kyx (certiloop's own
claims)."""

from dataclasses import replace
from pathlib import Path

import pytest

from certiloop.models.kyx import read_entries
from certiloop.models.lang.terms import And, Implies, Real, cmp, const
from certiloop.proofs.core.vcgen import TooManyObligations, generate
from certiloop.proofs.engine import discharge as discharge_module
from certiloop.proofs.engine import polysize
from certiloop.proofs.engine.budget import MAX_NONLINEAR_SIZE, Budget
from certiloop.proofs.engine.discharge import discharge_one
from certiloop.proofs.engine.polysize import nonlinear_size
from certiloop.proofs.engine.prover import Prover

FIXTURE = Path(__file__).resolve().parents[2] / "fixtures" / "kyx_nonlinear_size.kyx"
x, y, z = Real("x"), Real("y"), Real("z")


def entries() -> dict:
    return {e.name: e.theorem for e in read_entries(FIXTURE.read_text(), str(FIXTURE))}


def test_the_count_is_mixed_monomials_times_degree_times_coefficient_bits():
    # (x^2 + y^2)^3 = x^6 + 3x^4y^2 + 3x^2y^4 + y^6: two mixed monomials of degree 6, largest coefficient 3
    assert nonlinear_size(cmp("<=", (x**2 + y**2) ** 3, 1)) == 2 * 6 * 2
    # 0.0052726 x^2 y^2 + x^3 - 1: coefficients over 5,000,000 -> 26363, 5000000: 23 bits
    assert nonlinear_size(cmp("<=", const("0.0052726") * x**2 * y**2 + x**3, 1)) == 1 * 4 * 23
    # the largest comparison of the formula counts; degree 2 and below, and one variable, count 0
    small, big = cmp(">=", x * y * z, 0), cmp("<=", (x + y + z) ** 4, 2)
    assert nonlinear_size(And(small, Implies(cmp("<=", x * y, 3), big))) == nonlinear_size(big) > 0
    assert nonlinear_size(cmp("<=", 1000 * x * y + x**2, 1)) == 0
    assert nonlinear_size(cmp("<=", x**9 + 3 * x**4, 1)) == 0


def test_the_count_is_deterministic():
    def build():
        return cmp("<=", const("0.0311") * x**4 * y**4 + const("0.0172") * x**7 * y - (x - y) ** 5, 0)

    first = nonlinear_size(build())
    polysize._cache.clear()
    assert all(nonlinear_size(build()) == first for _ in range(3))
    assert first > 0


def test_an_expansion_too_large_counts_as_too_large():
    assert nonlinear_size(cmp("<=", (x + y + z + 1) ** 40, 1)) == polysize.TOO_LARGE


def test_above_the_bound_z3_is_not_asked_and_the_obligation_is_unknown(monkeypatch):
    theorem = entries()["decimal barrier of degree eight"]
    premise = next(ob for ob in generate(theorem) if "derivative condition" in ob.path)
    assert nonlinear_size(premise.formula) > MAX_NONLINEAR_SIZE

    def no_z3(*args, **kwargs):
        raise AssertionError("z3 was asked")

    monkeypatch.setattr(discharge_module, "check_valid", no_z3)
    result = discharge_one(premise)
    assert result.verdict == "unknown" and "not given to z3" in result.reason


def test_the_bound_turns_a_proof_into_unknown_never_into_a_wrong_verdict():
    found = entries()
    tight = Budget(max_nonlinear_size=10)
    with Prover(jobs=1) as prover:
        assert prover.prove(found["sextic ball kept by decay"]).verdict == "proved"
    runs = []
    for _ in range(2):
        with Prover(jobs=1, budget=tight) as prover:
            runs.append({name: prover.prove(theorem) for name, theorem in found.items()
                         if "choices" not in name})  # the nonlinear ones
    for name, result in runs[0].items():
        assert result.verdict == "unknown", (name, result.verdict)
    first_pass = [discharge_one(ob, tight) for ob in generate(found["sextic ball kept by decay"])]
    assert any(r.verdict == "unknown" and "not given to z3" in r.reason for r in first_pass)
    # the same verdicts and the same reasons, obligation by obligation, every time
    assert [[(o.verdict, o.reason) for o in r.obligations] for r in runs[0].values()] == \
        [[(o.verdict, o.reason) for o in r.obligations] for r in runs[1].values()]


def test_a_false_claim_is_never_proved_whatever_the_bound():
    theorem = entries()["sextic ball left by growth"]
    for budget in (Budget(), Budget(max_nonlinear_size=10), Budget(max_nonlinear_size=0)):
        with Prover(jobs=1, budget=budget) as prover:
            assert prover.prove(theorem).verdict != "proved"


def test_generation_stops_past_the_obligation_limit():
    theorem = entries()["choices multiply"]
    count = len(generate(theorem))
    assert count == 16
    assert len(generate(theorem, limit=count)) == count
    with pytest.raises(TooManyObligations, match="more than 15 obligations"):
        generate(theorem, limit=count - 1)


def test_too_many_obligations_is_unknown_never_proved():
    found = entries()
    valid, false = found["choices multiply"], found["choices multiply past the guarantee"]
    tight = Budget(max_obligations=4)
    for expected in ("proved", "refuted"):
        with Prover(jobs=1) as prover:
            assert prover.prove(replace(valid, expected=expected)).verdict == "proved"
        for _ in range(2):  # the same answer every time
            with Prover(jobs=1, budget=tight) as prover:
                result = prover.prove(replace(valid, expected=expected))
                assert result.verdict == "unknown"
                assert "the proof has more than 4 obligations" in result.obligations[0].reason
                # a false claim is still refuted by a confirmed run, and never proved
                assert prover.prove(replace(false, expected=expected)).verdict == "refuted"
