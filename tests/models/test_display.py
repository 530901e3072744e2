"""Notebook display: theorems, formulas and programs as LaTeX (dL notation) and HTML,
proof results and violating runs as HTML."""

import re
from html import escape as html_escape

from certiloop.models import (
    And,
    Box,
    Diamond,
    Exists,
    ForAll,
    Real,
    Reals,
    Theorem,
    assign,
    choice,
    havoc,
    loop,
    ode,
    seq,
)
from certiloop.models import test as check
from certiloop.models.library import textbook
from certiloop.testing import prove

x, y, v = Reals("x y v")


def balanced(latex: str) -> bool:
    plain = latex.replace(r"\{", "").replace(r"\}", "")
    depth = 0
    for ch in plain:
        depth += {"{": 1, "}": -1}.get(ch, 0)
        if depth < 0:
            return False
    delimiters = [len(re.findall(rf"\\{side}(?![a-z])", latex)) for side in ("left", "right")]
    return depth == 0 and delimiters[0] == delimiters[1] > 0


def outside_tags(html: str) -> str:
    return re.sub(r"<[^<>]+>", "", html)


def small() -> Theorem:
    return Theorem(name="t.small", assumptions=And(x >= 0, v > 0),
                   program=loop(seq(choice(assign(x, x + v), seq(havoc(y), check(y < 0))),
                                    ode({x: v}, x <= 5))),
                   guarantee=x >= 0, description="a <tiny> one")


def test_theorem_latex_is_the_dl_claim():
    text = small()._repr_latex_()
    assert text == (r"$$x \geq 0 \land v > 0 \rightarrow \left[ \left\{ \left\{ x := x + v \cup "
                    r"y := *;\; ?\,y < 0 \right\};\; \left\{ x' = v \;\&\; x \leq 5 \right\} \right\}^* "
                    r"\right] x \geq 0$$")


def test_library_theorems_give_well_formed_latex_with_their_pieces():
    train = textbook.train()
    text = train._repr_latex_()
    assert text.startswith("$$") and text.endswith(r"\right] p \leq m$$") and balanced(text)
    for piece in (r"\rightarrow \left[", r"\cup", r"\right\}^*", r"\frac{A}{b}", r"{\mathit{vt}}^{2}",
                  r"\left\{ p' = \mathit{vt}, \mathit{vt}' = a, t' = 1 \;\&\; \mathit{vt} \geq 0"):
        assert piece in text, piece
    from certiloop.models.library import get, names
    assert all(balanced(get(n)._repr_latex_()) for n in names())
    assert not [n for n in names() if "<" in outside_tags(get(n)._repr_html_())]


def test_formulas_and_programs_have_latex_too():
    a, b_max = Real("a"), Real("b_max")
    assert (x - 1 / (2 * b_max) >= -a)._repr_latex_() == r"$x - \frac{1}{2 \cdot \mathit{b\_max}} \geq -a$"
    assert ForAll(y, Exists(x, x > y))._repr_latex_() == r"$\forall y\, \exists x\, x > y$"
    assert Box(assign(x, 1), x > 0)._repr_latex_() == r"$\left[ x := 1 \right] x > 0$"
    assert Diamond(check(x < 0), ~(x == 0))._repr_latex_() == (
        r"$\left\langle ?\,x < 0 \right\rangle \lnot \left(x = 0\right)$")
    assert (x * (y + 1) ** 2)._repr_latex_() == r"$x \cdot {\left(y + 1\right)}^{2}$"
    assert seq(havoc(x), check(And(x > 0, x < 1)))._repr_latex_() == (
        r"$x := *;\; ?\,\left(x > 0 \land x < 1\right)$")


def test_theorem_html_escapes_and_shows_name_expectation_and_claim():
    html = small()._repr_html_()
    assert "<b>t.small</b> (expected proved) — a &lt;tiny&gt; one" in html
    assert ("<p><i>x</i> ≥ 0 ∧ <i>v</i> &gt; 0 → [{{<i>x</i> := <i>x</i> + <i>v</i> ∪ <i>y</i> := *; "
            "?<i>y</i> &lt; 0}; {<i>x</i>′ = <i>v</i> &amp; <i>x</i> ≤ 5}}<sup>*</sup>] "
            "<i>x</i> ≥ 0</p>") in html
    assert "<pre>" + html_escape(small().text) + "</pre>" in html
    assert "<" not in outside_tags(html)


def test_a_result_and_its_run_display_as_html():
    result = prove(textbook.water_tank_late_check)
    html = result._repr_html_()
    assert '<b style="color:#cf222e">refuted</b>' in html
    assert "textbook.water_tank_late_check" in html and "counterexample run" in html
    assert "violated: lo &lt;= x &amp; x &lt;= hi is false at the end" in html
    assert "<" not in outside_tags(html)
    run = result.refutation._repr_html_()
    assert run.startswith("<pre>counterexample run (checked with exact rationals):") and "start: " in run
