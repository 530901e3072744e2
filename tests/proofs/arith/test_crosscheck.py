"""Our SMT-LIB printer and the cvc5 second opinion (item 11: a check that shares neither
z3's solver nor z3's printer with the proof it re-checks)."""

from fractions import Fraction

import pytest

cvc5 = pytest.importorskip("cvc5", reason="the cross-check needs cvc5 (pip install 'certiloop[crosscheck]')")

import z3  # noqa: E402
from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from certiloop.models.lang.terms import (  # noqa: E402
    BOOL,
    FALSE,
    INT,
    REAL,
    And,
    Array,
    Bool,
    Exists,
    Family,
    ForAll,
    Iff,
    Implies,
    IndexSort,
    Int,
    Node,
    Not,
    Or,
    Real,
    Var,
    cmp,
    const,
    store,
)
from certiloop.proofs.arith.crosscheck import MISSING, CrossCheck, _solve, cross_check  # noqa: E402
from certiloop.proofs.arith.smtlib import original_name, printed, script  # noqa: E402
from certiloop.proofs.core.solver import check_valid  # noqa: E402

x, y, z = Real("x"), Real("y"), Real("z")
i, j = Int("i"), Int("j")
p, q = Bool("p"), Bool("q")
B = IndexSort("B")
b, c = Var("b", B), Var("c", B)


# --------------------------------------------------------------------------- parsing helpers


def cvc5_parse(text: str) -> tuple[set[str], set[str]]:
    """Parse with cvc5 in strict SMT-LIB mode (operands of one sort, logic symbols only);
    the declared term and sort names, turned back into certiloop names."""
    tm = cvc5.TermManager()
    solver = cvc5.Solver(tm)
    solver.setOption("strict-parsing", "true")
    sm = cvc5.SymbolManager(tm)
    parser = cvc5.InputParser(solver, sm)
    parser.setStringInput(cvc5.InputLanguage.SMT_LIB_2_6, text, "test")
    while True:
        cmd = parser.nextCommand()
        if cmd.isNull():
            break
        if cmd.getCommandName() != "check-sat":
            cmd.invoke(solver, sm)
    return ({original_name(t.getSymbol()) for t in sm.getDeclaredTerms()},
            {original_name(s.getSymbol()) for s in sm.getDeclaredSorts()})


def z3_parse(text: str) -> tuple[z3.ExprRef, set[str]]:
    """Parse with z3; the asserted formula and the free constants' certiloop names."""
    assertions = z3.parse_smt2_string(text)
    assert len(assertions) == 1
    names: set[str] = set()

    def walk(e: z3.ExprRef, seen: set) -> None:
        if e.get_id() in seen:
            return
        seen.add(e.get_id())
        if z3.is_const(e) and e.decl().kind() == z3.Z3_OP_UNINTERPRETED:
            names.add(original_name(e.decl().name()))
        if z3.is_quantifier(e):
            walk(e.body(), seen)
        elif z3.is_app(e):
            for ch in e.children():
                walk(ch, seen)

    walk(assertions[0], set())
    return assertions[0], names


def both_parse(f: Node) -> str:
    text = script(f)
    cvc5_parse(text)
    z3_parse(text)
    return text


def z3_verdict(f: Node) -> str:
    """z3 on OUR script: unsat means our text says `f` is valid."""
    s = z3.Solver()
    s.add(z3.parse_smt2_string(script(f)))
    s.set("timeout", 10_000)
    return str(s.check())


# --------------------------------------------------------------------------- the printer

