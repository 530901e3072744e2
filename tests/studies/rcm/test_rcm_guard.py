"""The extracted guard (studies/rcm/generated/axial_guard.py from rcm.axial_guard): shipped byte for
byte as a fresh extraction, pinned to the model's hash, called by kernel.rcm.guard_speed, and its
decisions the model's own, replayed in exact rationals by the interpreter."""

import subprocess
import sys
from fractions import Fraction

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.kernel.extract import shipped, shipped_drift
from certiloop.models import library
from certiloop.studies.rcm import arm as rcm_arm
from certiloop.studies.rcm import kernel as k
from certiloop.studies.rcm.generated import axial_guard as rcm_guard

GUARD = library.get("rcm.axial_guard")


def test_shipped_guard_is_a_fresh_extraction_of_the_proved_model():
    assert shipped()["rcm.axial_guard"][0].name == "axial_guard.py"
    assert shipped_drift("rcm.axial_guard") == ""
    assert (rcm_guard.MODEL, rcm_guard.MODEL_HASH) == ("rcm.axial_guard", GUARD.content_hash)


def test_a_changed_model_is_refused(monkeypatch):
    monkeypatch.setattr(rcm_guard, "MODEL_HASH", "0000000000000000")
    monkeypatch.setattr(rcm_arm, "_guard_checked", False)  # the module state behind kernel.rcm
    with pytest.raises(RuntimeError, match="older rcm.axial_guard.*certiloop.studies regenerate"):
        k.guard_speed(0.01, 1.0, 0.001)


def test_guard_speed_runs_the_extracted_code(monkeypatch):
    calls = []
    real = rcm_guard.controller

    def spy(*args):
        calls.append(args)
        return real(*args)

    monkeypatch.setattr(rcm_guard, "controller", spy)
    assert k.guard_speed(0.01, 10.0, 0.002, 0.004) == pytest.approx(2.0)
    assert calls == [(0.004, 10.0, 0.01, 0.002)]


def test_guard_speed_imports_no_prover():
    code = ("import sys; from certiloop.studies.rcm import kernel as rcm; rcm.guard_speed(0.01, 1.0, 0.001); "
            "print(sorted(m for m in ('z3', 'sympy', 'hypothesis', 'scipy') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


positive = st.fractions(min_value=Fraction(1, 10**4), max_value=1, max_denominator=10**4)
speeds = st.fractions(min_value=-10, max_value=10, max_denominator=10**4)


@settings(max_examples=200, deadline=None)
@given(extra=positive, w=speeds, m=positive, eps=positive)
def test_guard_speed_is_the_model_step_and_keeps_the_margin_in_exact_arithmetic(extra, w, m, eps):
    gap = m + extra                                     # the model's premise gap >= m
    gf, wf, mf, ef = (float(x) for x in (gap, w, m, eps))
    out = k.guard_speed(gf, wf, mf, ef)
    # the model's two branches, decided in rationals on the float inputs
    G, W, M, E = (Fraction(x) for x in (gf, wf, mf, ef))
    want = W if E * W <= G - M else (G - M) / E
    assert out == pytest.approx(float(want), rel=1e-12, abs=1e-15)
    assert G - E * Fraction(out) >= M                   # the margin holds exactly after one period
