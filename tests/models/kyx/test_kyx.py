"""KeYmaera X archives: reading (.kyx -> Theorem), writing (Theorem -> .kyx), and the CLI on them.

The fixtures in tests/fixtures/kyx_*.kyx are certiloop's own (KeYmaera X's benchmark archives are
others' text; benchmarks/bench_kyx.py takes their paths)."""

import json
import os
import re
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from certiloop.models import library
from certiloop.models.kyx import KyxError, NotExpressible, read_entries, to_kyx
from certiloop.models.kyx.writer import KYX_IDENT
from certiloop.models.lang.programs import ODE, Assign, Choice, Loop, Seq, assign, loop, seq, test
from certiloop.models.lang.terms import And, Box, ForAll, Iff, Implies, Not, Or, Real, cmp, const, free_vars
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.engine import Prover

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
VALID, INVALID = FIXTURES / "kyx_valid.kyx", FIXTURES / "kyx_invalid.kyx"


def run(*args):
    proc = subprocess.run([sys.executable, "-m", "certiloop.cli", *args], capture_output=True,
                          text=True, timeout=300, env={**os.environ, "COLUMNS": "200"})
    return proc.returncode, proc.stdout, proc.stderr


def entries(path: Path) -> dict:
    return {e.name: e for e in read_entries(path.read_text(), str(path))}


# --------------------------------------------------------------------------- reading


def test_every_entry_kind_is_read_with_its_name():
    found = entries(VALID)
    assert [(e.kind, e.error) for e in found.values()] == [
        ("ArchiveEntry", None), ("Theorem", None), ("Lemma", None), ("Exercise", None)]
    assert list(found) == ["ball: invariant on the loop", "train: solution of a polynomial flow",
                           "abs, min, max and a differential symbol", "old(x) in an ODE annotation"]


def test_definitions_are_expanded_and_constants_declared():
    t = entries(VALID)["ball: invariant on the loop"].theorem
    text = t.text
    assert "inside" not in text and "bounce" not in text  # predicate and program expanded
    assert "1/2" in text  # `Real c = 1/2;` substituted
    assert {c.name for c in t.constants} >= {"g", "H"}  # shared and entry Definitions
    assert t.description == "A falling ball stays below its drop height"  # for `certiloop list`
    loop = t.program
    assert isinstance(loop, Loop) and loop.invariant is not None
    flow = loop.body.parts[0]
    assert isinstance(flow, ODE) and len(flow.invariants) == 1  # @invariant on the ODE: a dI


def test_nullary_function_calls_are_constants():
    t = entries(VALID)["train: solution of a polynomial flow"].theorem
    names = set(free_vars(t.assumptions))
    assert {"b", "ep", "m", "A"} <= names and "b()" not in t.text


def test_differential_symbols_follow_dl_semantics():
    t = entries(VALID)["abs, min, max and a differential symbol"].theorem
    parts = t.program.parts
    flow = next(p for p in parts if isinstance(p, ODE))
    assert "x_prime" not in free_vars(flow.domain)  # x' > 0 in the domain reads 2 > 0
    after = parts[parts.index(flow) + 1]
    assert isinstance(after, Assign) and after.target.name == "x_prime" and str(after.value) == "2"


def test_old_in_an_ode_annotation_is_the_value_before_the_flow():
    t = entries(VALID)["old(x) in an ODE annotation"].theorem
    first, flow = t.program.parts
    assert isinstance(first, Assign) and first.target.name == "x_old" and first.value.name == "x"
    assert "x_old" in free_vars(flow.invariants[0])