NODE_KINDS = [
    x + y * 2 - z / 3 >= Fraction(-7, 4),  # + * neg / rational and negative constants
    x ** 0 + x ** 1 + x ** 3 + (x + y) ** 2 > -1,  # ^ (compound base is let-bound)
    -x == Fraction(5, 2),
    i + 2 * j - 1 < i * j,  # Int arithmetic, integer literals
    x + i <= 3,  # Real meets Int: to_real
    i / j > x,  # Int/Int division is real division
    cmp("==", i, const(Fraction(3))),
    cmp("!=", x, i),
    And(p, Or(q, Not(p)), Implies(q, p), Iff(p, q)),
    cmp("==", p, q),
    ForAll(x, Exists([y, i], y * y == x + i)),
    ForAll(b, Family("nx", B)(b) >= 0),
    cmp("==", b, c),
    Not(cmp("==", b, c)) | (Family("on", B, BOOL)(b)),
    Array("a", INT)[i + 1] == Array("a", INT)[i] + 1,
    Array("m", (INT, INT, INT), INT)[i, j, 1] > 0,  # 3-D array, curried
    cmp("==", store(Array("a", INT), (i,), x), Array("a", INT)),  # Real value, Int index
    store(Array("m", (B, INT), REAL), (b, i), const(2))[c][j] <= x,  # multi-index write
    cmp("==", Array("m", (B, INT), REAL)[b], Array("m", (B, INT), REAL)[c]),  # partial reads
    Node("and", (), BOOL),  # degenerate connectives built without the smart constructors
    Node("or", (p,), BOOL),
    Node("+", (x,), REAL) > Node("*", (), INT),
    FALSE,
]


@pytest.mark.parametrize("f", NODE_KINDS, ids=lambda f: str(f)[:40])
def test_every_node_kind_parses_in_cvc5_strict_mode_and_in_z3(f):
    text = both_parse(f)
    assert text.rstrip().endswith("(check-sat)")
    assert "(assert (not " in text


@pytest.mark.parametrize("f", NODE_KINDS, ids=lambda f: str(f)[:40])
def test_our_text_means_what_z3s_translation_means(f):
    """Read back into z3 with our symbols bound to the z3 translator's, the two translations
    are equivalent (where z3's translator applies: it uses n-ary arrays, we curry them)."""
    from certiloop.proofs.core.solver import Z3Translator

    if any(len(s.domain) > 1 for s in _array_sorts(f)):
        pytest.skip("multi-index arrays are curried in SMT-LIB, z3 uses n-ary arrays")
    if _degenerate(f):
        pytest.skip("z3's translator needs connectives and sums with enough arguments")
    f = _matrix(f)  # z3 cannot decide equivalence under binders; binders are tested below
    tr = Z3Translator()
    theirs = z3.Not(tr(f))
    body = "\n".join(line for line in script(f).splitlines() if not line.startswith("(declare-"))
    ours = z3.parse_smt2_string(body, ctx=tr.ctx,
                                sorts={f"s:{n}": s for n, s in tr.sorts.items()},
                                decls={f"v:{n}": v for n, v in tr.symbols.items()})
    s = z3.Solver(ctx=tr.ctx)
    s.add(z3.And(*ours) != theirs)
    s.set("timeout", 10_000)
    assert s.check() == z3.unsat


def _degenerate(f: Node) -> bool:
    return (f.op in ("and", "or", "+", "*") and len(f.args) < 2) or any(_degenerate(a) for a in f.args)


def _matrix(f: Node) -> Node:
    if f.op in ("forall", "exists"):
        return _matrix(f.args[0])
    return f if not f.args else Node(f.op, tuple(_matrix(a) for a in f.args), f.sort, f.payload)


def _array_sorts(f: Node):
    out = []

    def walk(n):
        out.append(n.sort)
        if n.op in ("forall", "exists"):
            out.extend(v.sort for v in n.payload)
        for a in n.args:
            walk(a)

    walk(f)
    return [s for s in out if s.is_array]


def test_constants_are_typed_by_context():
    assert "(>= |v:x| 3.0)" in script(x >= 3)
    assert "(>= |v:i| 3)" in script(i >= 3)
    assert "(>= (+ |v:x| (to_real |v:i|)) (- (/ 7.0 4.0)))" in script(x + i >= Fraction(-7, 4))
    assert "(/ (to_real |v:i|) (to_real |v:j|))" in script(i / j > 0)
    assert "(- 5)" in script(i > -5)


def test_integer_division_is_real_division():
    # 1/2 is 1/2, not integer division's 0
    f = Implies(And(cmp("==", i, 1), cmp("==", j, 2)), i / j == Fraction(1, 2))
    assert cross_check(f).status == "confirmed"
    assert z3_verdict(f) == "unsat"


