"""Any identifier works (kernel/extract/names.py): a model whose symbols are C or Python keywords,
C library names or look like generated names (`t` -> cl_t, `lower` -> cl_lower) extracts to
C that compiles with -Wall -Wextra -Werror -pedantic (C99 and C11) and to Python that runs, and
both decide as the model does, by hand in exact rationals."""

import math
import subprocess
import sys
from fractions import Fraction

import numpy as np
import pytest

from certiloop.kernel.extract import extract
from certiloop.kernel.extract.c.build import Kernel, build, compiler
from certiloop.kernel.extract.c.emit import compile_error, extract_c
from certiloop.kernel.extract.modelplex import monitors
from certiloop.kernel.extract.names import C_LIBRARY, PREFIX, c_unsafe, python_unsafe
from certiloop.models.lang.programs import assign, branch, choice, loop, ode, seq
from certiloop.models.lang.programs import test as check
from certiloop.models.lang.terms import Reals
from certiloop.models.lang.theorem import Theorem

NAMES = ["t", "lower", "sin", "exp", "main", "add", "c", "out_a", "u_t", "cl_t", "n_B", "rc", "careful",
         "lambda", "class", "None", "double", "int", "taken", "np", "_step", "x_dot", "t1", "case_a",
         "state", "command", "math"]


def _model(names: list[str]) -> Theorem:
    """`{ ?g - p <= s*e; a := -d  ++  ?g - p > s*e; a := m }; {p' = a}` with the symbols named."""
    p, g, s, e, d, m, a = Reals(" ".join(names))
    step = choice(branch("brake", check(g - p <= s * e), assign(a, -d)),
                  branch("go", check(g - p > s * e), assign(a, m)))
    return Theorem("tests.names", d >= 0, loop(seq(step, ode({p: a}))), d >= 0)


def _decide(values: dict) -> Fraction:
    """The model's acceleration by hand, in exact rationals (keys: the roles)."""
    F = {k: Fraction(v) for k, v in values.items()}
    return -F["d"] if F["g"] - F["p"] <= F["s"] * F["e"] else F["m"]


SETS = [(NAMES * 2)[i:i + 7] for i in range(0, len(NAMES), 3)]  # every name, in sets of 7
ROLES = ["p", "g", "s", "e", "d", "m", "a"]


def _states():
    rng = np.random.default_rng(7)
    out = []
    for _ in range(40):
        v = {r: float(rng.choice([0.0, 1.0, 0.1, 3.0]) * rng.uniform(0.5, 2)) for r in ROLES[:-1]}
        if rng.uniform() < 0.5:  # a tie: g - p = s*e exactly where the floats allow
            v["g"] = v["p"] + v["s"] * v["e"]
        out.append(v)
    return out


def test_the_renaming_is_injective_and_total():
    pool = NAMES + sorted(C_LIBRARY)[:40] + ["x", "u_x", "u_u_x", "y"]
    for unsafe in (python_unsafe, lambda n: c_unsafe(n, "tests_names")):
        new = {n: PREFIX + n if unsafe(n) else n for n in pool}
        assert len(set(new.values())) == len(pool)
        assert all(not unsafe(v) or v.startswith(PREFIX) for v in new.values())
        assert all(unsafe(n) for n in pool if n.startswith(PREFIX))


@pytest.mark.parametrize("names", SETS, ids=["-".join(s) for s in SETS])
def test_python_extracts_and_decides_as_the_model(names):
    t = _model(names)
    ns: dict = {}
    exec(compile(extract(t), "<extracted>", "exec"), ns)
    role = dict(zip(names, ROLES))
    for state in _states():
        args = [state[role[name[len(PREFIX):]] if name not in role else role[name]] for name in ns["INPUTS"]]
        got, enabled = ns["controller"](*args)
        assert enabled and Fraction(got) == _decide(state)


@pytest.mark.parametrize("names", SETS, ids=["-".join(s) for s in SETS])
def test_monitor_module_runs(names):
    ns: dict = {}
    exec(compile(monitors(_model(names)), "<monitors>", "exec"), ns)
    role = dict(zip(names, ROLES))
    for state in _states()[:10]:
        named = {k: state[role[k[len(PREFIX):]] if k not in role else role[k]] for k in ns["STATE"]}
        out = next(iter(ns["COMMAND"]))
        want = float(_decide(state))
        assert ns["controller_monitor"](named, {out: want}) is True
        assert ns["controller_monitor"](named, {out: want + 1.0}) is False


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
@pytest.mark.parametrize("names", SETS, ids=["-".join(s) for s in SETS])
def test_c_compiles_with_werror_and_decides_as_the_model(names, tmp_path):
    files = extract_c(_model(names))
    assert compile_error(files) is None
    header = next(v for k, v in files.items() if k.endswith(".h"))
    kernel = Kernel(build(files, tmp_path), header)
    role = dict(zip(names, ROLES))
    for state in _states():
        args = [state[role[name[len(PREFIX):]] if name not in role else role[name]] for name in kernel.inputs]
        got, enabled = kernel(*args)
        if kernel.undecided:
            continue  # a tie the C cannot certify: it falls back (no decision)
        assert enabled and Fraction(got) <= _decide(state) < Fraction(math.nextafter(got, math.inf))


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
def test_cli_extract_c_with_t_and_lower_compiles(tmp_path, monkeypatch):
    """The issue's case: controller variables named `t` and `lower`, through the CLI."""
    model = tmp_path / "names_model.py"
    model.write_text(
        "from certiloop.models.lang.programs import assign, branch, choice, loop, ode, seq\n"
        "from certiloop.models.lang.programs import test as check\n"
        "from certiloop.models.lang.terms import Reals\n"
        "from certiloop.models.lang.theorem import Theorem\n\n"
        "p, t, lower, a = Reals('p t lower a')\n"
        "step = choice(branch('stop', check(p >= t), assign(a, 0)),\n"
        "              branch('go', check(p < t), assign(a, lower)))\n"
        "MODEL = Theorem('tests.t_lower', lower >= 0, loop(seq(step, ode({p: a}))), lower >= 0)\n")
    out = tmp_path / "c"
    done = subprocess.run([sys.executable, "-m", "certiloop.cli", "extract", f"{model}:MODEL",
                           "--lang", "c", "-o", str(out)], capture_output=True, text=True, cwd=tmp_path)
    if done.returncode == 2 and "MODEL" in done.stderr:
        pytest.skip(f"model loading: {done.stderr.strip()}")
    assert done.returncode == 0, done.stderr
    source = next(out.glob("*.c"))
    built = subprocess.run([compiler(), "-std=c11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-c",
                            source.name, "-o", "k.o"], cwd=out, capture_output=True, text=True)
    assert built.returncode == 0 and not built.stderr, built.stderr