def test_old_in_a_loop_invariant_is_the_value_before_the_loop():
    """As KeYmaera X reads it (IJRR17's Theorem 9 uses it on an inner loop): a fresh variable
    assigned just before the loop, which the loop does not write."""
    from certiloop.models.lang.programs import Loop, written
    from certiloop.proofs.engine.prover import Prover

    text = """ArchiveEntry "up" ProgramVariables Real x; Real y; End.
      Problem x >= 0 & y = x -> [{x := x + 1;}*@invariant(x >= old(x) & y = old(x))] x >= y End. End.
    ArchiveEntry "down" ProgramVariables Real x; End.
      Problem x >= 0 -> [{x := x - 1;}*@invariant(x <= old(x))] x >= 0 End. End."""
    up, down = (e.theorem for e in read_entries(text))
    first, loop = up.program.parts
    assert isinstance(first, Assign) and first.target.name == "x_old" and isinstance(loop, Loop)
    assert "x_old" in free_vars(loop.invariant) and "x_old" not in written(loop.body)
    with Prover(jobs=1) as prover:
        assert prover.prove(up).verdict == "proved"
        found = prover.prove(down)  # x = 0 steps to -1: a replayed run, the invariant notwithstanding
        assert found.verdict == "refuted" and found.run.replayed


def _value(n, env):
    """An evaluator written for this test (independent of the engine)."""
    op = n.op
    if op == "const":
        return n.payload
    if op == "var":
        return env[n.payload]
    if op == "+":
        return sum((_value(a, env) for a in n.args), Fraction(0))
    if op == "*":
        out = Fraction(1)
        for a in n.args:
            out *= _value(a, env)
        return out
    if op == "neg":
        return -_value(n.args[0], env)
    if op == "cmp":
        a, b = (_value(x, env) for x in n.args)
        return {"<": a < b, "<=": a <= b, ">": a > b, ">=": a >= b, "==": a == b, "!=": a != b}[n.payload]
    if op == "and":
        return all(_value(a, env) for a in n.args)
    if op == "or":
        return any(_value(a, env) for a in n.args)
    raise AssertionError(op)


ABS_MIN_MAX = read_entries("""ArchiveEntry "a" ProgramVariables Real x; Real y; End.
  Problem abs(x - y) <= max(x, 1) & min(abs(x), y) < 2 -> [?true;]true End. End.""")[0].theorem


@given(st.fractions(-5, 5, max_denominator=4), st.fractions(-5, 5, max_denominator=4))
def test_abs_min_max_case_splits_agree_with_python(x, y):
    expected = abs(x - y) <= max(x, 1) and min(abs(x), y) < 2
    assert _value(ABS_MIN_MAX.assumptions, {"x": x, "y": y}) == expected


def test_a_disjunction_beside_a_box_becomes_an_assumption():
    t = entries(INVALID)["a loop under a disjunction"].theorem
    assert str(t.assumptions) == "x = 0 & !(y = 1)" and isinstance(t.program, Loop)
    assert str(t.guarantee) == "x <= 1"


def test_a_negative_exponent_is_a_division_checked_like_any_other():
    (e,) = read_entries('ArchiveEntry "a" Definitions Real tau = 10^-10; End. ProgramVariables Real x; '
                        'End. Problem x > 0 -> x^-1 > 0 & x^(-2) >= tau*0 & 2^-3 = 1/8 End. End.', "f.kyx")
    assert e.theorem.assumptions.key == (Real("x") > 0).key
    # tau is the number 10^-10; x^-n is the division 1/x^n
    assert str(e.theorem.guarantee) == "1/x > 0 & 1/x^2 >= 1/10000000000*0 & 1/8 = 1/8"
    with Prover(jobs=1) as p:
        assert p.prove(e.theorem, search=False).verdict == "proved"
        # x^-1 where x may be 0: refused as ill-defined, never proved
        (bad,) = read_entries('ArchiveEntry "b" ProgramVariables Real x; End. '
                              'Problem x^(-1) >= 0 -> x > 0 End. End.', "f.kyx")
        result = p.prove(bad.theorem)
        assert result.verdict == "unknown" and result.ill_defined and "ill-defined" in result.reason
        # a false one is refuted: x = 1/2 gives x^-2 = 4
        (false,) = read_entries('ArchiveEntry "c" ProgramVariables Real x; End. '
                                'Problem x > 0 -> x^-2 < 1 End. End.', "f.kyx")
        assert p.prove(false.theorem).verdict == "refuted"
    (zero,) = read_entries('ArchiveEntry "d" Problem 0^-1 > 0 End. End.', "f.kyx")
    assert zero.theorem is None and re.match(r"f\.kyx:1:\d+: division by the constant 0", zero.error)


