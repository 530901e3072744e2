"""The pytest plugin (certiloop.testing.plugin), run on user files with pytester."""

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

pytest_plugins = ["pytester"]

MODELS = """
import dataclasses
from certiloop.models.library.textbook import cart_forward, cart_may_brake

safe = cart_forward()             # a Theorem at module level

def unsafe():                     # a zero-argument function returning one
    return cart_may_brake()

def _private():                   # not public: never called
    raise RuntimeError("called")

def helper(x):                    # takes an argument: not a model
    return x
"""


@pytest.fixture(scope="module", autouse=True)
def _loaded_once():
    """pytester's in-process runs unload every module they imported, and numpy's C core
    cannot be loaded twice in a process: run one proof here first, so the modules a run
    needs are loaded outside them."""
    from certiloop.models.library.textbook import cart_may_brake
    from certiloop.testing import assert_refuted

    assert_refuted(cart_may_brake)


@pytest.fixture
def run(pytester, monkeypatch):
    """pytest in-process with only our plugin (no entry points, so an installed copy of the
    plugin cannot be registered twice)."""
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    return lambda *args: pytester.runpytest("-p", "certiloop.testing.plugin", *args)


def test_theorems_in_models_files_become_items(pytester, run):
    pytester.makepyfile(cart_models=MODELS)
    result = run("-v")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["*cart_models.py::safe PASSED*", "*cart_models.py::unsafe PASSED*"])


def test_a_wrong_expectation_fails_with_the_counterexample(pytester, run):
    wrong = "\nwrong = dataclasses.replace(cart_may_brake(), expected='proved')\n"
    pytester.makepyfile(cart_models=MODELS + wrong)
    result = run()
    result.assert_outcomes(passed=2, failed=1)
    result.stdout.fnmatch_lines([
        "*textbook.cart_may_brake is refuted, not proved*",
        "*counterexample run (checked with exact rationals):*",
        "*start: *y0 = *",
        "*violated: y >= y0 is false at the end*",
        "FAILED cart_models.py::wrong*",
    ])
    assert "assertions.py" not in result.stdout.str()  # the message, not our traceback


def test_a_models_file_named_on_the_command_line_is_collected_once(pytester, run):
    # pytest makes a test module of any file named on the command line; its `test` (the
    # DSL's ?Q) must not become a test asking for a fixture `cond`
    pytester.makepyfile(cart_models="from certiloop.models import test\n" + MODELS)
    result = run("cart_models.py", "-v")
    result.assert_outcomes(passed=2)
    assert "fixture 'cond' not found" not in result.stdout.str()


def test_a_user_test_module_may_import_the_dsl_test(pytester, run):
    pytester.makepyfile(test_mine="""
        from certiloop.models import Reals, Theorem, assign, test
        from certiloop.testing import assert_proved
        x, = Reals("x")
        def test_guarded_step_is_safe():
            assert_proved(Theorem(name="g", assumptions=x >= 0,
                                  program=test(x >= 1) >> assign(x, x - 1), guarantee=x >= 0))
    """)
    run("-v").assert_outcomes(passed=1)


def test_k_selects_by_theorem_name(pytester, run):
    pytester.makepyfile(cart_models=MODELS)
    run("-k", "cart_may_brake").assert_outcomes(passed=1)


def test_a_model_that_cannot_be_built_is_a_collection_error(pytester, run):
    pytester.makepyfile(bad_models="""
        from certiloop.models import Reals, Theorem, skip
        x, = Reals("x")
        def broken():
            return Theorem(name="b", assumptions=x >= 0, program=skip(), guarantee=x >= 0, expected="maybe")
    """)
    result = run()
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*bad_models.py: broken() failed: ModelError: theorem b: expected must be*"])


def test_test_modules_and_other_files_are_not_collected_as_models(pytester, run):
    # test_arm_models.py matches *_models.py, but it is a test module: only its tests run (not
    # named test_models.py: certiloop's own tests/models/test_models.py is already imported in-process)
    pytester.makepyfile(test_arm_models="""
        from certiloop.models.library.textbook import cart_may_brake
        wrong = cart_may_brake()
        def test_plain():
            assert True
    """, cart_helpers=MODELS)
    run().assert_outcomes(passed=1)


