"""The proof checker (proofs/checker): certificates the prover writes are accepted, each leaf
is the formula hand mathematics gives, wrong hints are rejected, rules not covered yet are
refused with exit 1, and the command's exit codes and SMT-LIB export."""

import json
from dataclasses import replace

import z3

from certiloop.cli.main import main
from certiloop.models.lang.programs import assign, loop, ode, seq, test
from certiloop.models.lang.terms import And, Exists, Implies, Reals, cmp
from certiloop.models.lang.theorem import Theorem
from certiloop.models.library import textbook
from certiloop.proofs.arith.smtlib import script
from certiloop.proofs.checker import check, check_file
from certiloop.proofs.engine.certificate_writer import certificate

x, y, v, a = Reals("x y v a")


def _doc(theorem: Theorem, plan=None) -> dict:
    return json.loads(json.dumps(certificate(theorem, plan or {})))


def test_a_leaf_is_the_formula_hand_mathematics_gives():
    """x >= 0 -> [?x <= 5; x := x + 1] x >= 1: one leaf, x >= 0 & x <= 5 -> x + 1 >= 1."""
    t = Theorem("tiny.step", x >= 0, seq(test(x <= 5), assign(x, x + 1)), x >= 1)
    doc = _doc(t)
    assert [leaf["path"] for leaf in doc["leaves"]] == ["postcondition"]
    assert doc["leaves"][0]["smtlib"] == script(Implies(And(x >= 0, x <= 5), x + 1 >= 1))
    assert check(doc).status == "accepted"


def test_the_solution_rule_checks_the_recorded_solution_by_differentiation():
    """x' = v, v' = a from the start: x(s) = x + v s + a s^2 / 2, v(s) = v + a s."""
    plant = ode({x: v, v: a}, v >= 0)
    t = Theorem("tiny.flow", And(x >= 0, v >= 0, a >= 0), loop(plant, invariant=x >= 0), x >= 0,
                constants=(a,))
    doc = _doc(t)
    ode_rule = next(r for r in doc["rules"] if r["rule"] == "solve")
    assert check(doc).status == "accepted"
    wrong = json.loads(json.dumps(doc))
    rule = next(r for r in wrong["rules"] if r["rule"] == "solve")
    rule["solution"]["x"] = ode_rule["solution"]["v"].replace("'v'", "'x'", 1)  # x(s) = x + a s: not x's
    outcome = check(wrong)
    assert outcome.status == "rejected" and "solution" in outcome.message


def test_a_differential_invariant_that_is_not_one_is_rejected():
    """x' = -x keeps x >= 0 (dI: x' = -x is not >= 0 everywhere, so dI fails) but dbx with
    cofactor -1 proves it; a chain claiming dI must be rejected by its own premise."""
    plant = ode({x: -x}, invariants=[x >= 0])
    t = Theorem("tiny.decay", x >= 0, plant, x >= 0)
    doc = _doc(t)
    chain = next(r for r in doc["rules"] if r["rule"] == "dC")["chain"]
    assert chain[0]["method"] == "dbx"  # the annotation's Darboux identity p' = -1 * p
    assert check(doc).status == "accepted"
    from certiloop.proofs.core.odes import OdeStep

    as_di = _doc(t, {plant.key: (OdeStep(x >= 0, "dI"),)})
    outcome = check(as_di)
    assert outcome.status == "rejected" and "derivative condition" in outcome.message


def test_a_rule_not_covered_yet_is_refused_never_accepted():
    from certiloop.models.lang.terms import Real

    w = Real("w")  # a witness (∃ around a loop): not a rule the checker follows yet
    t = Theorem("tiny.witness", x >= 0, loop(assign(x, x + 1)), x >= 0, witnesses=((w, x),))
    outcome = check(_doc(t))
    assert outcome.status == "rejected" and outcome.exit_code == 1
    assert "rule witness not checkable yet" in outcome.message


def test_the_progress_rule_is_checked_by_its_own_premise():
    """x' = x^2 keeps x >= 0 (at x = 0 the flow rests: f = 0), which the strict barrier cannot
    show; -x^3 >= 0 under x' = 1 is false from x = 0 (p' = p'' = 0 there, f = 1): rejected."""
    from certiloop.proofs.core.odes import OdeStep

    rests = ode({x: x * x}, invariants=[x >= 0])
    kept = Theorem("tiny.progress", x >= 0, rests, x >= 0)
    assert check(_doc(kept, {rests.key: (OdeStep(x >= 0, "progress"),)})).status == "accepted"
    moves = ode({x: 1}, invariants=[-x * x * x >= 0])
    false = Theorem("tiny.cubic", cmp("==", x, 0), moves, -x * x * x >= 0)
    outcome = check(_doc(false, {moves.key: (OdeStep(-x * x * x >= 0, "progress"),)}))
    assert outcome.status == "rejected" and "z3 says sat" in outcome.message