def test_unsupported_constructs_are_refused_with_line_and_column():
    bad = entries(FIXTURES / "kyx_unsupported.kyx")["real exponent"]
    assert bad.theorem is None and re.search(r"kyx_unsupported\.kyx:3:\d+: exponent `x`", bad.error)
    for text, what in [
        ('ArchiveEntry "a" Definitions Real f(Real x); End. Problem f(1) > 0 End. End.', "uninterpreted"),
        ('ArchiveEntry "a" Problem exp(2) > 0 End. End.', "`exp` is not supported"),
        ('ArchiveEntry "a" Problem 2^(1/3) > 1 End. End.', "exponent `1/3` is not supported"),
        ('ArchiveEntry "a" Problem x>0 -> <{x:=x+1;}*>[{x:=x-1;}*]x>5 End. End.', "loop inside"),
        ('ArchiveEntry "a" Definitions Real c; End. Problem [c := 1;]c > 0 End. End.', "constant `c`"),
        ('ArchiveEntry "a" Definitions Real c = 2; End. Problem \\forall c c>0 End. End.', "quantify over"),
    ]:
        (e,) = read_entries(text, "f.kyx")
        assert e.theorem is None and what in e.error and re.match(r"f\.kyx:\d+:\d+: ", e.error), e.error


def test_syntax_errors_name_line_and_column():
    with pytest.raises(KyxError, match=r"kyx_syntax_error\.kyx:3:33: unexpected '\]'.*`;`"):
        read_entries((FIXTURES / "kyx_syntax_error.kyx").read_text(), str(FIXTURES / "kyx_syntax_error.kyx"))


# --------------------------------------------------------------------------- writing


# integer counters, index sorts and arrays (cfmpa: the grid and its layer/cell indices)
EXPRESSIBLE_NOT = {
    "cfmpa.builtdr",
    "cfmpa.builtdr_skips_last_row",
    "cfmpa.builtdr_inclusive",
    "cfmpa.check_path",
    "cfmpa.early_arrival",
    "cfmpa.execution",
    "cfmpa.execution_early_arrival",
    "cfmpa.execution_grid_floor",
    "cfmpa.execution_layers_floor",
    "cfmpa.execution_original",
    "cfmpa.execution_pose_only",
    "cfmpa.execution_wrong_direction",
    "cfmpa.original_backward_half_unreachable",
    "cfmpa.property3",
    "cfmpa.property3_printed",
    "cfmpa.property4",
    "cfmpa.property5_unguarded",
    "cfmpa.property8",
    "cfmpa.property8_converse",
    "cfmpa.searchoptpath",
}


@pytest.mark.parametrize("name", library.names())
def test_library_round_trip(name):
    """export -> read gives the same theorem (same content hash), or a precise reason."""
    t = library.get(name)
    try:
        text = to_kyx(t)
    except NotExpressible as exc:
        assert re.search(r"integer symbol|quantifier over the \w+ symbol|array", str(exc)), str(exc)
        assert name in EXPRESSIBLE_NOT or name.startswith(("sbs.ctrl2", "raven.deviation_stop_3d"))
        return
    (entry,) = read_entries(text, f"{name}.kyx")
    assert entry.error is None, entry.error
    assert entry.theorem.content_hash == t.content_hash
    # KeYmaera X's identifiers: letters and digits, an optional _index (DLParser.ident)
    for declared in re.findall(r"Real (\S+);", text):
        assert KYX_IDENT.fullmatch(declared), declared


def test_export_writes_invariants_as_annotations():
    text = to_kyx(library.get("textbook.bouncing_ball"))
    assert "}*@invariant(" in text and "}@invariant(" in text  # the loop's and the ODE's
    assert "Definitions" in text and "ProgramVariables" in text


def test_nested_choices_keep_their_shape():
    (e,) = read_entries('ArchiveEntry "a" ProgramVariables Real x; End. '
                        'Problem [{x:=1; ++ x:=2;} ++ x:=3;]x>0 End. End.')
    prog = e.theorem.program
    assert isinstance(prog, Choice) and len(prog.alternatives) == 2
    assert isinstance(prog.alternatives[0], Choice) and not isinstance(prog.alternatives[1], Seq)