def test_model_file_pattern_is_configurable(pytester, run):
    pytester.makeini("[pytest]\ncertiloop_model_files = *_hybrid.py\n")
    pytester.makepyfile(cart_hybrid=MODELS, cart_models=MODELS)
    run().assert_outcomes(passed=2)


def test_importing_the_plugin_loads_no_prover():
    code = ("import sys, certiloop.testing.plugin, certiloop.testing; "
            "print(sorted(m for m in ('z3', 'sympy', 'scipy', 'certiloop.proofs', 'certiloop.models') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_plugin_is_a_pytest11_entry_point():
    project = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml").read_text())
    assert project["project"]["entry-points"]["pytest11"] == {"certiloop": "certiloop.testing.plugin"}
    assert "certiloop.testing" in project["tool"]["setuptools"]["packages"]


def test_imported_builders_annotated_theorem_are_items_once(pytester, run):
    # cart_forward is also built as `safe` below: one item for it, named where it is defined
    pytester.makepyfile(lib_models="""
        from certiloop.models.library.textbook import cart_forward, cart_may_brake
        from os.path import join        # an imported function that is no builder: never called
        safe = cart_forward()
    """)
    result = run("-v")
    result.assert_outcomes(passed=2)
    result.stdout.fnmatch_lines(["*lib_models.py::safe PASSED*", "*lib_models.py::cart_may_brake PASSED*"])


def test_a_models_file_without_theorems_is_warned_about(pytester, run):
    pytester.makepyfile(empty_models="""
        from os.path import join
        def make(x):
            return x
        LIMIT = 3
    """)
    result = run("-W", "always")
    result.stdout.fnmatch_lines(["*CertiloopModelsWarning*empty_models.py*yields no certiloop theorem*"])
    assert result.ret == pytest.ExitCode.NO_TESTS_COLLECTED


def test_a_file_with_theorems_is_not_warned_about(pytester, run):
    pytester.makepyfile(cart_models=MODELS)
    result = run("-W", "always")
    result.assert_outcomes(passed=2)
    assert "CertiloopModelsWarning" not in result.stdout.str()


WIP_MODELS = """
import dataclasses
from certiloop.models.library.textbook import cart_forward

unfinished = cart_forward()                                               # unknown at rlimit 10
finished = dataclasses.replace(cart_forward(), name="user.finished")      # unknown at rlimit 10
"""


def test_a_work_in_progress_model_that_is_unknown_is_xfail(pytester, run):
    pytester.makepyprojecttoml('[tool.pytest.ini_options]\ncertiloop_rlimit = "10"\n'
                               '[tool.certiloop]\nwip = ["unfinished"]\n')
    pytester.makepyfile(cart_models=WIP_MODELS)
    result = run("-rxX")
    result.assert_outcomes(xfailed=1, failed=1)  # finished is not on the list
    result.stdout.fnmatch_lines(["*XFAIL*unfinished*work in progress*"])


def test_a_wrong_verdict_fails_and_a_proof_is_xpass_even_in_progress(pytester, run):
    # names match item names or theorem names (textbook.cart_forward)
    pytester.makepyprojecttoml('[tool.certiloop]\nwip = ["wrong", "textbook.cart_*"]\n')
    pytester.makepyfile(cart_models="""
        import dataclasses
        from certiloop.models.library import textbook
        safe = textbook.cart_forward()
        wrong = dataclasses.replace(textbook.cart_may_brake(), name="user.wrong", expected="proved")
    """)
    result = run("-rxX")
    result.assert_outcomes(xpassed=1, failed=1)
    result.stdout.fnmatch_lines(["*user.wrong is refuted, not proved*"])


def test_a_malformed_wip_list_is_a_usage_error(pytester, run):
    pytester.makepyprojecttoml('[tool.certiloop]\nwip = "unfinished"\n')
    pytester.makepyfile(cart_models=MODELS)
    result = run()
    assert result.ret == pytest.ExitCode.USAGE_ERROR
    assert "[tool.certiloop] wip must be a list of model names" in result.stderr.str()