def test_powers_are_repeated_products():
    assert "(* |v:x| |v:x| |v:x|)" in script(x ** 3 >= 0)
    assert cross_check(x ** 0 == 1).status == "confirmed"
    assert cross_check(x ** 2 >= 0).status == "confirmed"
    assert cross_check((x + y) ** 2 == x * x + 2 * x * y + y * y).status == "confirmed"


def test_curried_arrays_read_back_what_was_written():
    m = Array("m", (INT, INT), REAL)
    written = store(m, (i, j), x)
    assert cross_check(written[i][j] == x).status == "confirmed"
    assert cross_check(Implies(cmp("!=", i, 0), written[0][j] == m[0][j])).status == "confirmed"
    assert cross_check(written[i][0] == x).status == "disagrees"


@pytest.mark.parametrize("f,logic", [
    (x * y >= 0, "QF_NRA"),
    (x + 2 * y >= 0, "QF_LRA"),
    (x / 3 >= 0, "QF_LRA"),
    (x / y >= 0, "QF_NRA"),
    (i * j >= 0, "QF_NIA"),
    (i + j >= 0, "QF_LIA"),
    (x + i >= 0, "QF_LIRA"),
    (ForAll(y, x * y >= 0), "NRA"),
    (Family("nx", B)(b) >= x, "QF_AUFLRA"),  # a family is an array over its index sort
    (ForAll(b, Family("nx", B)(b) * x >= 0), "AUFNRA"),
    (Array("a", INT)[i] >= x * x, "QF_ANIRA"),
    (ForAll(i, Array("a", INT, INT)[i] >= 0), "ALIA"),
    (ForAll(b, Array("a", B)[b] * x >= i), "AUFNIRA"),
    (Or(p, Not(p)), "QF_UF"),
    (ForAll(b, Family("on", B, BOOL)(b)), "ALL"),
])
def test_the_logic_is_the_narrowest_that_covers_the_script(f, logic):
    assert printed(f).logic == logic
    both_parse(f)
    # cvc5 refuses to solve outside the declared logic (nonlinear in a linear one, ...)
    assert not cross_check(f).detail.startswith("cvc5 error"), cross_check(f).detail


# --------------------------------------------------------------------------- symbols

AWKWARD = ["true", "and", "x@1", "F[i@3]", "a b", "select", "pi", "exp", "θ"]


def test_awkward_names_round_trip_through_cvc5_and_z3():
    """In SMT-LIB |true| IS true (quoting does not make a new symbol), so certiloop symbols
    are printed with a prefix, |v:true|, and sorts as |s:and|."""
    syms = [Real(n) for n in AWKWARD if n != "F[i@3]"]
    sort = IndexSort("and")
    family, bound, free = Family("F[i@3]", sort), Var("or", sort), Var("not", sort)
    f = And(*(s * s >= 0 for s in syms), ForAll(bound, family(bound) >= 0)) >> (family(free) >= 0)
    text = script(f)
    names, sorts = cvc5_parse(text)
    assert names == set(AWKWARD) | {"not"}
    assert sorts == {"and"}
    _, znames = z3_parse(text)
    assert znames == names
    assert cross_check(f).status == "confirmed"


def test_the_model_of_a_disagreement_uses_certiloop_names():
    syms = [Real(n) for n in AWKWARD[:5]]
    res = cross_check(syms[0] + syms[1] + syms[2] + syms[3] + syms[4] > 1)
    assert res.status == "disagrees"
    names = {line.split(" = ")[0] for line in res.detail.splitlines()}
    assert names == set(AWKWARD[:5])


@pytest.mark.parametrize("bad", ["a|b", "a\\b", "|x|", "tab\there"])
def test_names_that_no_smtlib_symbol_can_hold_are_rejected(bad):
    with pytest.raises(ValueError, match="cannot appear in an SMT-LIB quoted symbol"):
        script(Real(bad) >= 0)
    with pytest.raises(ValueError, match="cannot appear"):
        script(Var("b", IndexSort(bad)) == Var("c", IndexSort(bad)))