# --------------------------------------------------------------------------- the CLI


def test_prove_archive_writes_a_list_with_entry_names(tmp_path):
    out = tmp_path / "r.json"
    code, _, err = run("prove", str(VALID), "--json", str(out), "--jobs", "1")
    assert code == 0, err
    data = json.loads(out.read_text())
    assert [d["model"] for d in data] == list(entries(VALID))
    assert all(d["verdict"] == "proved" for d in data)


def test_invalid_entries_are_never_proved_and_refuted_with_replayed_runs(tmp_path):
    out = tmp_path / "r.json"
    code, _, err = run("prove", str(INVALID), "--json", str(out), "--jobs", "1")
    assert code == 1, err
    verdicts = {d["model"]: d for d in json.loads(out.read_text())}
    assert all(d["verdict"] != "proved" for d in verdicts.values())
    for name in ("loop that overshoots", "flow that leaves", "a symbol only in the guarantee",
                 "a loop under a disjunction"):
        assert verdicts[name]["verdict"] == "refuted" and verdicts[name]["run_check"]["replayed"], name


def test_one_entry_by_name_even_with_a_colon():
    code, out, err = run("prove", f'{VALID}:"abs, min, max and a differential symbol"', "-q")
    assert code == 0, err
    assert "1 of 1 model proved" in out
    code, _, err = run("prove", f"{VALID}:no such entry")
    assert code == 2 and "no entry named 'no such entry'" in err and len(err.strip().splitlines()) == 1


def test_unsupported_and_malformed_archives_exit_2_with_one_line():
    for name, pattern in [("kyx_unsupported.kyx", r"kyx_unsupported\.kyx:3:\d+"),
                          ("kyx_syntax_error.kyx", r"kyx_syntax_error\.kyx:3:33")]:
        code, _, err = run("prove", str(FIXTURES / name))
        assert code == 2 and re.search(pattern, err) and len(err.strip().splitlines()) == 1, err


MIXED = """
ArchiveEntry "good"
  ProgramVariables Real x; End.
  Problem x >= 0 -> [x := x + 1;] x >= 1 End.
End.
ArchiveEntry "real exponent"
  ProgramVariables Real x; End.
  Problem x >= 1 -> [x := 2^x;] x >= 1 End.
End.
ArchiveEntry "engine lacks the rule"
  ProgramVariables Real x; Real v; End.
  Problem v = 0 & x = 0 -> [ {x' = v}@invariant(x = 0 -> v = 0) ] x = 0 End.
End.
ArchiveEntry "bad"
  ProgramVariables Real x; End.
  Problem x >= 0 -> [x := x - 1;] x >= 0 End.
End.
"""


def test_a_whole_archive_runs_every_entry_it_can_and_names_the_others(tmp_path):
    """An entry certiloop cannot read, or whose rule the engine lacks, gets its own row; the
    others are proved, falsified and gated as usual; the exit code is 2 (bad input)."""
    archive = tmp_path / "mixed.kyx"
    archive.write_text(MIXED)
    code, out, err = run("prove", str(archive), "--json", str(tmp_path / "p.json"))
    verdicts = {d["model"]: d["verdict"] for d in json.loads((tmp_path / "p.json").read_text())}
    assert verdicts == {"good": "proved", "real exponent": "not supported",
                        "engine lacks the rule": "not supported", "bad": "refuted"}
    assert code == 2 and len(err.strip().splitlines()) == 1 and "(and 1 more)" in err, err
    assert err.count("real exponent") == 1, err  # named once, not again in front of the reason
    assert "1 of 4 models proved, 2 not supported" in out and re.search(r"mixed\.kyx:8:\d+: exponent", out)
    code, out, _ = run("list", str(archive), "--json")
    assert code == 0 and [d["expected"] for d in json.loads(out)] == ["proved", "not supported", "proved",
                                                                       "proved"]
    code, out, err = run("falsify", str(archive), "--json", "-", "--max-examples", "20")
    found = {d["model"]: d["verdict"] for d in json.loads(out)}
    assert code == 2 and found["real exponent"] == "not supported" and found["bad"] == "refuted", err
    code, out, err = run("gate", str(archive), "--no-cache", "--falsify-examples", "20",
                         "--json", str(tmp_path / "g.json"))
    gate = {d["model"]: (d["verdict"], d["passed"]) for d in json.loads((tmp_path / "g.json").read_text())}
    assert code == 1 and gate == {"good": ("proved", True), "real exponent": ("not supported", False),
                                  "engine lacks the rule": ("not supported", False),
                                  "bad": ("refuted", False)}, err
    assert "FAIL real exponent: expected proved, but it is not supported:" in out


