"""The checker stays small and separate: its lines plus every line of ours it imports are
fewer than 3,500, and it imports nothing of the prover (only models/lang and proofs/arith)."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
FOLDERS = {"models": "models", "proofs": "proofs", "falsify": "falsify", "kernel": "kernel", "cli": "cli",
           "testing": "testing", "studies": "studies"}
ALLOWED = ("certiloop.proofs.checker", "certiloop.models.lang", "certiloop.proofs.arith.smtlib")
LIMIT = 3500


def _path(module: str) -> Path | None:
    parts = module.split(".")[1:]
    base = ROOT / FOLDERS[parts[0]] / Path(*parts[1:]) if len(parts) > 1 else ROOT / FOLDERS[parts[0]]
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.exists():
            return candidate
    return None


# notebook display (LaTeX, HTML): imported only inside the display members, which checking never calls
DISPLAY = "certiloop.models.lang.notation"


def _imported(path: Path) -> set[str]:
    """Every certiloop module a file imports, anywhere in it (functions included), but the
    display module where a function imports it and what only type checkers read (`if
    TYPE_CHECKING:`, never run; the fresh-process test below checks what does load)."""
    tree = ast.parse(path.read_text())
    in_functions = {id(n) for f in ast.walk(tree) if isinstance(f, ast.FunctionDef) for n in ast.walk(f)}
    typing_only = {id(n) for f in ast.walk(tree) if isinstance(f, ast.If)
                   and isinstance(f.test, ast.Name) and f.test.id == "TYPE_CHECKING" for n in ast.walk(f)}
    out = set()
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("certiloop"):
            for alias in node.names:
                sub = f"{node.module}.{alias.name}"
                if sub == DISPLAY and id(node) in in_functions:
                    continue
                out.add(sub if _path(sub) is not None else node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("certiloop"))
    return out


def _closure() -> dict[str, Path]:
    """The checker's modules, what they import of ours transitively, and each package's
    __init__ that importing them runs."""
    todo = [f"certiloop.proofs.checker.{p.stem}".removesuffix(".__init__")
            for p in (ROOT / "proofs" / "checker").glob("*.py")]
    seen: dict[str, Path] = {}
    while todo:
        module = todo.pop()
        if module in seen or module == "certiloop":
            continue
        path = _path(module)
        assert path is not None, module
        seen[module] = path
        todo += _imported(path)
        todo.append(module.rsplit(".", 1)[0])  # the package's __init__ runs first
    return seen


def test_the_checker_imports_only_models_lang_and_the_smtlib_printer():
    modules = _closure()
    outside = sorted(m for m in modules if not m.startswith(ALLOWED)
                     and m not in ("certiloop.models", "certiloop.proofs", "certiloop.proofs.arith"))
    assert outside == []
    prover = ("certiloop.proofs.engine", "certiloop.proofs.core", "certiloop.proofs.refute", "certiloop.cli",
              "certiloop.falsify")
    assert not any(m.startswith(prover) for m in modules)


def test_the_checker_with_what_it_imports_is_under_3500_lines():
    lines = {m: len(p.read_text().splitlines()) for m, p in _closure().items()}
    assert sum(lines.values()) < LIMIT, sorted(lines.items(), key=lambda kv: -kv[1])


def test_the_count_sees_the_checker_and_its_imports():
    modules = _closure()  # a count that missed them would pass trivially
    assert {"certiloop.proofs.checker.derive", "certiloop.models.lang.terms",
            "certiloop.proofs.arith.smtlib", "certiloop.models"} <= set(modules)


def test_checking_loads_only_the_modules_counted(tmp_path):
    """The exclusions above hold at run time: checking a certificate in a fresh process loads
    no module of ours outside the counted closure, and not notation.py (and the check
    accepts, so the check did run)."""
    import json
    import subprocess
    import sys

    from certiloop.models.library import textbook
    from certiloop.proofs.engine.certificate_writer import certificate

    path = tmp_path / "ball.json"
    path.write_text(json.dumps(certificate(textbook.bouncing_ball(), {})))
    code = ("import sys\n"
            "from certiloop.proofs.checker import check_file\n"
            f"outcome = check_file({str(path)!r})\n"
            "assert outcome.status == 'accepted', outcome\n"
            "assert 'certiloop.models.lang.notation' not in sys.modules\n"
            "print(' '.join(m for m in sys.modules if m.startswith('certiloop')))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    loaded = set(done.stdout.split())
    assert "certiloop.proofs.checker.derive" in loaded
    assert loaded - {"certiloop"} <= set(_closure()), loaded - set(_closure())
