"""Read KeYmaera X archives (.kyx) into certiloop `Theorem`s.

An entry's `Problem` is a dL formula; it becomes `assumptions -> [program] guarantee` by
peeling what is equivalent: `A -> B` moves A into the assumptions, `[a][b]P` is `[a;b]P`,
and `[a](Q -> P)` is `[a;?Q]P`. Whatever is left (a diamond, an equivalence, a quantifier)
stays in the guarantee, behind the program `?true`.

Language the engine does not have is translated exactly or refused with line and column:
  * definitions (functions, predicates, programs) are expanded where they are used;
  * `abs`, `min`, `max` are split into cases at the comparison (or assignment) using them;
  * a differential symbol `x'` is an ordinary variable that an ODE sets to its right-hand
    side at the end of the flow (dL's semantics); inside the ODE's own domain and
    annotations it is replaced by that right-hand side, which it equals along the flow;
  * `(e)'` is the total differential of e (sum of ∂e/∂x · x'; constants have none).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from lark import Lark, Token, Tree
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from certiloop.models.kyx.grammar import GRAMMAR
from certiloop.models.lang.programs import (
    ODE,
    Assign,
    Choice,
    Havoc,
    Loop,
    Program,
    Seq,
    Test,
    assign,
    children,
    choice,
    havoc,
    if_,
    loop,
    ode,
    seq,
    skip,
    test,
    written,
)
from certiloop.models.lang.terms import (
    BOOL,
    FALSE,
    MODALITIES,
    TRUE,
    And,
    Box,
    Diamond,
    Exists,
    ForAll,
    Iff,
    Implies,
    ModelError,
    Node,
    Not,
    Or,
    Real,
    Var,
    cmp,
    const,
    div,
    free_vars,
    neg,
    substitute,
)
from certiloop.models.lang.theorem import Theorem


class KyxError(ModelError):
    """A .kyx file is malformed or uses what certiloop does not support; names file:line:col."""


_PARSER: Lark | None = None
BUILTINS = ("abs", "min", "max")
METADATA = re.compile(r"/\*@certiloop (\{.*?\})\s*\*/", re.S)


def _parser() -> Lark:
    global _PARSER
    if _PARSER is None:
        _PARSER = Lark(GRAMMAR, parser="lalr", propagate_positions=True, maybe_placeholders=False)
    return _PARSER


def _where(source: str, node: Any) -> str:
    meta = getattr(node, "meta", None)
    line = getattr(node, "line", None) or getattr(meta, "line", None)
    column = getattr(node, "column", None) or getattr(meta, "column", None)
    return f"{source}:{line}:{column}" if line is not None else source


def parse_tree(text: str, source: str = "<kyx>") -> Tree:
    try:
        return _parser().parse(text)
    except UnexpectedCharacters as exc:
        raise KyxError(f"{source}:{exc.line}:{exc.column}: unexpected character "
                       f"{text[exc.pos_in_stream]!r}") from None
    except UnexpectedToken as exc:
        if exc.token.type == "$END":
            raise KyxError(f"{source}: unexpected end of file (a missing `End.`?)") from None
        raise KyxError(f"{source}:{exc.line}:{exc.column}: unexpected {_first_word(exc.token.value)!r}"
                       f" (expected {_readable(exc.accepts or exc.expected)})") from None
    except UnexpectedEOF:
        raise KyxError(f"{source}: unexpected end of file (a missing `End.`?)") from None
    except UnexpectedInput as exc:  # pragma: no cover - the three above are all lark raises
        raise KyxError(f"{source}:{exc.line}:{exc.column}: cannot parse here") from None


def _first_word(text: str) -> str:
    words = str(text).split()
    return words[0][:30] if words else str(text)[:30]


def _readable(names) -> str:
    """Terminal names as what to type: `;`, `End.`, a number, ..."""
    shown = set()
    for name in names:
        term = next((t for t in _parser().terminals if t.name == name), None)
        if name in ("IDENT", "DIFFSYM", "NUMBER", "STRING", "CMP", "ADDOP", "MULOP"):
            shown.add({"IDENT": "a name", "DIFFSYM": "x'", "NUMBER": "a number", "STRING": "a string",
                       "CMP": "a comparison", "ADDOP": "+ or -", "MULOP": "* or /"}[name])
        elif term is not None and term.pattern.type == "str":
            shown.add(f"`{term.pattern.value}`")
        elif name == "END":
            shown.add("`End.`")
    return "one of " + ", ".join(sorted(shown)) if shown else "something else"


# --------------------------------------------------------------------------- declarations


@dataclass
class Definition:
    kind: str  # constant | term | formula | program
    params: tuple[str, ...] = ()
    body: Tree | None = None
    where: Any = None


@dataclass
class Scope:
    source: str
    defs: dict[str, Definition] = field(default_factory=dict)
    variables: list[str] = field(default_factory=list)
    bools: set[str] = field(default_factory=set)

    def declare(self, name: str, d: Definition) -> None:
        if name in self.defs or name in self.variables:
            raise KyxError(f"{_where(self.source, d.where)}: `{name}` is declared twice")
        self.defs[name] = d


def _declarations(items: list[Tree], scope: Scope) -> None:
    for block in items:
        if block.data == "variables":
            for decl in block.children:
                if not isinstance(decl, Tree):
                    continue
                sort, *names = decl.children
                for n in names:
                    if str(sort) != "Real":
                        raise KyxError(f"{_where(scope.source, n)}: program variable `{n}` of sort "
                                       f"{sort}: only Real program variables are supported")
                    if n in scope.defs or n in scope.variables:
                        raise KyxError(f"{_where(scope.source, n)}: `{n}` is declared twice")
                    scope.variables.append(str(n))
        elif block.data in ("definitions", "shared"):
            for decl in block.children:
                if isinstance(decl, Tree):
                    _declaration(decl, scope)


def _params(tree: Tree | None, scope: Scope) -> tuple[str, ...]:
    if tree is None:
        return ()
    out = []
    for p in tree.children:
        sort, *name = p.children
        if str(sort) != "Real" or not name:
            raise KyxError(f"{_where(scope.source, sort)}: function parameters must be named Real "
                           "parameters, as in `Real f(Real x) = x^2;`")
        out.append(str(name[0]))
    return tuple(out)


def _declaration(decl: Tree, scope: Scope) -> None:
    kind = decl.data
    if kind == "import_":
        path = ".".join(str(c) for c in decl.children)
        if not all(str(c) in ("kyx", "math", *BUILTINS) for c in decl.children):
            raise KyxError(f"{_where(scope.source, decl)}: import {path} is not supported (only "
                           "kyx.math.abs, min and max)")
        return
    if kind == "decl_names":
        sort, *names = decl.children
        for n in names:
            scope.declare(str(n), Definition("constant", where=n))
            if str(sort) == "Bool":
                scope.bools.add(str(n))
        return
    if kind == "decl_function":
        sort, name, *rest = decl.children
        params = _params(rest[0] if rest else None, scope)
        if params:
            raise KyxError(f"{_where(scope.source, name)}: uninterpreted function `{name}` with "
                           "arguments is not supported: give it a definition (`= ...`)")
        scope.declare(str(name), Definition("constant", where=name))
        if str(sort) == "Bool":
            scope.bools.add(str(name))
        return
    if kind in ("def_term", "def_formula"):
        sort, name, *rest = decl.children
        body = rest[-1]
        params = _params(rest[0] if len(rest) == 2 else None, scope)
        want = "Real" if kind == "def_term" else "Bool"
        if str(sort) != want:
            raise KyxError(f"{_where(scope.source, name)}: `{name}` is declared {sort} but defined "
                           f"with {'=' if want == 'Real' else '<->'}")
        scope.declare(str(name), Definition("term" if want == "Real" else "formula", params, body, name))
        return
    if kind == "decl_program":
        raise KyxError(f"{_where(scope.source, decl.children[0])}: program constant "
                       f"`{decl.children[0]}` without a definition is not supported")
    if kind == "def_program":
        name, body = decl.children
        scope.declare(str(name), Definition("program", (), body, name))
        return
    raise KyxError(f"{_where(scope.source, decl)}: unsupported declaration")  # pragma: no cover


# --------------------------------------------------------------------------- expressions


class Builder:
    """Turns one entry's trees into nodes and programs."""

    def __init__(self, scope: Scope, prime_names: dict[str, str]):
        self.scope = scope
        self.source = scope.source
        self.primes = prime_names  # x -> the variable standing for x'
        self.cases: dict[str, tuple[str, tuple[Node, ...]]] = {}  # marker -> (abs|min|max, args)
        self.expanding: list[str] = []
        self.olds: dict[str, Node] | None = None  # in ODE annotations: old(e) -> its variable

    def old(self, e: Node) -> Node:
        """old(e) in an ODE's annotation: e's value before the ODE, kept in a fresh variable."""
        assert self.olds is not None
        for name, value in self.olds.items():
            if value.same(e):
                return Real(name)
        used = set(self.primes.values()) | set(self.scope.variables) | set(self.scope.defs) | set(self.olds)
        base = f"{e.payload}_old" if e.op == "var" else "old"
        candidate, k = base, 1
        while candidate in used:
            k += 1
            candidate = f"{base}{k}"
        self.olds[candidate] = e
        return Real(candidate)

    def fail(self, where: Any, message: str) -> KyxError:
        return KyxError(f"{_where(self.source, where)}: {message}")

    # ---- differential symbols
    def prime(self, name: str) -> Node:
        if name not in self.primes:
            used = set(self.primes.values()) | set(self.scope.variables) | set(self.scope.defs)
            candidate, k = f"{name}_prime", 1
            while candidate in used:
                k += 1
                candidate = f"{name}_prime{k}"
            self.primes[name] = candidate
        return Real(self.primes[name])

    def differential(self, e: Node, where: Any) -> Node:
        op = e.op
        if op == "const":
            return const(0)
        if op == "var":
            d = self.scope.defs.get(e.payload)
            if d is not None and d.kind == "constant":
                return const(0)
            if e.payload in self.primes.values():
                raise self.fail(where, f"the differential of the differential symbol `{e.payload}`")
            return self.prime(e.payload)
        if op == "+":
            return Node("+", (), e.sort) if not e.args else _sum(self.differential(a, where) for a in e.args)
        if op == "neg":
            return neg(self.differential(e.args[0], where))
        if op == "*":
            terms = []
            for i, a in enumerate(e.args):
                rest = [b for j, b in enumerate(e.args) if j != i]
                terms.append(_product([self.differential(a, where), *rest]))
            return _sum(terms)
        if op == "/":
            a, b = e.args
            return div(self.differential(a, where) * b - a * self.differential(b, where), b ** 2)
        if op == "^":
            n = e.payload
            base = e.args[0]
            return const(0) if n == 0 else n * base ** (n - 1) * self.differential(base, where)
        raise self.fail(where, f"cannot take the differential of `{e}`")

    # ---- terms and formulas
    def expr(self, t: Any, env: dict[str, Node]) -> Node:
        if isinstance(t, Token):
            raise self.fail(t, f"unexpected {t!r}")  # pragma: no cover
        rule = getattr(self, f"e_{t.data}", None)
        if rule is None:
            raise self.fail(t, f"`{t.data}` is not supported here")
        return rule(t, env)

    def e_number(self, t, env):
        text = str(t.children[0])
        return const(int(text)) if text.isdigit() else const(Fraction(text))

    def e_true(self, t, env):
        return TRUE

    def e_false(self, t, env):
        return FALSE

    def e_symbol(self, t, env):
        name = str(t.children[0])
        if name in env:
            return env[name]
        d = self.scope.defs.get(name)
        if d is not None and d.kind in ("term", "formula"):
            return self.call(t, name, [], env)
        if d is not None and d.kind == "program":
            raise self.fail(t, f"`{name}` is a program, used here as a term")
        if name in self.scope.bools:
            return Var(name, BOOL)
        return Real(name)

    def e_diffsym(self, t, env):
        return self.prime(str(t.children[0])[:-1])

    def e_differential(self, t, env):
        return self.differential(self.expr(t.children[0], env), t)

    def e_call(self, t, env):
        name, *args = t.children
        return self.call(t, str(name), args, env)

    def call(self, t, name: str, arg_trees: list, env: dict[str, Node]) -> Node:
        args = [self.expr(a, env) for a in arg_trees]
        if name == "old" and self.olds is not None and len(args) == 1:
            return self.old(args[0])
        if name in BUILTINS:
            want = 1 if name == "abs" else 2
            if len(args) != want:
                raise self.fail(t, f"{name} takes {want} argument(s), got {len(args)}")
            marker = f"{name}@{len(self.cases) + 1}"
            self.cases[marker] = (name, tuple(args))
            return Real(marker)
        d = self.scope.defs.get(name)
        if d is None:
            if name == "sqrt" or name in ("exp", "sin", "cos", "ln"):
                raise self.fail(t, f"`{name}` is not supported (no real-closed-field encoding)")
            if args:
                raise self.fail(t, f"undeclared function `{name}` with arguments is not supported")
            return Real(name)
        if d.kind == "constant":
            if args:
                raise self.fail(t, f"`{name}` is a constant, called with arguments")
            return Var(name, BOOL) if name in self.scope.bools else Real(name)
        if d.kind == "program":
            raise self.fail(t, f"`{name}` is a program, used here as a term")
        if len(args) != len(d.params):
            raise self.fail(t, f"`{name}` takes {len(d.params)} argument(s), got {len(args)}")
        if name in self.expanding:
            raise self.fail(t, f"definition of `{name}` refers to itself")
        self.expanding.append(name)
        try:
            return self.expr(d.body, dict(zip(d.params, args)))
        finally:
            self.expanding.pop()

    def e_neg(self, t, env):
        return neg(self._num(t.children[0], env))

    def _num(self, t, env) -> Node:
        n = self.expr(t, env)
        if n.sort == BOOL:
            raise self.fail(t, f"`{n}` is a formula, used here as a term")
        return n

    def _bool(self, t, env) -> Node:
        n = self.expr(t, env)
        if n.sort != BOOL:
            raise self.fail(t, f"`{n}` is a term, used here as a formula")
        return n

    def e_sum(self, t, env):
        out = self._num(t.children[0], env)
        for op, rhs in zip(t.children[1::2], t.children[2::2]):
            r = self._num(rhs, env)
            out = out + r if str(op) == "+" else out - r
        return out

    def e_product(self, t, env):
        out = self._num(t.children[0], env)
        for op, rhs in zip(t.children[1::2], t.children[2::2]):
            r = self._num(rhs, env)
            if str(op) == "*":
                out = out * r
            elif out.op == "const" and r.op == "const":  # a rational literal such as 1/3
                if r.payload == 0:
                    raise self.fail(rhs, "division by the constant 0")
                out = const(out.payload / r.payload)
            else:
                if r.op == "const" and r.payload == 0:
                    raise self.fail(rhs, "division by the constant 0")
                out = div(out, r)
        return out

    def e_power(self, t, env):
        base = self._num(t.children[0], env)
        exponent = self._num(t.children[1], env)
        if exponent.op != "const" or exponent.payload.denominator != 1 or exponent.payload < 0:
            raise self.fail(t.children[1], f"exponent `{exponent}` is not supported: only natural "
                            "number literals")
        return base ** int(exponent.payload)

    def e_comparison(self, t, env):
        a, op, b = t.children
        left, right = self.expr(a, env), self.expr(b, env)
        if left.sort == BOOL or right.sort == BOOL:
            raise self.fail(op, "comparison of formulas is not supported")
        node = cmp({"=": "==", "!=": "!="}.get(str(op), str(op)), left, right)
        return self.split_cases(node)

    def split_cases(self, f: Node) -> Node:
        """Replace abs/min/max markers in a first-order formula by a case split."""
        markers = [m for m in free_vars(f) if m in self.cases]
        if not markers:
            return f
        m = markers[0]
        kind, args = self.cases[m]
        out = Or(*(And(guard, substitute(f, {m: value})) for guard, value in _cases(kind, args)))
        return self.split_cases(out)

    def e_not_(self, t, env):
        return Not(self._bool(t.children[0], env))

    def e_conjunction(self, t, env):
        return And(*(self._bool(c, env) for c in t.children))

    def e_disjunction(self, t, env):
        return Or(*(self._bool(c, env) for c in t.children))

    def e_implication(self, t, env):
        return Implies(self._bool(t.children[0], env), self._bool(t.children[1], env))

    def e_reverse_implies(self, t, env):
        return Implies(self._bool(t.children[1], env), self._bool(t.children[0], env))

    def e_equiv(self, t, env):
        return Iff(self._bool(t.children[0], env), self._bool(t.children[1], env))

    def e_quantifier(self, t, env):
        q, *names, body = t.children
        inner = {k: v for k, v in env.items() if k not in {str(n) for n in names}}
        variables = [Real(str(n)) for n in names]
        f = self._bool(body, inner)
        return ForAll(variables, f) if str(q) == "\\forall" else Exists(variables, f)

    def e_box(self, t, env):
        return Box(self.program(t.children[0], env), self._bool(t.children[1], env))

    def e_diamond(self, t, env):
        return Diamond(self.program(t.children[0], env), self._bool(t.children[1], env))

    # ---- programs
    def program(self, t: Tree, env: dict[str, Node]) -> Program:
        rule = getattr(self, f"p_{t.data}", None)
        if rule is None:
            raise self.fail(t, f"program `{t.data}` is not supported")
        return rule(t, env)

    def p_choice(self, t, env):
        alternatives = [self.program(c, env) for c in t.children]
        if len(alternatives) == 1:
            return alternatives[0]
        # built directly, not with `choice`, so `{a ++ b} ++ c` keeps its shape
        return Choice(tuple(alternatives), tuple(f"branch {i}" for i in range(1, len(alternatives) + 1)))

    def p_sequence(self, t, env):
        return seq(*(self.program(c, env) for c in t.children))

    def p_group(self, t, env):
        return self.program(t.children[0], env)

    def p_if_then(self, t, env):
        cond = self._bool(t.children[0], env)
        then = self.program(t.children[1], env)
        other = self.program(t.children[2], env) if len(t.children) > 2 else None
        return if_(self._first_order(cond, t.children[0]), then, other)

    def _first_order(self, f: Node, where) -> Node:
        if any(m in self.cases for m in free_vars(f)):  # pragma: no cover - split at comparisons
            raise self.fail(where, "abs/min/max left in a formula")
        return f

    def p_assign(self, t, env):
        name, value = t.children
        return self._assign(self._target(name, env), self._num(value, env), value)

    def p_diff_assign(self, t, env):
        name, value = t.children
        return self._assign(self.prime(str(name)[:-1]), self._num(value, env), value)

    def _target(self, name: Token, env) -> Node:
        n = str(name)
        d = self.scope.defs.get(n)
        if n in env or (d is not None and d.kind != "constant"):
            raise self.fail(name, f"cannot assign to `{n}`: it is a parameter or a definition")
        if d is not None:
            raise self.fail(name, f"cannot assign to the constant `{n}` (declared in Definitions)")
        return Real(n)

    def _assign(self, target: Node, value: Node, where) -> Program:
        markers = [m for m in free_vars(value) if m in self.cases]
        if not markers:
            return assign(target, value)
        kind, args = self.cases[markers[0]]
        return choice(*(seq(test(self.split_cases(guard)),
                            self._assign(target, substitute(value, {markers[0]: v}), where))
                        for guard, v in _cases(kind, args)))

    def p_havoc(self, t, env):
        return havoc(self._target(t.children[0], env))

    def p_test(self, t, env):
        return test(self._bool(t.children[0], env))

    def p_program_call(self, t, env):
        name = str(t.children[0])
        d = self.scope.defs.get(name)
        if d is None or d.kind != "program":
            raise self.fail(t, f"`{name}` is not a defined program (HP {name} ::= {{...}};)")
        if name in self.expanding:
            raise self.fail(t, f"program `{name}` refers to itself")
        self.expanding.append(name)
        try:
            return self.program(d.body, {})
        finally:
            self.expanding.pop()

    def p_loop(self, t, env):
        body, _star, *notes = t.children
        invariants = self._annotations(notes, env)
        return loop(self.program(body, env), And(*invariants) if invariants else None)

    def p_ode(self, t, env):
        eqs_tree, *rest = t.children
        domain_tree = rest[0] if rest and rest[0].data != "annotation" else None
        notes = rest[1:] if domain_tree is not None else rest
        eqs: list[tuple[Node, Node]] = []
        for eq in eqs_tree.children:
            lhs, rhs = eq.children
            value = self._num(rhs, env)
            bad = [m for m in free_vars(value) if m in self.cases or m in self.primes.values()]
            if bad:
                raise self.fail(rhs, "abs/min/max or a differential symbol in an ODE right-hand side "
                                "is not supported")
            eqs.append((Real(str(lhs)[:-1]), value))
        domain = TRUE if domain_tree is None else self._bool(domain_tree, env)
        outer, self.olds = self.olds, {}
        try:
            invariants = self._annotations(notes, env)
            olds = self.olds
        finally:
            self.olds = outer
        # along the flow x' equals its right-hand side (only primes already in use matter)
        flow = {self.primes[x.payload]: f for x, f in eqs if x.payload in self.primes}
        domain, invariants = substitute(domain, flow), [substitute(i, flow) for i in invariants]
        try:
            system = ode(eqs, domain, invariants=invariants)
        except ModelError as exc:
            raise self.fail(t, str(exc)) from None
        # old(e): remember e just before the flow
        return seq(*(assign(Real(n), e) for n, e in olds.items()), system) if olds else system

    def _annotations(self, notes: list[Tree], env) -> list[Node]:
        out: list[Node] = []
        for note in notes:
            kind, *formulas = note.children
            if str(kind) != "@invariant":
                continue  # @variant: for diamond proofs, which do not use it
            for f in formulas:
                out.append(self._bool(f, env))
        return out


