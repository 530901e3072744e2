"""certiloop.testing: prove models inside your own pytest suite.

    from certiloop.testing import assert_proved, assert_refuted

    def test_train_is_safe():
        assert_proved(train)                       # fails with the counterexample run

    def test_old_design_overruns():
        cex = assert_refuted(train_no_lookahead)   # the confirmed violating run
        assert cex.initial["vt"] != "0"

The pytest plugin (`certiloop.testing.plugin`, registered as a pytest11 entry point) turns
every theorem in a `*_models.py` file into a test of its `expected` verdict; a model listed
in `[tool.certiloop] wip = [...]` (pyproject.toml) is a work in progress, reported as xfail
while it is `unknown` (see the plugin's docstring).
Importing this package is cheap: the prover is imported when an assertion first runs.
"""

from certiloop.testing.assertions import Counterexample, assert_proved, assert_refuted, prove

__all__ = ["Counterexample", "assert_proved", "assert_refuted", "prove"]
