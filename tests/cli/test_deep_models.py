"""Deeply nested models: long programs and deep formulas prove, falsify, read and print
through the command line; one archive entry that cannot be handled is its own row.

The verdicts are checked by hand: from x >= 0, n steps of x := x + 1 keep x >= 0 (x ends at
x + n); n steps of x := x - 1 break it at x = 0 (x ends at -n). The quick run uses sizes
past the old failure (400 statements, 400 nested boxes, 300 nested quantifiers); the sizes
the command line promises (10,000 statements, 2,000 deep) run with -m slow.
"""

import json

import pytest

from certiloop.cli import main


def _archive(name: str, problem: str) -> str:
    return f'ArchiveEntry "{name}"\nProgramVariables Real x; End.\nProblem {problem} End.\nEnd.\n'


def _sequence(n: int, step: str = "x := x + 1;") -> str:
    return " ".join([step] * n)


def _problems(n: int, depth: int) -> dict[str, tuple[str, str]]:
    """name -> (problem, its verdict worked out by hand)."""
    return {
        "sequence": (f"x >= 0 -> [{_sequence(n)}] x >= n_check".replace("n_check", str(n)), "proved"),
        "sequence_unsafe": (f"x >= 0 -> [{_sequence(n, 'x := x - 1;')}] x >= 0", "refuted"),
        "loop_body": (f"x >= 0 -> [{{{_sequence(n)}}}*@invariant(x >= 0)] x >= 0", "proved"),
        "nested_boxes": ("x >= 0 -> " + "[x := x + 1;]" * depth + f" x >= {depth}", "proved"),
        "nested_quantifiers": ("x >= 0 -> " + "".join(f"\\forall y{i} " for i in range(depth))
                               + "x >= 0", "proved"),
        "nested_parentheses": ("x >= 0 -> " + "(" * depth + "x >= 0" + ")" * depth, "proved"),
    }


def _prove_all(tmp_path, n: int, depth: int, capsys) -> None:
    problems = _problems(n, depth)
    kyx = tmp_path / "deep.kyx"
    kyx.write_text("".join(_archive(name, p) for name, (p, _) in problems.items()))
    out = tmp_path / "deep.json"
    code = main(["prove", str(kyx), "--jobs", "1", "-q", "--json", str(out)])
    capsys.readouterr()
    verdicts = {d["model"]: d["verdict"] for d in json.loads(out.read_text())}
    assert verdicts == {name: verdict for name, (_, verdict) in problems.items()}
    assert code == 1  # the unsafe sequence is refuted


def _falsify(tmp_path, n: int, capsys) -> None:
    problems = _problems(n, 10)
    kyx = tmp_path / "seq.kyx"
    kyx.write_text(_archive("safe", problems["sequence"][0])
                   + _archive("unsafe", problems["sequence_unsafe"][0]))
    out = tmp_path / "falsify.json"
    code = main(["falsify", str(kyx), "-q", "--max-examples", "20", "--database", "none", "--json", str(out)])
    capsys.readouterr()
    docs = {d["model"]: d for d in json.loads(out.read_text())}
    assert code == 1
    assert docs["safe"]["counterexample"] is None
    assert docs["unsafe"]["verdict"] == "refuted"
    assert -n <= docs["unsafe"]["counterexample"]["trace"][-1]["state"]["x"] < 0  # x0 - n, 0 <= x0 < n


def _falsify_deep_guarantee(tmp_path, depth: int, capsys) -> None:
    """A guarantee of 2*depth negations (an even number: the formula inside, by hand) is
    evaluated on every example; hypothesis lowers the recursion limit to its depth + 2,000
    around each one, which stopped it with a RecursionError (exit 2)."""
    negated = "!(" * (2 * depth)
    closing = ")" * (2 * depth)
    kyx = tmp_path / "deep_guarantee.kyx"
    kyx.write_text(_archive("safe", f"x >= 0 -> [x := x + 1;] {negated}x >= 1{closing}")
                   + _archive("unsafe", f"x >= 0 -> [x := x - 1;] {negated}x >= 0{closing}"))
    out = tmp_path / "deep_guarantee.json"
    code = main(["falsify", str(kyx), "-q", "--max-examples", "10", "--database", "none", "--jobs", "1",
                 "--json", str(out)])
    capsys.readouterr()
    docs = {d["model"]: d for d in json.loads(out.read_text())}
    assert code == 1
    assert docs["safe"]["counterexample"] is None
    assert docs["unsafe"]["verdict"] == "refuted"
    assert -1 <= docs["unsafe"]["counterexample"]["trace"][-1]["state"]["x"] < 0  # x0 - 1, 0 <= x0 < 1


def test_falsify_evaluates_a_guarantee_nested_past_hypothesis_limit(tmp_path, capsys):
    _falsify_deep_guarantee(tmp_path, 1_200, capsys)