def _sum(items) -> Node:
    items = list(items)
    out = items[0]
    for x in items[1:]:
        out = out + x
    return out


def _product(items) -> Node:
    out = items[0]
    for x in items[1:]:
        out = out * x
    return out


def _cases(kind: str, args: tuple[Node, ...]) -> list[tuple[Node, Node]]:
    """(guard, value) pairs, exhaustive and exclusive, for abs(a), min(a, b), max(a, b)."""
    if kind == "abs":
        (a,) = args
        return [(a >= 0, a), (a < 0, -a)]
    a, b = args
    if kind == "min":
        return [(a <= b, a), (a > b, b)]
    return [(a >= b, a), (a < b, b)]


# --------------------------------------------------------------------------- problem -> Theorem


def _with_ode_primes(p: Program, primes: dict[str, str]) -> Program:
    """After every ODE, set the differential symbols in use to the right-hand sides (dL:
    x' = f(x) holds in the final state of every run, also the run of duration 0)."""
    if isinstance(p, ODE):
        sets = [assign(Real(primes[v.payload]), f) for v, f in p.eqs if v.payload in primes]
        return seq(p, *sets) if sets else p
    if isinstance(p, Seq):
        return seq(*(_with_ode_primes(q, primes) for q in p.parts))
    if isinstance(p, Loop):
        return Loop(_with_ode_primes(p.body, primes), p.invariant, p.label, p.each, p.count)
    if hasattr(p, "alternatives"):
        return type(p)(tuple(_with_ode_primes(q, primes) for q in p.alternatives), p.labels)
    return p