def test_a_rule_the_engine_lacks_is_bad_input_naming_the_entry():
    name = "an implication as a differential invariant"
    code, _, err = run("prove", f'{FIXTURES / "kyx_unsupported.kyx"}:"{name}"')
    assert code == 2 and err.startswith(f"certiloop: error: {name}: differential invariant"), err


def test_a_guarded_differential_invariant_is_proved():
    """`v'=0 -> x=old(x)` (KeYmaera X's STTT tutorial style): v' reads as the right-hand
    side, and a condition constant along the flow guards the atom."""
    text = """ArchiveEntry "guarded"
      ProgramVariables Real x; Real v; Real a; Real x0; End.
      Problem v = 0 & x = x0 -> [ {x' = v, v' = a}@invariant(v' = 0 -> v = old(v), v' = 0 -> x = x0) ]
                                   (a = 0 -> x = x0) End.
    End."""
    from certiloop.proofs.engine.prover import Prover

    (entry,) = read_entries(text)
    with Prover(jobs=1) as prover:
        assert prover.prove(entry.theorem).verdict == "proved"


MODAL_TESTS = """
ArchiveEntry "no flow stays below m for ever"
  ProgramVariables Real x; Real m; End.
  Problem [ ?[{x' = 1}]x <= m; ] false End.
End.
ArchiveEntry "some flow reaches m"
  ProgramVariables Real x; Real m; End.
  Problem [ ?<{x' = 1}>x >= m; ] false End.
End.
ArchiveEntry "a braking check before each step"
  ProgramVariables Real x; Real v; Real m; Real b; End.
  Problem b > 0 & v >= 0 & [{x' = v, v' = -b}]x <= m
    -> [ { { ?[{x' = v, v' = 1 & v >= 0}][{x' = v, v' = -b}]x <= m; ++ ?v = 0; }
           {x' = v, v' = -b & v >= 0} }* @invariant([{x' = v, v' = -b}]x <= m) ] x <= m End.
End.
ArchiveEntry "a check that lets the car overshoot"
  ProgramVariables Real x; Real v; Real m; End.
  Problem v = 1 & x <= m -> [ { ?[x := x + 1;]x <= m + 1; x := x + 1; }* ] x <= m End.
End.
"""


def test_tests_with_modalities_are_read_by_their_first_order_equivalent():
    """`?[a]P` in a program (KeYmaera X's model-predictive checks): the test passes where the
    expansion of [a]P holds. Never passing ([{x'=1}]x <= m is false everywhere) proves the
    box of anything; always passing (<{x'=1}>x >= m) must not; a braking check proves its
    car safe; a check that lets the car overshoot is never proved."""
    from certiloop.proofs.engine.prover import Prover

    verdicts = {}
    with Prover(jobs=1) as prover:
        for entry in read_entries(MODAL_TESTS):
            verdicts[entry.name] = prover.prove(entry.theorem).verdict
    overshoot = verdicts.pop("a check that lets the car overshoot")
    assert verdicts == {"no flow stays below m for ever": "proved", "some flow reaches m": "refuted",
                        "a braking check before each step": "proved"}
    assert overshoot != "proved"


