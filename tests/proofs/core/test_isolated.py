"""Quantified nonlinear checks run in a child process with a deterministic allocation budget
(proofs/core/isolated.py): z3 can stall there where neither its resource count nor its timeout
reaches. The stalling claim below is a certiloop transcription of an obligation of ModelPlex's
curved ground robot (a circle that avoids the obstacle for every curvature up to Da); its
negation is satisfiable (w1 = v1 = 0 and xr3, yr3 on the obstacle), yet z3 5.4 stops counting
units after about 170,000 and returns minutes later."""

import time
from fractions import Fraction

import pytest

from certiloop.models.lang.terms import And, Exists, ForAll, Implies, Not, Or, Real, cmp
from certiloop.proofs.core import isolated
from certiloop.proofs.core.solver import check_here, check_valid, max_allocs

pytestmark = pytest.mark.skipif(not isolated.available(), reason="needs the forkserver start method")

xr, yr, xo, yo, da, xr1, yr1, w1, v1, acc, acc2, xr3, yr3 = (
    Real(n) for n in "xr yr xo yo Da xr1 yr1 w1 v1 acc acc2 xr3 yr3".split())


def stalling_claim():
    circle = cmp("!=", (xr1 + w1 / ((-1) * acc) - xo) ** 2 + (yr1 - v1 / ((-1) * acc) - yo) ** 2,
                 (v1**2 + w1**2) / acc**2)
    hypotheses = And(Or(cmp("!=", xr, xo), cmp("!=", yr, yo)), cmp("<", 0, da), cmp("<=", da, 1),
                     Not(And(cmp("==", xr1, xo), cmp("==", yr1, yo))),
                     ForAll(acc, Implies(And(cmp("<", 0, acc), cmp("<=", acc, da)), circle)),
                     cmp("<", 0, acc2), cmp("<=", acc2, da))
    return Implies(hypotheses, Not(And(cmp("==", xr3, xo), cmp("==", yr3, yo))))


def test_a_stall_ends_at_the_allocation_budget_not_at_the_clock():
    # a wall net far beyond the budget: only the allocation count can have ended the call
    answer = check_valid(stalling_claim(), 2_000_000, wall_s=600.0)
    assert answer.status == "unknown"
    assert "allocation budget spent" in answer.reason
    assert "wall-clock" not in answer.reason


def test_the_allocation_budget_is_deterministic():
    x, y = Real("x"), Real("y")
    claim = Implies(ForAll(y, cmp(">=", x * y * y, 0)), cmp(">=", x, 0))
    runs = [check_valid(claim, 2_000_000) for _ in range(3)]
    assert {r.status for r in runs} == {"unsat"}
    assert len({r.spent for r in runs}) == 1
    # z3 folds a thread's allocations into its count every 100 KB, so the count follows the
    # process's memory layout: within the 0.4% the budget's margin allows (proofs/core/isolated.py)
    counts = [r.allocations for r in runs]
    assert max(counts) - min(counts) <= 0.004 * min(counts)
    assert 0 < runs[0].allocations < max_allocs(2_000_000)


def test_the_child_answers_as_z3_in_this_process_would():
    x, y, t = Real("x"), Real("y"), Real("t")
    claims = [
        # valid: a square is never negative, for every t
        Implies(cmp(">", x, 0), ForAll(t, cmp(">=", x * t * t, 0))),
        # false: x*t*t >= 1 does not hold at t = 0
        Implies(cmp(">", x, 0), ForAll(t, cmp(">=", x * t * t, 1))),
        # false, with a witness hypothesis: some y with y*y = x makes x >= 0, and x = 4 > 3
        Implies(Exists(y, cmp("==", y * y, x)), cmp("<=", x, 3)),
    ]
    for claim in claims:
        here, child = check_here(claim, 2_000_000, 60.0), check_valid(claim, 2_000_000)
        assert child.status == here.status, claim
        assert child.allocations > 0  # it did run in a child
        assert child.model_falsifies == here.model_falsifies
        if child.status == "sat":  # the model came back as plain values, and it is z3's
            assert child.model == here.model
            assert all(isinstance(v, (Fraction, int, bool)) for v in child.model.values())
    assert [check_valid(c, 2_000_000).status for c in claims] == ["unsat", "sat", "sat"]


def test_z3s_exit_message_does_not_reach_the_output(capfd):
    check_valid(stalling_claim(), 2_000_000)
    out, _ = capfd.readouterr()
    assert "allocation" not in out.lower()