def _primes_in_formula(f: Node, primes: dict[str, str]) -> Node:
    if f.op in MODALITIES:
        inner = _primes_in_formula(f.args[0], primes)
        return Node(f.op, (inner,), f.sort, _with_ode_primes(f.payload, primes))
    if not f.args:
        return f
    return Node(f.op, tuple(_primes_in_formula(a, primes) for a in f.args), f.sort, f.payload)


def _has_loop(p: Program) -> bool:
    return isinstance(p, Loop) or any(_has_loop(q) for q in children(p))


def _nested_loop(f: Node) -> bool:
    if f.op in MODALITIES and _has_loop(f.payload):
        return True
    if f.op in MODALITIES:
        return _nested_loop(f.args[0])
    return any(_nested_loop(a) for a in f.args)


def split_problem(f: Node, exact: bool = False) -> tuple[Node, Program, Node]:
    """`A -> [a](Q -> [b]P)` as (A, a; ?Q; b, P): each step an equivalence. exact: just
    `A -> [a]P` (how certiloop writes a theorem, so it reads back as the same one)."""
    if exact:
        assumptions, rest = (f.args[0], f.args[1]) if f.op == "implies" else (TRUE, f)
        if rest.op == "box":
            return assumptions, rest.payload, rest.args[0]
        return assumptions, skip(), rest
    assumptions: list[Node] = []
    parts: list[Program] = []
    while True:
        if f.op == "implies" and not parts:
            assumptions.append(f.args[0])
            f = f.args[1]
        elif f.op == "implies" and parts and f.args[0].op not in MODALITIES and not _modal(f.args[0]):
            parts.append(test(f.args[0]))
            f = f.args[1]
        elif f.op == "box":
            parts.append(f.payload)
            f = f.args[0]
        else:
            break
    return And(*assumptions), seq(*parts) if parts else skip(), f


