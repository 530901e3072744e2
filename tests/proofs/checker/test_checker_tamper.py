"""Tampered certificates are never accepted: any string changed, leaves swapped, dropped or
taken from another model, a branch dropped, an operator, a constant or an invariant changed.
Each mutant must be rejected (exit 1) or malformed (exit 2)."""

import copy
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models import library
from certiloop.models.lang.programs import Loop, Seq
from certiloop.models.library import textbook
from certiloop.proofs.checker import check
from certiloop.proofs.engine.certificate_writer import certificate

# the first three are used by name below; the train divides by a term (well-definedness leaves),
# builtDR quantifies over integer-indexed arrays
MODELS = (textbook.bouncing_ball, textbook.water_tank, textbook.cart_forward, textbook.train,
          lambda: library.get("cfmpa.builtdr"))


@pytest.fixture(scope="module")
def certificates() -> list[dict]:
    docs = [json.loads(json.dumps(certificate(build(), {}))) for build in MODELS]
    assert [check(d).status for d in docs] == ["accepted"] * len(docs)  # the originals pass
    return docs


def _strings(obj, path=()):
    """(path, text) of every string in a JSON document: dict keys and values, list items."""
    if isinstance(obj, str):
        yield path, obj
    elif isinstance(obj, dict):
        for k, v in obj.items():
            yield (*path, ("key", k)), k
            yield from _strings(v, (*path, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _strings(v, (*path, i))


def _replaced(doc, path, new: str):
    doc = copy.deepcopy(doc)
    *outer, last = path
    target = doc
    for step in outer:
        target = target[step]
    if isinstance(last, tuple):  # a dict key renamed
        target[new] = target.pop(last[1])
    else:
        target[last] = new
    return doc


@settings(max_examples=200)
@given(st.data())
def test_any_string_changed_is_never_accepted(certificates, data):
    doc = data.draw(st.sampled_from(certificates))
    path, text = data.draw(st.sampled_from(list(_strings(doc))))
    where = data.draw(st.integers(0, len(text)))
    how = data.draw(st.sampled_from(["insert", "delete", "replace"]))
    char = data.draw(st.sampled_from(list("0123456789 ()<>=+-*/,.'xyzhvg@|_")))
    if how == "insert":
        new = text[:where] + char + text[where:]
    elif how == "delete" and where < len(text):
        new = text[:where] + text[where + 1:]
    else:
        new = text[:where] + char + text[where + 1:]
    if new == text:
        new = text + "1"
    outcome = check(_replaced(doc, path, new))
    assert outcome.status in ("rejected", "malformed"), (path, text[:80], new[:80])
    assert outcome.exit_code in (1, 2)


def _leaf_text_with(doc, old: str, new: str) -> list[dict]:
    """Copies of doc with one occurrence of `old` in one leaf's formula replaced by `new`."""
    out = []
    for i, leaf in enumerate(doc["leaves"]):
        if old in leaf["smtlib"]:
            mutant = copy.deepcopy(doc)
            mutant["leaves"][i]["smtlib"] = leaf["smtlib"].replace(old, new, 1)
            out.append(mutant)
    return out


@pytest.mark.parametrize("old, new", [("(<= ", "(< "), ("(>= ", "(> "), ("(+ ", "(- "), ("(* ", "(+ "),
                                      ("0.0", "1.0"), ("2.0", "3.0"), ("(and ", "(or ")])
def test_a_changed_operator_or_constant_in_a_leaf_is_rejected(certificates, old, new):
    mutants = [m for doc in certificates for m in _leaf_text_with(doc, old, new)]
    assert mutants, f"no leaf holds {old!r}: the test would check nothing"
    assert all(check(m).status == "rejected" for m in mutants)


def test_swapped_dropped_and_foreign_leaves_are_rejected(certificates):
    ball, tank = certificates[:2]
    swapped = copy.deepcopy(ball)
    swapped["leaves"][0], swapped["leaves"][1] = swapped["leaves"][1], swapped["leaves"][0]
    dropped = copy.deepcopy(ball)
    dropped["leaves"].pop()
    foreign = copy.deepcopy(ball)
    foreign["leaves"][0] = copy.deepcopy(tank["leaves"][0])
    foreign_text = copy.deepcopy(ball)
    foreign_text["leaves"][0]["smtlib"] = tank["leaves"][0]["smtlib"]
    for mutant in (swapped, dropped, foreign, foreign_text):
        assert check(mutant).status == "rejected"


def test_a_dropped_branch_of_the_tree_is_rejected(certificates):
    for doc in certificates:
        for i in range(len(doc["tree"]["children"])):
            mutant = copy.deepcopy(doc)
            mutant["tree"]["children"].pop(i)
            assert check(mutant).status == "rejected"


def test_another_models_theorem_over_these_leaves_is_rejected(certificates):
    ball, tank = certificates[:2]
    mutant = copy.deepcopy(ball)
    mutant["theorem"] = copy.deepcopy(tank["theorem"])
    assert check(mutant).status == "rejected"


def _weaker_invariant(t):
    """The bouncing ball with its loop invariant cut down to `0 <= h`: not inductive (the
    energy bound is what keeps the ball below H), so no proof of it may be accepted."""
    loop = t.program
    body = loop.body
    assert isinstance(loop, Loop) and isinstance(body, Seq)
    import dataclasses

    weaker = dataclasses.replace(loop, invariant=loop.invariant.args[0])
    return dataclasses.replace(t, program=weaker)


def test_a_changed_invariant_is_rejected_even_with_a_consistent_certificate(certificates):
    ball = certificates[0]
    changed = _weaker_invariant(textbook.bouncing_ball())
    forged = json.loads(json.dumps(certificate(changed, {})))  # the engine records; it decides nothing
    assert check(forged).status == "rejected"
    spliced = copy.deepcopy(ball)
    spliced["theorem"] = forged["theorem"]
    spliced["rules"] = forged["rules"]
    assert check(spliced).status == "rejected"


@pytest.mark.parametrize("build", [textbook.bouncing_ball_superelastic, textbook.water_tank_late_check,
                                   textbook.cart_may_brake])
def test_a_certificate_for_a_false_claim_is_rejected(build):
    """The refuted textbook variants (each with a run the interpreter replays, see
    test_library) written up as if proved: some leaf is not valid, so z3 never says unsat."""
    outcome = check(json.loads(json.dumps(certificate(build(), {}))))
    assert outcome.status == "rejected", outcome.message
