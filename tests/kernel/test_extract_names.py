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


MACRO_NAMES = ["M_SQRT2", "M_LN2", "INT8_MAX", "SIZE_MAX", "FP_ILOGB0", "MAXFLOAT", "HUGE", "DBL_MAX",
               "UINT64_C", "WCHAR_MAX", "isless", "math_errhandling", "unix", "M_PI_2"]
MACRO_SETS = [(MACRO_NAMES * 2)[i:i + 7] for i in range(0, len(MACRO_NAMES), 7)]


def _compiles_as_a_user_types_it(files: dict, folder) -> str:
    """The compiler's diagnostics under `cc -Wall -Wextra -Werror -pedantic` (its default GNU
    mode, where <math.h> defines M_SQRT2 and more), "" where it compiles cleanly."""
    for name, text in files.items():
        (folder / name).write_text(text)
    source = next(name for name in files if name.endswith(".c"))
    done = subprocess.run([compiler(), "-Wall", "-Wextra", "-Werror", "-pedantic", "-c", source, "-o", "k.o"],
                          cwd=folder, capture_output=True, text=True)
    return done.stderr if done.returncode or done.stderr.strip() else ""


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
@pytest.mark.parametrize("names", MACRO_SETS, ids=["-".join(s) for s in MACRO_SETS])
def test_c_library_macro_names_compile_in_the_compilers_default_mode(names, tmp_path):
    """Symbols named like the macros <math.h>/<stdint.h> define (in GNU mode only, some of them)
    are renamed: the C compiles as the user compiles it, not only under -std=c99."""
    files = extract_c(_model(names))
    assert compile_error(files) is None
    assert _compiles_as_a_user_types_it(files, tmp_path) == ""


@pytest.mark.skipif(compiler() is None, reason="no C compiler")
@pytest.mark.parametrize("model_name", ["2fast", "x" * 300, "drone.v2-final"])
def test_any_model_name_gives_c_identifiers_and_short_file_names(model_name, tmp_path):
    t = _model(["p", "g", "s", "e", "d", "m", "a"])
    files = extract_c(Theorem(model_name, t.assumptions, t.program, t.guarantee))
    assert all(len(name) <= 64 and (name[0].isalpha() or name[0] == "_") for name in files)
    assert _compiles_as_a_user_types_it(files, tmp_path) == ""


ODD_NAMES = ['drone"""v2', "a\\N{x}", "ends */ here", "tri??/graph", 'say "hi"', "brace {x}", "höhe"]


@pytest.mark.parametrize("model_name", ODD_NAMES)
def test_model_names_and_descriptions_with_quotes_backslashes_and_comment_ends(model_name, tmp_path):
    """The model's name and description stand in the generated docstrings, C comments and the
    header's MODEL string: `\"\"\"`, a backslash, `*/` or a trigraph there broke the Python (refused)
    and the C (refused by the compile check, exit 1); they are escaped, and MODEL is the name."""
    t = _model(["p", "g", "s", "e", "d", "m", "a"])
    t = Theorem(model_name, t.assumptions, t.program, t.guarantee, description=model_name)
    for source in (extract(t), monitors(t)):
        ns: dict = {}
        exec(compile(source, "<extracted>", "exec"), ns)
        assert ns["MODEL"] == model_name
    if compiler() is None:
        return
    files = extract_c(t)
    assert _compiles_as_a_user_types_it(files, tmp_path) == ""
    header = next(name for name in files if name.endswith(".h"))
    macro = header[:-2].upper() + "_MODEL"
    (tmp_path / "show.c").write_text(f'#include <stdio.h>\n#include "{header}"\n'
                                     f'int main(void) {{ fputs({macro}, stdout); return 0; }}\n')
    subprocess.run([compiler(), "show.c", "-o", "show"], cwd=tmp_path, check=True)
    shown = subprocess.run(["./show"], cwd=tmp_path, capture_output=True, check=True).stdout
    assert shown.decode("utf-8") == model_name


@pytest.mark.parametrize("model_name", ["a\nb", "tab\there", "nul\x00"])
def test_a_model_name_that_is_not_one_printable_line_is_refused(model_name):
    from certiloop.models import ModelError

    t = _model(["p", "g", "s", "e", "d", "m", "a"])
    with pytest.raises(ModelError, match="printable characters on one line"):
        Theorem(model_name, t.assumptions, t.program, t.guarantee)