def _modal(f: Node) -> bool:
    return f.op in MODALITIES or any(_modal(a) for a in f.args)


@dataclass
class Entry:
    name: str
    kind: str
    theorem: Theorem | None
    error: str | None  # why the entry cannot be used (not supported), with line and column


def read_entries(text: str, source: str = "<kyx>") -> list[Entry]:
    """Every entry of an archive, each a Theorem or the one-line reason it is not supported.
    A syntax error in the file raises KyxError (no entry can be trusted then)."""
    tree = parse_tree(text, source)
    if tree.data == "bare_formula":
        raise KyxError(f"{source}: a bare formula, not an archive: wrap it in "
                       "ArchiveEntry \"name\" Problem ... End. End.")
    shared = Scope(source)
    entries: list[Entry] = []
    seen: set[str] = set()
    for item in tree.children:
        if item.data == "shared":
            _declarations([item], shared)
            continue
        kind, *rest = item.children
        name_tok = next(c for c in rest if isinstance(c, Token) and c.type == "STRING")
        name = json.loads(str(name_tok)) if "\\" in str(name_tok) else str(name_tok)[1:-1]
        if name in seen:
            raise KyxError(f"{_where(source, name_tok)}: two entries named {name!r}")
        seen.add(name)
        span = text[item.meta.start_pos:item.meta.end_pos]
        try:
            theorem = _entry_theorem(item, name, shared, span, source)
            entries.append(Entry(name, str(kind), theorem, None))
        except ModelError as exc:
            message = str(exc)
            if not isinstance(exc, KyxError):
                message = f"{_where(source, name_tok)}: {message}"
            entries.append(Entry(name, str(kind), None, message))
    return entries