def test_list_gate_and_falsify_accept_archives():
    code, out, _ = run("list", str(INVALID), "--json")
    assert code == 0
    assert [d["model"] for d in json.loads(out)][:2] == ["loop that overshoots", "flow that leaves"]
    assert json.loads(out)[0]["expected"] == "refuted"  # from the /*@certiloop*/ comment
    code, _, err = run("gate", f'{INVALID}:"loop that overshoots"')
    assert code == 0, err
    code, out, err = run("falsify", f'{INVALID}:"loop that overshoots"', "--max-examples", "200")
    assert code == 1, err


def test_export_cli_round_trips_and_refuses_what_kyx_cannot_say(tmp_path):
    target = tmp_path / "train.kyx"
    code, _, err = run("export", "textbook.train", "textbook.train_no_lookahead", "--kyx", "-o", str(target))
    assert code == 0, err
    code, out, _ = run("list", str(target), "--json")
    assert [(d["model"], d["expected"]) for d in json.loads(out)] == [
        ("textbook.train", "proved"), ("textbook.train_no_lookahead", "refuted")]
    code, _, err = run("export", "cfmpa.builtdr", "--kyx")
    assert code == 2 and "integer symbol `k`" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("path", [VALID, INVALID])
def test_archive_entries_round_trip_through_the_writer(path):
    """.kyx -> Theorem -> .kyx -> Theorem: the same claim (x', old(x), abs cases included)."""
    for entry in read_entries(path.read_text(), str(path)):
        (again,) = read_entries(to_kyx(entry.theorem), "again.kyx")
        assert again.theorem.content_hash == entry.theorem.content_hash, entry.name


def test_older_blocks_labels_if_else_and_precedence():
    found = entries(FIXTURES / "kyx_syntax_variety.kyx")
    first = found["labelled entry, old Functions and Variables blocks"].theorem
    assert first.assumptions.op == "cmp" and str(first.assumptions) == "x = 0"  # `P <- Q` is Q -> P
    assert {c.name for c in first.constants} == {"A", "v"}  # v: only in the guarantee
    second = found["if-else, precedence"].theorem
    conjuncts = second.assumptions.args
    assert str(conjuncts[0]) == "-x^2 <= 0"  # -(x^2), not (-x)^2
    assert conjuncts[1].op == "not" and conjuncts[1].args[0].op == "cmp"  # !(x > 1)
    box = second.guarantee.args[0]  # [if ..](..) & 2^3 = 8: the box binds tighter than &
    assert box.op == "box" and isinstance(box.payload, Choice) and len(box.payload.alternatives) == 2
    power = second.guarantee.args[1].args[0]
    assert power.op == "^" and power.payload == 3 and str(power.args[0]) == "2"
    (e,) = read_entries('ArchiveEntry "a" ProgramVariables Real x; End. Problem x^2^3 >= 0 End. End.')
    assert e.theorem.guarantee.args[0].payload == 8  # ^ is right-associative: x^(2^3)
    (e,) = read_entries('ArchiveEntry "a" ProgramVariables Real x; End. Problem x<-1 End. End.')
    assert str(e.theorem.guarantee) == "x < -1"  # as KeYmaera X: `<-` needs a blank after it


def test_made_up_names_never_clash_with_names_the_entry_spells():
    (e,) = read_entries('ArchiveEntry "a" Problem x_prime = 5 & x_old = 1 -> '
                        "[{x'=1}@invariant(x >= old(x))](x' = 1 & x_prime = 5) End. End.")
    written = {p.target.name for p in e.theorem.program.parts if isinstance(p, Assign)}
    assert written and not written & {"x_prime", "x_old"}


# random formulas: the writer's parentheses and the reader's precedence must agree exactly
_x, _y = Real("x"), Real("y")
_terms = st.recursive(
    st.one_of(st.sampled_from([_x, _y]), st.integers(-3, 3).map(const),
              st.fractions(-3, 3, max_denominator=3).map(const)),
    lambda inner: st.one_of(
        st.tuples(inner, inner).map(lambda p: p[0] + p[1]),
        st.tuples(inner, inner).map(lambda p: p[0] - p[1]),
        st.tuples(inner, inner).map(lambda p: p[0] * p[1]),
        st.tuples(inner, st.sampled_from([_x, _y])).map(lambda p: p[0] / p[1]),
        inner.map(lambda a: -a),
        st.tuples(inner, st.integers(0, 3)).map(lambda p: p[0] ** p[1])),
    max_leaves=6)