def test_one_name_with_two_sorts_is_rejected():
    with pytest.raises(ValueError, match="two sorts"):
        script(And(Real("v") >= 0, Int("v") >= 0))


def test_bound_variables_shadow_free_ones():
    f = And(x >= 0, ForAll(Var("x", B), Family("nx", B)(Var("x", B)) >= 0))
    assert printed(f).symbols == {"x": REAL, "nx": Family("nx", B).sort}
    both_parse(f)


def test_modalities_and_terms_are_refused():
    with pytest.raises(ValueError, match="not a formula"):
        script(x + 1)
    from certiloop.models import assign
    from certiloop.models.lang.terms import Box

    with pytest.raises(ValueError, match="modal"):
        script(Box(assign(x, 1), x >= 0))


def test_the_comment_is_commented_out():
    text = script(x >= 0, "model a\nobligation (o1): |x| >= 0")
    assert text.startswith("; model a\n; obligation (o1): |x| >= 0\n")
    both_parse(x >= 0)


# --------------------------------------------------------------------------- verdicts


def test_a_valid_formula_is_confirmed_and_an_invalid_one_disagrees():
    ok = cross_check(Implies(And(x > 0, y > x), x * y > x * x))
    assert isinstance(ok, CrossCheck) and ok.status == "confirmed", ok
    bad = cross_check(Implies(x > 0, x * x > x))
    assert bad.status == "disagrees"
    assert bad.detail.startswith("x = ")


def test_an_algebraic_counterexample_is_shown_as_an_isolating_interval():
    res = cross_check(cmp("!=", x * x, 2))
    assert res.status == "disagrees"
    assert "root in" in res.detail and "x^2" in res.detail


def test_quantified_index_families_are_confirmed():
    nx, ny = Family("nx", B), Family("ny", B)
    f = Implies(ForAll(b, nx(b) * nx(b) + ny(b) * ny(b) == 1), ForAll(b, nx(b) <= 1))
    assert cross_check(f).status == "confirmed"


def test_the_budget_is_resources_not_time_and_is_reproducible():
    hard = Implies(And(x > 0, y > 0, z > 0, x * y * z == 1), x + y + z >= 3)  # AM-GM
    tiny = [cross_check(hard, rlimit=50) for _ in range(2)]
    assert all(r.status == "unknown" and "RESOURCEOUT" in r.detail for r in tiny)
    assert tiny[0].resources == tiny[1].resources
    easy = [cross_check(x * x + 1 > 0, rlimit=1_000_000) for _ in range(2)]
    assert easy[0].status == "confirmed" and easy[0].resources == easy[1].resources


def test_missing_cvc5_names_the_extra(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "cvc5", None)
    with pytest.raises(ImportError, match=r"certiloop\[crosscheck\]"):
        cross_check(x >= 0)
    assert "--cross-check needs cvc5" in MISSING


# --------------------------------------------------------------------------- z3 vs cvc5

VARS = [Real("x"), Real("y"), Real("z")]


@st.composite
def polynomials(draw, nvars):
    """A small polynomial: a few monomials of degree <= 3 with coefficients in -3..3."""
    terms = []
    for _ in range(draw(st.integers(1, 3))):
        coeff = draw(st.integers(-3, 3))
        powers = [draw(st.integers(0, 2)) for _ in range(nvars)]
        factors = [v ** k for v, k in zip(VARS[:nvars], powers) if k]
        terms.append(coeff * factors[0] if len(factors) == 1 else
                     Node("*", (const(coeff), *factors), REAL) if factors else const(coeff))
    return terms[0] if len(terms) == 1 else Node("+", tuple(terms), REAL)


@st.composite
def formulas(draw, nvars, depth=2):
    if depth == 0 or draw(st.booleans()):
        op = draw(st.sampled_from(["<", "<=", "==", "!=", ">=", ">"]))
        return cmp(op, draw(polynomials(nvars)), draw(st.integers(-2, 2)))
    kind = draw(st.sampled_from(["and", "or", "not", "implies"]))
    a = draw(formulas(nvars, depth - 1))
    if kind == "not":
        return Not(a)
    b = draw(formulas(nvars, depth - 1))
    return {"and": And, "or": Or, "implies": Implies}[kind](a, b)


