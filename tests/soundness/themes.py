"""The two tests every theme module runs, parametrised over its cases."""

from __future__ import annotations

import os

import pytest

from .harness import Case, record, run_all


def theme_tests(module, theme: str):
    cases: list[Case] = module.CASES
    ids = [c.id for c in cases]

    @pytest.fixture(scope="module")
    def outcomes(request):
        # only the cases this run selected: the quick tier and `-m slow` each take their share
        selected = {item.callspec.params["case"].id for item in request.session.items
                    if item.module is request.module and item.originalname == "test_engine_outcome_allowed"
                    and not item.get_closest_marker("skip")}
        outcomes = run_all(module.__name__, cases, only=selected)
        if os.environ.get("SOUNDNESS_TIMES"):  # each case's own time, for tests/tiers.py
            with open(os.environ["SOUNDNESS_TIMES"], "a") as out:
                for case_id, outcome in outcomes.items():
                    out.write(f"{outcome['seconds']:.2f}s case {request.node.nodeid}::"
                              f"test_engine_outcome_allowed[{case_id}]\n")
        return outcomes

    @pytest.mark.parametrize("case", cases, ids=ids)
    def test_witness_confirms_label(case: Case):
        if case.witness is None:
            assert case.truth == "ill-formed", f"{case.id}: a {case.truth} case needs a witness"
            return
        case.witness()

    @pytest.mark.parametrize("case", cases, ids=ids)
    def test_engine_outcome_allowed(case: Case, outcomes):
        outcome = outcomes[case.id]
        ok, why = record(theme, case, outcome)
        assert ok, (
            f"{case.id} ({case.truth}{', ' + case.nonblocking if case.nonblocking else ''}): "
            f"{why}; engine says: {outcome['reason'][:400]}"
        )

    def test_theme_shape():
        assert len(set(ids)) == len(ids), "case ids must be unique"
        assert len(cases) >= 10
        assert {"true", "false"} <= {c.truth for c in cases}

    return outcomes, test_witness_confirms_label, test_engine_outcome_allowed, test_theme_shape
