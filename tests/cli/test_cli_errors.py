"""Every exception class the command line raises for a user's mistake: one line on stderr,
exit 2, no traceback, naming the thing and its place.

The classes are found by reading the source (every class deriving from a user-error root),
so a new error class without a case here fails `test_every_user_error_class_has_a_case`.
"""

import ast
import textwrap
from pathlib import Path

import pytest

from certiloop.cli import main
from certiloop.cli.main import _main

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = {"models", "proofs", "falsify", "kernel", "testing", "cli", "api", "studies"}
USER_ERROR_ROOTS = {"ModelError", "BadInput", "OutputPathError", "PlanInputError"}
# caught inside the engine, never shown as an error: a proof too large is `unknown`
HANDLED_INSIDE = {"TooManyObligations": "proofs/engine/prover.py: the verdict is unknown, none tried"}

MODELS = textwrap.dedent("""
    import math
    from certiloop.models import *
    x, v = Real("x"), Real("v")
    n = Int("n")
    unpinned = Theorem("user.unpinned", x >= 0, loop(seq(havoc(v), assign(x, x + v * v)), x >= 0), x >= 0)
    integer = Theorem("user.integer", n >= 0, assign(n, n + 1), n >= 1)

    def transcendental():
        return Theorem("user.sin", x >= 0, assign(x, math.sin(x)), x >= -1)
""")


def _cases(tmp: Path) -> list[tuple[str, list[str], str, list[str]]]:
    """(class raised by the command, argv, what the line must say)."""
    models = tmp / "user_models.py"
    models.write_text(MODELS)
    head = 'ArchiveEntry "a"\nProgramVariables Real x; Real y; End.\n'
    (tmp / "broken.kyx").write_text(head + "Problem x >= ; End.\nEnd.\n")
    (tmp / "dinv.kyx").write_text(head + "Problem\n  x = 0 & y = 1 -> "
                                  "[{x' = y, y' = -x}@invariant(abs(x) <= 1)] abs(x) <= 1\nEnd.\nEnd.\n")
    (tmp / "raises.py").write_text("import math\n\nLIMIT = 1 / 0\n")
    return [
        ("BadInput", ["prove", "textbook.cart_forward", "--rlimit", "0"], ["--rlimit", "at least 1"]),
        ("BadInput", ["prove", "--no-such-flag", "x"], ["--no-such-flag", "--help"]),
        ("OutputPathError", ["prove", "textbook.cart_forward", "--json", str(tmp / "missing" / "r.json")],
         ["--json", "does not exist", "create it first"]),
        ("PlanInputError", ["plan", "raven.frs_box", "--samples", "1"], ["--samples", "between 2"]),
        ("ModelError", ["prove", "no.such.model"], ["no.such.model"]),
        ("ModelError", ["prove", f"{models}:transcendental"],
         [f"{models}:10", "transcendental functions are not supported"]),
        ("ModelError", ["prove", f"{tmp / 'raises.py'}:thm"],
         [f"{tmp / 'raises.py'}:3", "ZeroDivisionError"]),
        ("KyxError", ["prove", str(tmp / "broken.kyx")], [f"{tmp / 'broken.kyx'}:3:", "unexpected"]),
        # the reader's KyxError, carried by the entry to the one-entry archive's ModelError
        ("ModelError", ["prove", str(tmp / "dinv.kyx")], [f"{tmp / 'dinv.kyx'}:4:", "-c <= e & e <= c"]),
        ("NotExpressible", ["export", f"{models}:integer", "--kyx"], ["user.integer", "integer symbol `n`"]),
        ("ExtractError", ["extract", f"{models}:unpinned", "--no-cache", "--jobs", "1"],
         ["user.unpinned", "cannot extract"]),
        # no small model reaches it through extraction: raised in place of the monitors
        ("MonitorError", ["extract", "textbook.cart_forward", "--no-cache", "--jobs", "1", "--monitors"],
         ["the step has loops and nondeterministic choices: no monitor"]),
    ]


@pytest.fixture
def no_monitors(monkeypatch):
    from certiloop.kernel.extract import modelplex
    from certiloop.kernel.extract.monitor_terms import MonitorError

    def refuse(theorem):
        raise MonitorError("the step has loops and nondeterministic choices: no monitor")

    monkeypatch.setattr(modelplex, "monitors", refuse)


def _raised(argv: list[str]) -> BaseException:
    with pytest.raises(Exception) as info:
        _main(argv)
    return info.value


def _names(exc: BaseException | None) -> set[str]:
    """The class names of exc and of what it was raised from (a BadInput made of a PlanInputError)."""
    out = set()
    while exc is not None:
        out |= {k.__name__ for k in type(exc).__mro__}
        exc = exc.__cause__ or exc.__context__
    return out


def test_each_user_error_is_one_line_exit_2_naming_its_place(tmp_path, capsys, monkeypatch, no_monitors):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("CERTILOOP_DEBUG", raising=False)
    for _cls, argv, says in _cases(tmp_path):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("certiloop: error: "), (argv, err)
        assert "Traceback" not in err and "internal error" not in err
        for part in says:
            assert part in lines[0], (argv, part, lines[0])


def test_each_case_raises_its_class(tmp_path, capsys, monkeypatch, no_monitors):
    """The table is honest: each case really goes through the class it is listed for."""
    monkeypatch.chdir(tmp_path)
    for cls, argv, _ in _cases(tmp_path):
        names = _names(_raised(argv))
        capsys.readouterr()
        assert cls in names, (cls, argv, names)


def _user_error_classes() -> set[str]:
    """Every class in certiloop's source deriving (by name, transitively) from a user-error root."""
    bases: dict[str, set[str]] = {}
    for path in ROOT.rglob("*.py"):
        if any(part.startswith(".") for part in path.parts) or path.parts[len(ROOT.parts)] not in PACKAGES:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef):
                names = {b.id if isinstance(b, ast.Name) else b.attr for b in node.bases
                         if isinstance(b, (ast.Name, ast.Attribute))}
                bases.setdefault(node.name, set()).update(names)
    found = set(USER_ERROR_ROOTS)
    while True:
        more = {name for name, of in bases.items() if of & found} - found
        if not more:
            return found
        found |= more


def test_every_user_error_class_has_a_case(tmp_path):
    covered = {cls for cls, _, _ in _cases(tmp_path)} | set(HANDLED_INSIDE)
    missing = _user_error_classes() - covered
    assert not missing, f"user error classes without a case in this test: {sorted(missing)}"
