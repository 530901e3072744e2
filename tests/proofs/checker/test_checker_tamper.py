"""Tampered certificates are never accepted: any string changed, leaves swapped, dropped or
taken from another model, a branch dropped, an operator, a constant or an invariant changed.
Each mutant must be rejected (exit 1) or malformed (exit 2)."""

import copy
import json
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.models import library
from certiloop.models.lang.programs import Loop, Seq
from certiloop.models.library import textbook
from certiloop.proofs.checker import check
from certiloop.proofs.checker.certificate import FORMAT, FORMAT_V2
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


# --------------------------------------------------------------------------- format 2: weakenings

# proved through weakenings: instantiated + lowered + abstracted (3-d deviation stop, whose
# lemma leaf is instantiated and lowered only) and abstracted alone (predictive controller)
WEAKENED = ("raven.deviation_stop_3d", "sbs.predictive")


@pytest.fixture(scope="module")
def weakened_certificates() -> list[dict]:
    from certiloop.proofs.engine.prover import Prover

    docs = []
    with Prover(jobs=1) as prover:
        for name in WEAKENED:
            result = prover.prove(library.get(name))
            docs.append(json.loads(json.dumps(certificate(*result.proof, result.obligations))))
    assert [d["format"] for d in docs] == [FORMAT_V2] * len(docs)
    assert [check(d).status for d in docs] == ["accepted"] * len(docs)  # the originals pass
    return docs


def test_the_v1_certificates_above_are_still_read(certificates):
    assert {d["format"] for d in certificates} == {FORMAT}


def _weakening_values(doc):
    """(path, value) of every string and number in the leaves' weakenings."""
    def walk(obj, path):
        if isinstance(obj, (str, int)) and not isinstance(obj, bool):
            yield path, obj
        elif isinstance(obj, dict):
            for k, v in obj.items():
                yield from walk(v, (*path, k))
        elif isinstance(obj, list):
            for n, v in enumerate(obj):
                yield from walk(v, (*path, n))
    for n, leaf in enumerate(doc["leaves"]):
        if leaf.get("weakening") is not None:
            yield from walk(leaf["weakening"], ("leaves", n, "weakening"))


# one meaning-changing edit of a key text: a symbol renamed, a number changed, a comparison
# changed. (Not `+` to `*`: a sum of one term is that term, as is a product of one factor, and
# atoms are compared up to polynomial identity, README.md.)
EDITS = ((r"'(\w+)@(\w+)'", lambda m: f"'{m[1]}@9{m[2]}'"),
         (r"Fraction\((-?\d+), ", lambda m: f"Fraction({int(m[1]) + 1}, "),
         (r"'>='", lambda m: "'>'"), (r"'<'", lambda m: "'<='"), (r"'=='", lambda m: "'!='"))


def _edits(value):
    if isinstance(value, int):
        yield value + 1
        return
    for pattern, new in EDITS:
        found = list(re.finditer(pattern, value))
        for m in found[:1] + found[-1:] if len(found) > 1 else found:  # the first and the last
            yield value[:m.start()] + new(m) + value[m.end():]


@pytest.mark.slow  # proves two models for their certificates
def test_every_value_of_a_weakening_changed_is_rejected(weakened_certificates):
    """Each string (symbol, key text) and number (hypothesis index) of the weakenings of the
    first leaves, edited so that it means something else: never accepted."""
    tried = 0
    for doc in weakened_certificates:
        values = list(_weakening_values(doc))
        leaves = sorted({path[1] for path, _ in values})[:3]
        for path, value in values:
            if path[1] not in leaves:
                continue
            for new in _edits(value):
                tried += 1
                outcome = check(_replaced(doc, path, new))
                assert outcome.exit_code in (1, 2), (path, str(value)[:80], str(new)[:80])
    assert tried > 100, tried  # every field kind was edited


@pytest.mark.slow
@settings(max_examples=60)
@given(st.data())
def test_any_string_of_a_weakening_changed_is_never_accepted(weakened_certificates, data):
    doc = data.draw(st.sampled_from(weakened_certificates))
    path, text = data.draw(st.sampled_from([(p, v) for p, v in _weakening_values(doc) if isinstance(v, str)]))
    where = data.draw(st.integers(0, len(text)))
    char = data.draw(st.sampled_from(list("0123456789 ()<>=+-*/,.'xyzhvg@|_")))
    new = text[:where] + char + text[where + 1:]
    if new == text:
        new = text + "1"
    assert check(_replaced(doc, path, new)).exit_code in (1, 2), (path, text[:80], new[:80])


def test_a_weakening_moved_dropped_or_from_another_leaf_is_rejected(weakened_certificates):
    doc = weakened_certificates[1]
    first, second = [n for n, leaf in enumerate(doc["leaves"]) if leaf["weakening"] is not None][:2]
    moved = copy.deepcopy(doc)
    moved["leaves"][first]["weakening"] = copy.deepcopy(doc["leaves"][second]["weakening"])
    dropped = copy.deepcopy(doc)
    dropped["leaves"][first].update(weakening=None)  # z3 on the leaf as stated: still labelled weakened
    as_v1 = copy.deepcopy(doc)
    as_v1["format"] = FORMAT
    for mutant in (moved, dropped, as_v1):
        assert check(mutant).exit_code in (1, 2)
