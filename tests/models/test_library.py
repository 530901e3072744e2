"""Every library model meets the verdict its author expects, end to end."""

import pytest

from certiloop.models import library
from certiloop.proofs.engine.prover import Prover


@pytest.fixture(scope="module")
def prover():
    with Prover(jobs=2) as p:
        yield p


@pytest.mark.parametrize("name", library.names())
def test_model_meets_expected_verdict(prover, name):
    theorem = library.get(name)
    result = prover.prove(theorem)
    assert result.verdict == theorem.expected, result.reason
    if theorem.expected == "proved":
        assert all(o.verdict == "proved" for o in result.obligations)
        assert result.refutation is None
    else:
        ref = result.refutation
        assert ref is not None and result.run is not None and result.run.confirmed, \
            "a refutation must come with a replayed run"
        # a lemma whose program changes nothing (`test(TRUE)`) is violated at its start: no steps
        assert ref.trace or not theorem.program.symbols(), "a run through a program has steps"
        assert ref.check in ("exact rationals", "interval arithmetic")


def test_ctrl1_broken_counterexample_is_the_past_boundary_slide(prover):
    ref = prover.prove(library.get("sbs.ctrl1_broken")).refutation
    assert any("past boundary, towards" in step.path for step in ref.trace)
    final_py = ref.trace[-1].state["py"]
    assert final_py.startswith("-"), final_py


def test_unknown_library_name_suggests_close_names():
    with pytest.raises(Exception, match=r"did you mean .*sbs\.ctrl1"):
        library.get("sbs.ctrl")