def z3_check(f: Node):
    """certiloop's own z3 check, with a deterministic budget."""
    return check_valid(f, rlimit=5_000_000, wall_s=60.0)


@given(st.integers(2, 3).flatmap(lambda n: formulas(n)))
def test_z3_and_cvc5_never_contradict_each_other(f):
    theirs = z3_check(f)
    ours = cross_check(f, rlimit=200_000, wall_s=5.0)
    if theirs.status == "unsat":
        assert ours.status != "disagrees", (str(f), ours.detail)
    if theirs.status == "sat":
        assert ours.status != "confirmed", (str(f), theirs.model)


# --------------------------------------------------------------------------- the product: --cross-check


def _result(formula: Node, verdict: str = "proved"):
    from certiloop.proofs.core.verdicts import ObligationResult

    return ObligationResult("o1", "p", verdict, 0.0, proved_formula=formula)


def test_the_second_opinion_reports_a_disagreement_as_an_alarm():
    from certiloop.proofs.engine.second_opinion import second_opinion

    good = second_opinion([_result(x * x + 1 > 0), _result(x * x > 0, verdict="unknown")])
    assert good.confirmed == ["o1"] and good.checked == 1 and not good.disagreements
    # a "proof" of a false claim, as a z3 or translation bug would produce
    bad = second_opinion([_result(Implies(x > 0, x * x > x))])
    assert [i for i, _ in bad.disagreements] == ["o1"] and "DISAGREES" in bad.summary


def test_every_obligation_z3_proves_carries_the_form_it_proved():
    from certiloop.models import library
    from certiloop.proofs.core.vcgen import generate
    from certiloop.proofs.engine import Budget, discharge_one

    for ob in generate(library.get("sbs.ctrl1")):
        res = discharge_one(ob, Budget())
        if res.verdict == "proved":
            assert res.proved_formula is not None and cross_check(res.proved_formula).status == "confirmed"


def test_prove_cross_check_confirms_a_library_model(tmp_path):
    import json

    from certiloop.cli.main import main

    out = tmp_path / "r.json"
    assert main(["prove", "textbook.bouncing_ball", "--cross-check", "--json", str(out)]) == 0
    check = json.loads(out.read_text())["cross_check"]
    assert check["checked"] >= 1 and check["confirmed"] == check["checked"] and not check["disagreements"]


def test_a_disagreement_fails_prove_with_exit_3(monkeypatch, capsys):
    from certiloop.cli.main import main
    from certiloop.proofs.engine import second_opinion as module

    real = module.second_opinion

    def forged(obligations, rlimit=None):  # as if z3 had proved a false formula
        for ob in obligations:
            ob.proved_formula = Implies(x > 0, x * x > x)
        return real(obligations, rlimit)

    monkeypatch.setattr(module, "second_opinion", forged)
    assert main(["prove", "sbs.eqn12", "--cross-check", "--jobs", "1"]) == 3
    assert "SOUNDNESS ALARM" in capsys.readouterr().err


def test_smtlib_export_is_valid_for_names_that_are_smtlib_words(tmp_path):
    from certiloop.models.lang.programs import assign
    from certiloop.models.lang.theorem import Theorem
    from certiloop.proofs.engine import Prover

    true_, select, let = Real("true"), Real("select"), Real("let")
    theorem = Theorem("words", assumptions=And(true_ >= 0, select >= 0),
                      program=assign(let, true_ + select), guarantee=let >= 0)
    with Prover(jobs=1) as prover:
        result = prover.prove(theorem, smtlib_dir=tmp_path)
    assert result.verdict == "proved"
    files = sorted(tmp_path.glob("*.smt2"))
    assert files
    for f in files:
        text = f.read_text()
        names, _ = cvc5_parse(text)  # strict SMT-LIB 2.6
        assert names <= {"true", "select", "let"}
        assert _solve(text, {})[0] == "unsat", text
