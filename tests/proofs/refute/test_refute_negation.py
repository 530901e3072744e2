"""Refutation by a proof of the negation at a state (proofs/refute/negation.py): claims false
for a reason no single run shows -- a diamond no flow reaches, a modality or a quantifier
inside a formula, a flow without a polynomial solution -- are refuted with a state, and each
state is checked here by other means (arithmetic on the state, numerical integration);
valid claims of the same shapes are never refuted, and a wrong negation would be caught."""

import json
import os
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models.kyx import read_entries
from certiloop.models.lang.terms import And, Exists, ForAll, Iff, Implies, Not, Or, Real, cmp, const
from certiloop.proofs.core.solver import check_valid
from certiloop.proofs.core.verdicts import ObligationResult
from certiloop.proofs.engine.prover import Prover
from certiloop.proofs.refute import negation

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
FALSE, VALID = FIXTURES / "kyx_negation_false.kyx", FIXTURES / "kyx_negation_valid.kyx"


def prove_archive(path: Path) -> dict:
    out = {}
    with Prover(jobs=1) as prover:
        for entry in read_entries(path.read_text(), str(path)):
            try:
                out[entry.name] = prover.prove(entry.theorem).to_json()
            except ValueError as exc:  # ModelError: not supported
                out[entry.name] = {"verdict": "not supported", "reason": str(exc)}
    return out


def start(result) -> dict[str, Fraction]:
    shown = result["counterexample"]["initial"].items()
    return {k: Fraction(v.split(" (= ")[-1].rstrip(")")) for k, v in shown}


def test_false_claims_are_refuted_with_a_state_checked_independently():
    from scipy.integrate import solve_ivp

    results = prove_archive(FALSE)
    for name, r in results.items():
        assert r["verdict"] == "refuted", (name, r.get("reason"))
        assert r["run_check"]["negation_proved"], name
    s = start(results["parallel flows never meet"])
    assert s["p"] - s["q"] != 2  # p - q never changes under p' = q' = u
    assert start(results["domain gap blocks the goal"]) == {"s": 1}  # from 1 the flow stops at 2 < 5
    assert start(results["box in the antecedent"])["z_prime"] != 3
    y0 = start(results["decay never reaches zero"])["y"]
    flow = solve_ivp(lambda t, y: -3 * y, (0, 20), [float(y0)], rtol=1e-10, atol=1e-300)
    assert y0 == 2 and flow.success and flow.y.min() > 0


def test_valid_claims_of_the_same_shapes_are_never_refuted():
    results = prove_archive(VALID)
    assert {n: r["verdict"] for n, r in results.items()} == {
        "flows that do meet": "proved", "domain without a gap": "proved",
        "box in the antecedent, same value": "proved", "quantifier that holds": "proved",
        "decay reaches a half": "unknown"}  # read since nested unsolved flows are: never refuted


def _refutations_of_valid_entries(prover) -> list[str]:
    """The valid entries (with obligations) refuted by a proof of the negation at any of a few
    states each, handed over as if a failed obligation's solver model had proposed them."""
    found = []
    for entry in read_entries(VALID.read_text(), str(VALID)):
        if entry.name == "decay reaches a half":
            continue
        theorem = entry.theorem
        for state in negation.small_states(theorem):
            fake = ObligationResult("o1", "postcondition", "unknown", 0.0, raw_model=state)
            if prover._refute_by_negation(theorem, [fake]) is not None:
                found.append(entry.name)
    return found


def test_no_state_refutes_a_valid_claim_and_a_wrong_negation_would(monkeypatch):
    """Valid claims are refuted at no candidate state; a negation that forgets to negate the
    consequent of an implication would 'refute' them, so the check is not blind."""
    with Prover(jobs=1) as prover:
        assert _refutations_of_valid_entries(prover) == []
        monkeypatch.setattr(negation, "negate", lambda f: And(*f.args) if f.op == "implies" else f)
        assert "flows that do meet" in _refutations_of_valid_entries(prover)


x, y = Real("x"), Real("y")
atoms = st.sampled_from([cmp(op, a, const(c)) for op in ("<", "<=", ">", ">=", "==", "!=")
                         for a in (x, y) for c in (-1, 0, 2)])


def formulas(depth: int = 3):
    if depth == 0:
        return atoms
    sub = formulas(depth - 1)
    return st.one_of(atoms, st.builds(And, sub, sub), st.builds(Or, sub, sub), st.builds(Implies, sub, sub),
                     st.builds(Not, sub), st.builds(lambda f: ForAll(x, f), sub),
                     st.builds(lambda f: Exists(y, f), sub))


@settings(max_examples=150, deadline=None)
@given(formulas())
def test_negate_is_the_negation(f):
    answer = check_valid(Iff(negation.negate(f), Not(f)), 1_000_000)
    assert answer.status == "unsat", (str(f), str(negation.negate(f)))


def test_cli_shows_a_state_not_a_run():
    proc = subprocess.run([sys.executable, "-m", "certiloop.cli", "prove",
                           f'{FALSE}:"parallel flows never meet"', "--json", "-"], capture_output=True,
                          text=True, timeout=300, env={**os.environ, "COLUMNS": "200"})
    data = json.loads(proc.stdout)[0] if proc.stdout.startswith("[") else json.loads(proc.stdout)
    assert proc.returncode == 1 and data["verdict"] == "refuted"
    assert data["counterexample"]["trace"] == []
    assert data["counterexample"]["check"] == "a proof of the negation"


@pytest.mark.parametrize("shape", ["modal", "first-order"])
def test_candidates_pin_every_symbol_of_the_claim(shape):
    entry = "box in the antecedent" if shape == "modal" else "quantifier after an assignment"
    theorem = next(e.theorem for e in read_entries(FALSE.read_text(), str(FALSE), only=entry) if e.theorem)
    states = negation.candidates(theorem, [{}, {"unrelated": Fraction(3)}])
    assert len(states) == 1 and set(states[0]) == set(negation.free_vars(negation.claim(theorem)))
