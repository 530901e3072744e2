"""Test profiles.

The default run (the README's test command, CI) is derandomised: hypothesis uses a fixed
seed, so a failure reproduces. `HYPOTHESIS_PROFILE=deep python -m pytest -q` is the deep
run: everything, with random seeds, many more examples, and the tests marked `deep` (add
`-m deep` for only those); a fixed seed has already hidden a real kernel bug once. CI runs
the property tests once more under `deep-ci` (random seeds, 200 examples), and the tests
marked `slow` (`python -m pytest -q -m slow`: derandomised, the mutants of the big models)
that keep the quick run under 10 minutes. `dev` is random with default sizes.
"""

import os
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile("ci", derandomize=True, deadline=None, database=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("deep", deadline=None, max_examples=1000, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
# CI's short random-seed run of the property tests (.ci/run): random, not derandomised
settings.register_profile("deep-ci", deadline=None, max_examples=200, database=None,
                          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
settings.register_profile("dev", deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

DEEP = os.environ.get("HYPOTHESIS_PROFILE") == "deep"


def pytest_configure(config):
    config.addinivalue_line("markers", "deep: slow property and soundness runs (the deep profile)")
    config.addinivalue_line("markers", "slow: derandomised but slow (mutants of the big models): "
                            "`python -m pytest -q -m slow`, which CI runs after the quick run")


# the slowest tests of a timed run (tests/tiers.py chooses them): marked `slow` at collection
SLOW_TESTS = set((Path(__file__).parent / "slow_tests.txt").read_text().splitlines())  # ids may hold spaces


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Tests marked `deep` run only in the deep profile or when asked for with -m deep; tests
    marked `slow` (in the code, or listed in slow_tests.txt) only in the deep profile or with
    -m slow (CI runs both sets)."""
    for item in items:
        if item.nodeid in SLOW_TESTS:
            item.add_marker(pytest.mark.slow)
    asked = config.getoption("-m") or ""
    for marker, command in (("deep", "HYPOTHESIS_PROFILE=deep python -m pytest -q"),
                            ("slow", "python -m pytest -q -m slow")):
        if DEEP or marker in asked:
            continue
        skip = pytest.mark.skip(reason=f"{marker} run only: {command}")
        for item in items:
            if marker in item.keywords:
                item.add_marker(skip)


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session, exitstatus):
    session.config.stash[EXIT_STATUS] = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """Exit with the session's status once everything is reported, skipping the interpreter's
    teardown: once in CI the process died of a segmentation fault after printing
    a clean summary, a known way for z3's native objects to be freed at shutdown (pysmt#522,
    z3#335). Pytester's in-process sessions do not load this file, so they are unaffected."""
    status = config.stash.get(EXIT_STATUS, None)
    if status is None:
        return
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


EXIT_STATUS = pytest.StashKey[int]()