_atoms = st.tuples(_terms, st.sampled_from(["<", "<=", "==", "!=", ">=", ">"]), _terms).map(
    lambda p: cmp(p[1], p[0], p[2]))
_formulas = st.recursive(
    _atoms,
    lambda inner: st.one_of(
        st.tuples(inner, inner).map(lambda p: And(*p)), st.tuples(inner, inner).map(lambda p: Or(*p)),
        inner.map(Not), st.tuples(inner, inner).map(lambda p: Implies(*p)),
        st.tuples(inner, inner).map(lambda p: Iff(*p)), inner.map(lambda f: ForAll(_y, f)),
        inner.map(lambda f: Box(assign(_x, _x + 1), f))),
    max_leaves=5)


@given(_formulas, _formulas)
def test_random_formulas_survive_export_and_read(assumption, guarantee):
    t = Theorem("random", assumption, loop(seq(assign(_x, _x + 1), test(guarantee)), invariant=guarantee),
                guarantee)
    (entry,) = read_entries(to_kyx(t), "random.kyx")
    assert entry.error is None, entry.error
    assert entry.theorem.content_hash == t.content_hash


def test_keymaera_x_4_syntax_and_a_file_without_entries():
    """`Functions.`, `R x.`, `Problem.` (KeYmaera X 4), a byte-order mark, no ArchiveEntry: one
    entry named after the file; `R abs(R).` declares the built-in abs."""
    legacy = FIXTURES / "kyx_legacy.kyx"
    (e,) = read_entries(legacy.read_text(encoding="utf-8"), str(legacy))
    assert e.name == "kyx_legacy" and e.error is None, e.error
    assert {c.name for c in e.theorem.constants} == {"b"} and isinstance(e.theorem.program, ODE)
    code, out, err = run("prove", str(FIXTURES / "kyx_legacy.kyx"), "-q")
    assert code == 0, err + out


@pytest.mark.parametrize("text, message", [
    ('ArchiveEntry "g" ProgramVariables Real x; End. Problem [{x:=1;}^@]x>0 End. End.', "hybrid games"),
    ('ArchiveEntry "e" ProgramVariables Real x; End. Problem [x:=__________;]x>0 End. End.', "blank"),
    ('ArchiveEntry "h" Definitions HP o ::= {x\'=1}; End. Problem x>0 -> [o;]x>0 End. End.', None),
])
def test_games_and_exercise_blanks_are_named_and_hp_may_be_an_ode(text, message):
    if message is None:
        (e,) = read_entries(text)
        assert isinstance(e.theorem.program, ODE)
        return
    with pytest.raises(KyxError, match=rf"f\.kyx:1:\d+: .*{message}"):
        read_entries(text, "f.kyx")


@pytest.mark.parametrize("power, column", [("x^99999999999", 73), ("10^10^10", 74), ("x^(99999999999/2)", 74),
                                           ("x^-99999999999", 73)])
def test_a_huge_exponent_is_named_with_its_place(power, column):
    """x^(10^11) took hours to expand (the prover never answered) and 10^10^10 was computed as
    a number with ten billion digits while reading; both are refused where they are written."""
    text = f'ArchiveEntry "p" ProgramVariables Real x; End. Problem x = 1 -> [x := {power};] x > 0 End. End.'
    (e,) = read_entries(text, "f.kyx")  # the entry is its own "not supported" row, with the reason
    assert re.search(rf"f\.kyx:1:{column}: the exponent .* is larger than the 10,000 supported", str(e.error))


def test_powers_up_to_the_limit_are_read():
    text = ('ArchiveEntry "p" ProgramVariables Real x; End. '
            'Problem x = 1 -> [x := x^10000 + 2^-10000;] x > 0 End. End.')
    (e,) = read_entries(text, "f.kyx")
    assert e.error is None and e.theorem.program.value.args[0].payload == 10_000