def _entry_theorem(item: Tree, name: str, shared: Scope, span: str, source: str) -> Theorem:
    scope = Scope(source, dict(shared.defs), list(shared.variables), set(shared.bools))
    blocks = [c for c in item.children if isinstance(c, Tree) and c.data in ("definitions", "variables")]
    _declarations(blocks, scope)
    problem = next(c for c in item.children if isinstance(c, Tree) and c.data == "problem")
    builder = Builder(scope, {})
    formula_tree = problem.children[0]
    f = builder.expr(formula_tree, {})
    if f.sort != BOOL:
        raise KyxError(f"{_where(source, problem)}: the Problem is a term, not a formula")
    if builder.primes:
        f = _primes_in_formula(f, builder.primes)
    meta = _metadata(span, source, problem)
    if meta.get("names"):
        f = _rename(f, meta["names"])
    assumptions, program, guarantee = split_problem(f, exact=meta.get("shape") == "A->[a]P")
    for part, what in ((assumptions, "an assumption"), (guarantee, "the guarantee")):
        if _nested_loop(part):
            raise KyxError(f"{_where(source, problem)}: a loop inside {what}'s modality is not "
                           "supported (only the outermost [..] of the Problem may hold loops)")
    names = meta.get("names", {})
    constants = [Real(names.get(n, n)) for n, d in scope.defs.items()
                 if d.kind == "constant" and n not in scope.bools]
    writes = written(program)
    for c in constants:
        if c.payload in writes:
            raise KyxError(f"{_where(source, problem)}: the program writes `{c.payload}`, declared "
                           "constant in Definitions")
    theorem = Theorem(
        name=name,
        assumptions=assumptions,
        program=_relabel(program, meta.get("labels", [])),
        guarantee=guarantee,
        expected=meta.get("expected", "proved"),
        constants=tuple(constants) + _guarantee_only(assumptions, program, guarantee, constants),
        description=meta.get("description", ""),
        unroll=meta.get("unroll", 3),
        check_nonblocking=meta.get("check_nonblocking", False),
        abbreviations={k: _rename(_meta_term(v, scope, source), names)
                       for k, v in meta.get("abbreviations", {}).items()},
        scenarios=tuple(_rename(_meta_formula(s, scope, source), names) for s in meta.get("scenarios", [])),
    )
    return theorem