def test_the_wall_clock_net_kills_a_child_that_does_not_stop():
    # a budget so large it cannot end the stall (the parameter's 32-bit maximum), and a net of 1 s
    start = time.perf_counter()
    answer = isolated.check_in_child(check_here, stalling_claim(), 2_000_000, wall_s=1.0,
                                     max_allocs=2**32 - 1)
    assert answer.status == "unknown" and "wall-clock safety net" in answer.reason
    assert time.perf_counter() - start < 60  # killed, not waited for (z3 alone: minutes)


def test_linear_and_quantifier_free_checks_stay_in_this_process():
    x, t = Real("x"), Real("t")
    assert check_valid(Implies(cmp(">", x, 0), ForAll(t, cmp(">=", x + t, t))), 10**6).allocations == 0
    assert check_valid(Implies(cmp(">", x, 0), cmp(">", x * x, 0)), 10**6).allocations == 0


def _quantified_check_allocations(_):
    x, y = Real("x"), Real("y")
    answer = check_valid(Implies(ForAll(y, cmp(">=", x * y * y, 0)), cmp(">=", x, 0)), 2_000_000)
    return answer.status, answer.allocations


def test_a_pool_worker_checks_in_a_child_too():
    # pool workers are daemonic, and multiprocessing refuses children to those by default
    import multiprocessing

    with multiprocessing.get_context("fork").Pool(1) as pool:
        status, allocations = pool.map(_quantified_check_allocations, [0])[0]
    # about the allocations a check from this process counts (a check in this process counts
    # none): z3's count in a child varies with the memory layout of the process that started
    # its fork server (its arguments, paths, what ran before in it): CI saw 1,029 in 293,000,
    # one full local run 16,562 in 310,212 (5.3%; not reproduced alone), where a budget is at
    # least 10,000,000 and a finished check allocates at most 5,700,000
    here = _quantified_check_allocations(0)
    assert status == here[0] == "unsat"
    assert allocations > 0 and abs(allocations - here[1]) <= here[1] // 10


SCRIPT = """
from certiloop.models.lang.terms import ForAll, Implies, Real, cmp
from certiloop.proofs.core.solver import check_valid
print("script body runs")
x, y = Real("x"), Real("y")
answer = check_valid(Implies(ForAll(y, cmp(">=", x * y * y, 0)), cmp(">=", x, 0)), 2_000_000)
print(answer.status, answer.allocations)
"""


@pytest.mark.parametrize("how", ["file", "stdin"])
def test_a_script_without_a_main_guard_runs_once(tmp_path, how):
    # multiprocessing would re-run the parent's main script inside the child (or fail to
    # find a script read from stdin); the child must not import it
    import subprocess
    import sys

    if how == "file":
        (tmp_path / "verify.py").write_text(SCRIPT)
        proc = subprocess.run([sys.executable, "verify.py"], cwd=tmp_path, capture_output=True,
                              text=True, timeout=120)
    else:
        proc = subprocess.run([sys.executable, "-"], input=SCRIPT, cwd=tmp_path, capture_output=True,
                              text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.split("\n")
    assert lines.count("script body runs") == 1
    status, allocations = lines[1].split()
    assert status == "unsat" and int(allocations) > 0  # it ran in a child


FORKED_AFTER_OTHER_SERVER = """
import multiprocessing
from multiprocessing import forkserver

from certiloop.models.lang.terms import ForAll, Implies, Real, cmp
from certiloop.proofs.core.solver import check_valid


def in_worker():
    x, y = Real("x"), Real("y")
    answer = check_valid(Implies(ForAll(y, cmp(">=", x * y * y, 0)), cmp(">=", x, 0)), 2_000_000)
    return f"{answer.status} {answer.allocations > 0}"  # a quantified claim: checked in a child


if __name__ == "__main__":
    forkserver.ensure_running()  # other code's server: this process never ran an isolated check
    with multiprocessing.get_context("fork").Pool(1) as pool:
        print(pool.apply(in_worker))
"""


def test_a_forked_worker_checks_though_other_code_started_the_fork_server(tmp_path):
    """multiprocessing keeps one fork server per process; a forked worker cannot wait for its
    parent's, whoever started it, and must start its own (a test harness's server once made
    every isolated check of a pool's worker fail with 'No child processes')."""
    import subprocess
    import sys

    script = tmp_path / "forked.py"
    script.write_text(FORKED_AFTER_OTHER_SERVER)
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["unsat", "True"]