def test_a_division_by_zero_is_a_failing_leaf():
    """x >= 0 -> [y := 1/x] y >= 0 divides by 0 at x = 0: its well-definedness leaf
    x >= 0 -> x != 0 is false, so no certificate of it is accepted (1/x >= 0 holds for x > 0)."""
    t = Theorem("tiny.divide", x >= 0, assign(y, 1 / x), y >= 0)
    doc = _doc(t)
    assert doc["leaves"][0]["smtlib"] == script(Implies(x >= 0, x != 0))
    outcome = check(doc)
    assert outcome.status == "rejected" and "well-defined" in outcome.message


def test_check_proof_exit_codes_and_smtlib_export(tmp_path, capsys):
    good = tmp_path / "ball.json"
    good.write_text(json.dumps(certificate(textbook.bouncing_ball(), {})))
    bad = tmp_path / "tilt.json"
    bad.write_text(json.dumps(certificate(textbook.bouncing_ball_superelastic(), {})))
    broken = tmp_path / "broken.json"
    broken.write_text("{not json")
    out = tmp_path / "smt"
    assert main(["check-proof", str(good), "--smtlib", str(out)]) == 0
    assert main(["check-proof", str(good), str(bad)]) == 1
    assert main(["check-proof", str(good), str(broken)]) == 2
    text = capsys.readouterr().out
    assert "accepted: textbook.bouncing_ball" in text and "z3 says sat" in text and "malformed" in text
    files = sorted(out.glob("*.smt2"))
    assert len(files) == len(json.loads(good.read_text())["leaves"])
    for f in files:  # any solver can re-run them: z3 from the file alone says unsat
        solver = z3.Solver()
        solver.from_file(str(f))
        assert solver.check() == z3.unsat


def test_prove_writes_a_certificate_the_checker_accepts(tmp_path):
    assert main(["prove", "textbook.water_tank", "--certificate", str(tmp_path), "-q"]) == 0
    (path,) = tmp_path.glob("*.json")
    assert check_file(path).status == "accepted"


def test_extra_or_missing_fields_are_malformed():
    doc = _doc(textbook.water_tank())
    extra = dict(doc, comment="trust me")
    missing = {k: v for k, v in doc.items() if k != "tree"}
    assert check(extra).exit_code == 2 and check(missing).exit_code == 2


def test_prove_check_reports_checked_and_never_keeps_a_rejected_proof(monkeypatch, capsys):
    """--check: the checker's acceptance shows as `proved (checked)`; a rejection makes the
    verdict unknown with the checker's message (exit 1); without --check nothing changes."""
    assert main(["prove", "textbook.water_tank", "--check"]) == 0
    assert "textbook.water_tank: proved (checked)" in capsys.readouterr().out
    assert main(["prove", "textbook.water_tank"]) == 0
    plain = capsys.readouterr().out
    assert "textbook.water_tank: proved (" in plain and "checked" not in plain
    from certiloop.proofs import checker
    from certiloop.proofs.checker.certificate import Outcome

    monkeypatch.setattr(checker, "check", lambda doc: Outcome("rejected", "rejected: leaf o2 (tampered)"))
    assert main(["prove", "textbook.water_tank", "--check"]) == 1
    text = " ".join(capsys.readouterr().out.split())  # the console wraps long lines
    assert "textbook.water_tank: unknown" in text and "rejected: leaf o2 (tampered)" in text


def test_a_ghost_is_checked_by_its_existence_leaf_then_assumed():
    """x = 0 -> [x := x + 1] x >= 0 with a ghost g0 and the fact g0*g0 >= 1: hand mathematics
    gives two leaves, x = 0 -> ∃g0 g0*g0 >= 1, and x = 0 & g0*g0 >= 1 -> x + 1 >= 0."""
    g0 = Reals("g0")[0]
    t = Theorem("tiny.ghost", cmp("==", x, 0), assign(x, x + 1), x >= 0, ghosts=(("g0", g0 * g0 >= 1),))
    doc = _doc(t)
    assert [leaf["path"] for leaf in doc["leaves"]] == ["ghost g0: g0*g0 >= 1 / exists", "postcondition"]
    assert doc["leaves"][0]["smtlib"] == script(Implies(cmp("==", x, 0), Exists((g0,), g0 * g0 >= 1)))
    assert doc["leaves"][1]["smtlib"] == script(Implies(And(cmp("==", x, 0), g0 * g0 >= 1), x + 1 >= 0))
    assert check(doc).status == "accepted"
    # a ghost whose fact has no solution would let the proof assume false: its leaf fails
    impossible = _doc(replace(t, ghosts=(("g0", g0 * g0 < 0),)))
    outcome = check(impossible)
    assert outcome.status == "rejected" and "leaf o1 (ghost g0" in outcome.message
    # the certificate's ghost fact changed to another (its hash made to match): leaves differ
    import hashlib

    tampered = json.loads(json.dumps(doc))
    text = tampered["theorem"]["canonical"]
    fact = text.index("('ghosts'")
    text = text[:fact] + text[fact:].replace("'>='", "'>'", 1)
    tampered["theorem"].update(canonical=text, hash=hashlib.sha256(text.encode()).hexdigest()[:16])
    outcome = check(tampered)
    assert outcome.status == "rejected" and "tree" in outcome.message  # the ghost is on the path