def _guarantee_only(assumptions: Node, program: Program, guarantee: Node, constants) -> tuple[Node, ...]:
    """Symbols only the guarantee mentions: declared, never written, so constants."""
    known = set(free_vars(assumptions)) | set(program.symbols()) | {c.payload for c in constants}
    return tuple(v for n, v in free_vars(guarantee).items() if n not in known and v.sort != BOOL)


def _metadata(span: str, source: str, where) -> dict:
    m = METADATA.search(span)
    if m is None:
        return {}
    try:
        data = json.loads(m.group(1))
    except json.JSONDecodeError as exc:
        raise KyxError(f"{_where(source, where)}: unreadable /*@certiloop ...*/ comment: {exc}") from None
    return data if isinstance(data, dict) else {}


def _meta_term(text: str, scope: Scope, source: str) -> Node:
    tree = parse_tree(f'ArchiveEntry "m" Problem {text} = 0 End. End.', source)
    f = Builder(scope, {}).expr(tree.children[0].children[-2].children[0], {})
    return f.args[0]


def _meta_formula(text: str, scope: Scope, source: str) -> Node:
    tree = parse_tree(f'ArchiveEntry "m" Problem {text} End. End.', source)
    return Builder(scope, {}).expr(tree.children[0].children[-2].children[0], {})