def _export_and_list(tmp_path, n: int, depth: int, capsys) -> None:
    problems = _problems(n, depth)
    kyx = tmp_path / "deep.kyx"
    kyx.write_text("".join(_archive(name, p) for name, (p, _) in problems.items()))
    again = tmp_path / "again.kyx"
    assert main(["export", str(kyx), "--kyx", "-o", str(again)]) == 0
    assert main(["list", str(again), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert [row["model"] for row in listed] == list(problems)
    assert all(row["expected"] != "not supported" for row in listed)


def test_past_the_old_recursion_limit_every_command_works(tmp_path, capsys):
    _prove_all(tmp_path, 400, 400, capsys)
    _falsify(tmp_path, 400, capsys)
    _export_and_list(tmp_path, 400, 400, capsys)


@pytest.mark.slow
def test_ten_thousand_statements_and_two_thousand_levels(tmp_path, capsys):
    _prove_all(tmp_path, 10_000, 2_000, capsys)
    _falsify(tmp_path, 10_000, capsys)
    _export_and_list(tmp_path, 10_000, 2_000, capsys)


def _python_model(tmp_path, n: int, depth: int, capsys) -> None:
    model = tmp_path / "long.py"
    model.write_text(
        "from certiloop.models.lang.programs import assign, seq\n"
        "from certiloop.models.lang.terms import Implies, Real\n"
        "from certiloop.models.lang.theorem import Theorem\n"
        "x = Real('x')\n"
        "deep = x >= 0\n"
        f"for _ in range({depth}):\n"
        "    deep = Implies(x >= -1, deep)\n"
        f"long = Theorem('long', x >= 0, seq(*[assign(x, x + 1) for _ in range({n})]), deep)\n"
        "text = str(long)\n")
    assert main(["prove", f"{model}:long", "--jobs", "1", "-q"]) == 0
    assert main(["export", f"{model}:long", "--kyx", "-o", str(tmp_path / "long.kyx")]) == 0
    capsys.readouterr()


def test_a_long_python_model_prints_proves_and_exports(tmp_path, capsys):
    _python_model(tmp_path, 1000, 400, capsys)


@pytest.mark.slow
def test_a_python_model_of_ten_thousand_statements(tmp_path, capsys):
    _python_model(tmp_path, 10_000, 2_000, capsys)


def test_an_archive_entry_that_crashes_is_its_own_row_and_the_others_run(tmp_path, capsys, monkeypatch):
    from certiloop.proofs.engine import prover as prover_module

    real_prove = prover_module.Prover.prove

    def crash_on_one(self, theorem, *args, **kwargs):
        if theorem.name == "crashes":
            raise RuntimeError("a certiloop bug")
        return real_prove(self, theorem, *args, **kwargs)

    monkeypatch.setattr(prover_module.Prover, "prove", crash_on_one)
    monkeypatch.delenv("CERTILOOP_DEBUG", raising=False)
    kyx = tmp_path / "three.kyx"
    kyx.write_text(_archive("first", "x >= 0 -> [x := x + 1;] x >= 1")
                   + _archive("crashes", "x >= 0 -> [x := x + 1;] x >= 1")
                   + _archive("last", "x >= 0 -> [x := x + 1;] x >= 1"))
    out = tmp_path / "three.json"
    assert main(["prove", str(kyx), "--jobs", "1", "-q", "--json", str(out)]) == 2
    err = capsys.readouterr().err
    rows = {d["model"]: d for d in json.loads(out.read_text())}
    assert rows["first"]["verdict"] == rows["last"]["verdict"] == "proved"
    assert rows["crashes"]["verdict"] == "not supported"
    assert "RuntimeError: a certiloop bug" in rows["crashes"]["reason"]
    assert "Traceback" not in err and "crashes is not supported" in err


def test_an_entry_that_crashes_while_read_is_its_own_row(tmp_path, capsys, monkeypatch):
    from certiloop.models.kyx import reader

    real = reader._entry_theorem

    def crash_on_one(item, name, *args):
        if name == "crashes":
            raise RecursionError("maximum recursion depth exceeded")
        return real(item, name, *args)

    monkeypatch.setattr(reader, "_entry_theorem", crash_on_one)
    monkeypatch.delenv("CERTILOOP_DEBUG", raising=False)
    kyx = tmp_path / "two.kyx"
    kyx.write_text(_archive("crashes", "x >= 0 -> x >= 0") + _archive("fine", "x >= 0 -> x >= 0"))
    assert main(["list", str(kyx), "--json"]) == 0
    rows = {d["model"]: d for d in json.loads(capsys.readouterr().out)}
    assert rows["fine"]["expected"] != "not supported"
    assert rows["crashes"]["expected"] == "not supported"
    reason = rows["crashes"]["description"]
    assert "two.kyx:1:" in reason and "RecursionError" in reason


def test_the_gate_fails_a_crashing_model_in_its_own_row(tmp_path, capsys, monkeypatch):
    from certiloop.api import gate_run as gate_module

    real_check = gate_module.check_model

    def crash_on_one(theorem, *args, **kwargs):
        if theorem.name == "crashes":
            raise RuntimeError("a certiloop bug")
        return real_check(theorem, *args, **kwargs)

    monkeypatch.setattr(gate_module, "check_model", crash_on_one)
    monkeypatch.delenv("CERTILOOP_DEBUG", raising=False)
    kyx = tmp_path / "two.kyx"
    kyx.write_text(_archive("crashes", "x >= 0 -> [x := x + 1;] x >= 1")
                   + _archive("fine", "x >= 0 -> [x := x + 1;] x >= 1"))
    out = tmp_path / "gate.json"
    code = main(["gate", str(kyx), "--no-cache", "--jobs", "1", "--falsify-examples", "5", "-q",
                 "--json", str(out)])
    capsys.readouterr()
    rows = {d["model"]: d for d in json.loads(out.read_text())}
    assert code == 1
    assert rows["fine"]["verdict"] == "proved"
    assert rows["crashes"]["verdict"] == "not supported" and "RuntimeError" in json.dumps(rows["crashes"])