def _rename(f: Node, names: dict[str, str]) -> Node:
    """Rename symbols (KeYmaera X's spelling -> certiloop's) everywhere in a formula."""

    def node(n: Node) -> Node:
        if n.op == "var":
            return Var(names.get(n.payload, n.payload), n.sort)
        payload = n.payload
        if n.op in ("forall", "exists"):
            payload = tuple(node(v) for v in payload)
        elif n.op in MODALITIES:
            payload = program(payload)
        return Node(n.op, tuple(node(a) for a in n.args), n.sort, payload)

    def program(p: Program) -> Program:
        if isinstance(p, Assign):
            return Assign(node(p.target), node(p.value))
        if isinstance(p, Havoc):
            return Havoc(node(p.target))
        if isinstance(p, Test):
            return Test(node(p.cond))
        if isinstance(p, Seq):
            return Seq(tuple(program(q) for q in p.parts))
        if isinstance(p, Loop):
            inv = None if p.invariant is None else node(p.invariant)
            return Loop(program(p.body), inv, p.label, p.each, p.count)
        if isinstance(p, ODE):
            return ODE(tuple((node(v), node(e)) for v, e in p.eqs), node(p.domain),
                       tuple(node(i) for i in p.invariants))
        return type(p)(tuple(program(q) for q in p.alternatives), p.labels)

    return node(f)


def _relabel(p: Program, labels: list) -> Program:
    """Put back certiloop's branch and loop labels (pre-order), which .kyx has no syntax for."""
    if not labels:
        return p
    queue = list(labels)

    def walk(q: Program) -> Program:
        if isinstance(q, Seq):
            return Seq(tuple(walk(x) for x in q.parts))
        if isinstance(q, Loop):
            label = queue.pop(0) if queue else q.label
            return Loop(walk(q.body), q.invariant, label, q.each, q.count)
        if hasattr(q, "alternatives"):
            names = tuple(queue.pop(0) if queue else lab for lab in q.labels)
            return type(q)(tuple(walk(x) for x in q.alternatives), names)
        return q

    return walk(p)


__all__ = ["Entry", "KyxError", "read_entries", "split_problem", "Assign", "Havoc", "Test"]
