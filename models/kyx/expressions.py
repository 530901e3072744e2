"""Build certiloop terms, formulas and programs from one entry's parse trees (definitions
expanded, abs/min/max split into cases, square roots eliminated or named, differential
symbols and old(x) translated)."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from lark import Token, Tree

from certiloop.models.kyx.archive import BUILTINS, KyxError, Scope, place
from certiloop.models.kyx.lifting import NotDifferentiable, moves, rate
from certiloop.models.kyx.square_roots import (
    NotPolynomialInRoot,
    exact_root,
    never_negative,
    number,
    without_root,
)
from certiloop.models.lang.conveniences import if_
from certiloop.models.lang.nesting import divides
from certiloop.models.lang.programs import (
    ODE,
    Choice,
    Loop,
    Program,
    Seq,
    Test,
    assign,
    children,
    choice,
    havoc,
    loop,
    ode,
    seq,
    test,
    written,
)
from certiloop.models.lang.terms import (
    BOOL,
    FALSE,
    MAX_EXPONENT,
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


class Builder:
    """Turns one entry's trees into nodes and programs."""

    def __init__(self, scope: Scope, prime_names: dict[str, str], taken: set[str] = frozenset()):
        self.scope = scope
        self.taken = set(taken)  # every name the entry spells: made-up names must differ
        self.source = scope.source
        self.primes = prime_names  # x -> the variable standing for x'
        self.cases: dict[str, tuple[str, tuple[Node, ...]]] = {}  # marker -> (abs|min|max|sqrt, args)
        # symbol -> (e, where): a root of a term that may be negative, named for the reader
        # to pin down (s >= 0 & s^2 = e) where the claim shows e >= 0 (reader.py)
        self.named_roots: dict[str, tuple[Node, Any]] = {}
        self.binders: list[frozenset[str]] = []  # symbols bound around what is being built
        self.made: set[str] = set()  # names made up here (fresh_variable)
        self.expanding: list[str] = []
        self.olds: dict[str, Node] | None = None  # in loop and ODE annotations: old(e) -> its variable
        # square roots in ODE right-hand sides (lifting.py): while one is read, its variables;
        # the roots lifted there (e, s, moved by the flow); side conditions `Q -> e > 0`
        self.flow: frozenset[str] | None = None
        self.lifted: list[tuple[Node, Node, bool]] = []
        # abs/min/max read while a right-hand side is: (a, its sign g, moved by the flow, as written)
        self.signs: list[tuple[Node, Node, bool, str]] = []
        self.lift_conditions: list[tuple[str, Node]] = []
        # where a lifted root written again means its variable: (e, s, binders around it then,
        # programs being read then: inside a program read later, statements may write e)
        self.aliases: list[tuple[Node, Node, int, int]] = []
        self.programs = 0  # programs being read around what is being built
        self.lifted_flows: dict[int, tuple[ODE, list[tuple[Node, Node, bool]]]] = {}

    def old(self, e: Node) -> Node:
        """old(e) in a loop's or an ODE's annotation: e's value before it, kept in a fresh variable."""
        assert self.olds is not None
        for name, value in self.olds.items():
            if value.same(e):
                return Real(name)
        used = self._used() | set(self.olds)
        base = f"{e.payload}_old" if e.op == "var" and e.payload not in self.cases else "old"
        candidate, k = base, 1
        while candidate in used:
            k += 1
            candidate = f"{base}{k}"
        self.olds[candidate] = e
        return Real(candidate)

    def _used(self) -> set[str]:
        return (self.taken | set(self.primes.values()) | set(self.scope.variables) | set(self.scope.defs)
                | self.made | set(self.named_roots))

    def fail(self, where: Any, message: str) -> KyxError:
        return KyxError(f"{place(self.source, where)}: {message}")

    # ---- differential symbols
    def prime(self, name: str) -> Node:
        if name not in self.primes:
            used = self._used() | set(self.olds or {})
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
            if e.payload in self.cases or e.payload in self.named_roots:
                raise self.fail(where, "the differential of abs/min/max or a square root is not supported")
            return self.prime(e.payload)
        if op == "+":
            return _sum(self.differential(a, where) for a in e.args)
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
            if self.flow is not None:  # an ODE's right-hand side: a run may cross between the cases
                return self._lifted_case(name, args, t)
            marker = f"{name}@{len(self.cases) + 1}"
            self.cases[marker] = (name, tuple(args))
            return Real(marker)
        d = self.scope.defs.get(name)
        if d is None and name == "sqrt":
            if len(args) != 1:
                raise self.fail(t, f"sqrt takes 1 argument, got {len(args)}")
            if args[0].sort == BOOL:
                raise self.fail(t, f"`{self.shown(args[0])}` is a formula, used here as a term")
            return self.root(args[0], t)
        if d is None:
            if name in ("exp", "sin", "cos", "ln"):
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
            out = self.expr(d.body, dict(zip(d.params, args)))
        finally:
            self.expanding.pop()
        # KeYmaera X refuses both ways of meaning something else (a substitution clash): an
        # argument pasted under the body's binder of its symbol, and a symbol of the body's own
        # pasted under a binder of it around the use
        bound = _binds(out)
        passed: set[str] = set()
        for arg in args:
            passed |= (symbols := self.symbols(arg))
            if clash := sorted(symbols & bound):
                raise self.fail(t, f"substitution clash: the argument `{self.shown(arg)}` of `{name}` "
                                   f"mentions `{clash[0]}`, which the definition binds (a quantifier or "
                                   "a program writing it): use another name")
        around = set().union(*self.binders) if self.binders else set()
        # a name made up here (a lifted root's variable, a sign) stands for what the arguments
        # give, never for a symbol of the definition's own
        if clash := sorted((self.symbols(out) - passed - set(d.params) - self.made) & around):
            raise self.fail(t, f"substitution clash: the definition of `{name}` mentions `{clash[0]}`, which "
                               "is bound where it is used (by a quantifier or a program writing it): "
                               "pass it as an argument")
        return out

    def symbols(self, n: Node) -> set[str]:
        """The free symbols of n, with each abs/min/max or root marker read as the symbols of
        what it stands for."""
        out: set[str] = set()
        for name in free_vars(n):
            if name in self.cases:
                for a in self.cases[name][1]:
                    out |= self.symbols(a)
            elif name in self.named_roots:
                out |= {name} | self.symbols(self.named_roots[name][0])
            else:
                out.add(name)
        return out

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
                if number(r) == 0:
                    raise self.fail(rhs, "division by the constant 0")
                out = div(out, r)
        return out

    def e_power(self, t, env):
        base = self._num(t.children[0], env)
        exponent = self._num(t.children[1], env)
        if exponent.op == "^" and exponent.args[0].op == "const":  # 2^3 in x^2^3: a number
            if abs(exponent.args[0].payload) > 1 and exponent.payload > MAX_EXPONENT:
                raise self.fail(t.children[1], f"the exponent `{self.shown(exponent)}` is larger than the "
                                f"{MAX_EXPONENT:,} supported")
            exponent = const(exponent.args[0].payload ** exponent.payload)
        if exponent.op == "const" and abs(exponent.payload) > MAX_EXPONENT:  # x^(10^11): hours to expand
            raise self.fail(t.children[1], f"the exponent `{self.shown(exponent)}` is larger than the "
                            f"{MAX_EXPONENT:,} supported")
        if exponent.op == "const" and exponent.payload.denominator == 2:  # x^(k/2) = x^((k-1)/2)*sqrt(x)
            k = exponent.payload.numerator
            if k < 0 and number(base) == 0:
                raise self.fail(t, "division by the constant 0 (a negative power of 0)")
            whole = self.root(base, t)
            if abs(k) > 1:
                whole = whole * base ** ((abs(k) - 1) // 2)
            return whole if k > 0 else div(const(1), whole)
        if exponent.op != "const" or exponent.payload.denominator != 1:
            raise self.fail(t.children[1], f"exponent `{self.shown(exponent)}` is not supported: only "
                            "integer literals and halves (square roots)")

        if exponent.payload >= 0:
            return base ** int(exponent.payload)
        # x^-n is 1/x^n, a division: defined only where x != 0, which the claim's
        # well-definedness obligations check like any other division (10^-10 is a number)
        if (value := number(base)) == 0:
            raise self.fail(t, "division by the constant 0 (a negative power of 0)")
        if value is not None:
            return const(1 / value ** int(-exponent.payload))
        power = -int(exponent.payload)
        return div(const(1), base if power == 1 else base ** power)

    def e_comparison(self, t, env):
        a, op, b = t.children
        left, right = self.expr(a, env), self.expr(b, env)
        if left.sort == BOOL or right.sort == BOOL:
            raise self.fail(op, "comparison of formulas is not supported")
        node = cmp({"=": "==", "!=": "!="}.get(str(op), str(op)), left, right)
        return self.split_cases(node, op)

    def root(self, e: Node, where) -> Node:
        """sqrt(e): a number; a marker eliminated at its comparison when e is never negative by
        its shape; otherwise a symbol the reader pins down where the claim shows e >= 0."""
        signs = {g.payload for _, g, _, _ in self.signs}
        if any(m in self.cases or m in self.named_roots or m in signs for m in free_vars(e)):
            raise self.fail(where, f"the square root of `{self.shown(e)}`, which holds abs/min/max or "
                            "another root, is not supported")
        if (alias := self._alias(e)) is not None:
            return alias
        if (value := number(e)) is not None:
            e = const(value)
        if e.op == "const":
            if e.payload < 0:
                raise self.fail(where, f"the square root of the negative number {e.payload}")
            exact = exact_root(e.payload)
            if exact is not None:
                return const(exact)
        if self.flow is not None and (e.op == "const" or moves(e, self.flow) or never_negative(e)):
            return self._lift(e, where)  # in an ODE's right-hand side
        if never_negative(e):
            marker = f"sqrt@{len(self.cases) + 1}"
            self.cases[marker] = ("sqrt", (e,))
            return Real(marker)
        for name, (known, _) in self.named_roots.items():
            if known.same(e):
                return Real(name)
        named = self.fresh_variable("sqrt")
        self.named_roots[named.payload] = (e, where)
        return named

    def _lifted_case(self, kind: str, args: list[Node], where) -> Node:
        """abs/min/max in an ODE's right-hand side, where the flow cannot be split into the
        cases (a run may cross between them, infinitely often for all we know): |a| becomes
        g*a with a constant sign g = ±1 (lifting.py, `signed`), min(a, b) = (a + b - |a - b|)/2
        and max(a, b) = (a + b + |a - b|)/2."""
        if any(a.sort == BOOL for a in args):
            raise self.fail(where, f"{kind} takes terms, not formulas")
        if kind != "abs" and args[0].same(args[1]):  # min(a, a) = a: no sign to keep
            return args[0]
        a = args[0] if kind == "abs" else args[0] - args[1]
        written = f"{kind}({', '.join(str(self.shown(x)) for x in args)})"
        magnitude = self._signed(a, where, written)
        if kind == "abs":
            return magnitude
        total, half = args[0] + args[1], const(Fraction(1, 2))
        return half * (total - magnitude) if kind == "min" else half * (total + magnitude)

    def _signed(self, a: Node, where, written: str) -> Node:
        """|a| in the right-hand side being read: g*a for a fresh constant g = ±1."""
        if set(free_vars(a)) & set(self.primes.values()):
            raise self.fail(where, "a differential symbol in an ODE right-hand side is not supported")
        for known, g, _, _ in self.signs:
            if known.same(a):
                return g * a
        g = self.fresh_variable("sign")
        moving = moves(a, self.flow) or bool(set(free_vars(a)) & self._lifted_names())
        self.signs.append((a, g, moving, written))
        return g * a

    def _lifted_names(self) -> set[str]:
        return {s.payload for _, s, _ in self.lifted}

    def _alias(self, e: Node) -> Node | None:
        """The variable a root of e was lifted to, where it still means sqrt(e): right after
        or along its flow, where no quantifier or program since has bound e's symbols."""
        for known, s, depth, programs in reversed(self.aliases):
            if known.same(e) and programs == self.programs and not any(
                    set(free_vars(e)) & b for b in self.binders[depth:]):
                return s
        return None

    def _lift(self, e: Node, where) -> Node:
        """sqrt(e) in the right-hand side being read: a variable of the flow (lifting.py)."""
        for known, s, _ in self.lifted:
            if known.same(e):
                return s
        mentioned = set(free_vars(e))
        if mentioned & {s.payload for _, s, _ in self.lifted}:  # its rate would need the inner one's
            raise self.fail(where, f"the square root of `{self.shown(e)}`, which holds another root, in an "
                            "ODE's right-hand side is not supported")
        if mentioned & set(self.primes.values()):
            raise self.fail(where, "a differential symbol in an ODE right-hand side is not supported")
        s = self.fresh_variable("sqrt")
        self.lifted.append((e, s, moves(e, self.flow)))
        return s

    def fresh_variable(self, base: str) -> Node:
        """A real symbol named after `base` that the entry does not use."""
        used = self._used() | set(self.olds or {})
        candidate, k = base, 1
        while candidate in used:
            k += 1
            candidate = f"{base}{k}"
        self.made.add(candidate)
        return Real(candidate)

    def shown(self, n: Node) -> Node:
        """n for a message: abs/min/max and root markers written as the calls they stand for."""
        markers = {m: Real(f"{kind}({', '.join(str(self.shown(a)) for a in args)})")
                   for m, (kind, args) in self.cases.items() if m in free_vars(n)}
        return substitute(n, markers) if markers else n

    def split_cases(self, f: Node, where=None) -> Node:
        """Replace abs/min/max markers in a first-order formula by a case split, and square
        roots of never-negative terms by their sign conditions (roots.py)."""
        markers = [m for m in free_vars(f) if m in self.cases]
        if not markers:
            return f
        m = markers[0]
        kind, args = self.cases[m]
        if kind == "sqrt":
            try:
                return self.split_cases(without_root(f, m, args[0]), where)
            except NotPolynomialInRoot as exc:
                raise self.fail(where, f"a square root inside {exc} is not supported") from None
        out = Or(*(And(guard, substitute(f, {m: value})) for guard, value in _cases(kind, args)))
        return self.split_cases(out, where)

    def e_not_(self, t, env):
        return Not(self._bool(t.children[0], env))

    def e_conjunction(self, t, env):
        return _as_written(And, "and", [self._bool(c, env) for c in t.children])

    def e_disjunction(self, t, env):
        return _as_written(Or, "or", [self._bool(c, env) for c in t.children])

    def e_implication(self, t, env):
        left, right = t.children
        return _as_written(Implies, "implies", [self._bool(left, env), self._bool(right, env)])

    def e_reverse_implies(self, t, env):
        left, right = t.children[-1], t.children[0]
        return _as_written(Implies, "implies", [self._bool(left, env), self._bool(right, env)])

    def e_equiv(self, t, env):
        return Iff(self._bool(t.children[0], env), self._bool(t.children[1], env))

    def e_quantifier(self, t, env):
        q, *names, body = t.children
        for n in names:
            if str(n) in self.scope.defs:
                raise self.fail(n, f"cannot quantify over `{n}`: it is declared in Definitions")
        inner = {k: v for k, v in env.items() if k not in {str(n) for n in names}}
        variables = [Real(str(n)) for n in names]
        self.binders.append(frozenset(str(n) for n in names))
        try:
            f = self._bool(body, inner)
        finally:
            self.binders.pop()
        return ForAll(variables, f) if str(q) == "\\forall" else Exists(variables, f)

    def e_box(self, t, env):
        return Box(*self._modality(t, env))

    def e_diamond(self, t, env):
        return Diamond(*self._modality(t, env))

    def _modality(self, t, env) -> tuple[Program, Node]:
        program = self.program(t.children[0], env)
        self.binders.append(frozenset(written(program)))
        last = _last_statement(program)
        lifted = self.lifted_flows.get(id(last), (None, []))
        aliases = [(e, s, len(self.binders), self.programs) for e, s, _ in lifted[1]]
        aliases = aliases if lifted[0] is last else []
        self.aliases.extend(aliases)  # the post is evaluated right after the flow
        try:
            return program, self._bool(t.children[1], env)
        finally:
            del self.aliases[len(self.aliases) - len(aliases):]
            self.binders.pop()

    # ---- programs
    def program(self, t: Tree, env: dict[str, Node]) -> Program:
        rule = getattr(self, f"p_{t.data}", None)
        if rule is None:
            raise self.fail(t, f"program `{t.data}` is not supported")
        self.programs += 1
        try:
            return rule(t, env)
        finally:
            self.programs -= 1

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
        if kind == "sqrt":  # the root's one value (its argument is never negative), then the rest
            r = self.fresh_variable("root")
            return seq(havoc(r), test(And(r >= 0, cmp("==", r * r, args[0]))),
                       self._assign(target, substitute(value, {markers[0]: r}), where))
        return choice(*(seq(test(self.split_cases(guard, where)),
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
        invariants, olds = self._annotations_with_olds(notes, env)
        built = loop(self.program(body, env), And(*invariants) if invariants else None)
        # old(e) in the invariant: e's value before the loop (kept while the loop runs)
        return seq(*(self._assign(Real(n), e, t) for n, e in olds.items()), built) if olds else built

    def p_ode(self, t, env):
        eqs_tree, *rest = t.children
        domain_tree = rest[0] if rest and rest[0].data != "annotation" else None
        notes = rest[1:] if domain_tree is not None else rest
        eqs: list[tuple[Node, Node]] = []
        outer = self.flow, self.lifted, self.signs
        self.flow = frozenset(str(eq.children[0])[:-1] for eq in eqs_tree.children)
        self.lifted, self.signs = [], []
        try:
            for eq in eqs_tree.children:
                lhs, rhs = eq.children
                value = self._num(rhs, env)
                bad = [m for m in free_vars(value) if m in self.cases or m in self.primes.values()]
                if bad:
                    raise self.fail(rhs, "a differential symbol in an ODE right-hand side is not supported")
                eqs.append((Real(str(lhs)[:-1]), value))
            lifted, signs = self.lifted, self.signs
        finally:
            self.flow, self.lifted, self.signs = outer
        domain = TRUE if domain_tree is None else self._bool(domain_tree, env)
        self.aliases.extend((e, s, len(self.binders), self.programs) for e, s, _ in lifted)  # along the flow
        try:
            invariants, olds = self._annotations_with_olds(notes, env, differential=True)
        finally:
            del self.aliases[len(self.aliases) - len(lifted):]
        # along the flow x' equals its right-hand side (only primes already in use matter)
        flow = {self.primes[x.payload]: f for x, f in eqs if x.payload in self.primes}
        domain, invariants = substitute(domain, flow), [substitute(i, flow) for i in invariants]
        if set(free_vars(domain)) & {s.payload for _, s, _ in lifted}:
            # the domain reads x' = sqrt(e) where the side condition has not shown e >= 0
            raise self.fail(t, "a differential symbol in the domain of an ODE whose right-hand side takes a "
                            "square root is not supported")
        prefix, eqs, domain = self._lifted_flow(lifted, eqs, domain, t)
        prefix, domain = self._signed_flow(signs, prefix, domain)
        try:
            system = ode(eqs, domain, invariants=invariants)
        except ModelError as exc:
            raise self.fail(t, str(exc)) from None
        if lifted:
            self.lifted_flows[id(system)] = (system, lifted)
        # old(e): remember e just before the flow (after the lifted roots start: e may hold one)
        return seq(*prefix, *(self._assign(Real(n), e, t) for n, e in olds.items()), system)

    def _lifted_flow(self, lifted, eqs, domain, where):
        """The statements that start each lifted root, the flow's equations and domain with
        them (lifting.py), and the side condition `domain -> e > 0` of each moving root."""
        prefix: list[Program] = []
        rates = {x.payload: f for x, f in eqs}
        extra, inside = [], []
        for e, s, moving in lifted:
            pinned = And(s > 0 if moving else s >= 0, cmp("==", s * s, e))
            prefix += [havoc(s), test(pinned)]
            if not moving:
                continue
            try:
                speed = rate(e, rates)
            except NotDifferentiable as exc:
                raise self.fail(where, f"the square root of `{self.shown(e)}` in an ODE: cannot "
                                f"differentiate {exc}") from None
            extra.append((s, div(speed, 2 * s)))
            inside.append(pinned)
            self.lift_conditions.append((f"the flow keeps `{self.shown(e)}` > 0 (its square root is lifted)",
                                         Implies(domain, e > 0)))
        return prefix, eqs + extra, And(domain, *inside) if inside else domain

    def _signed_flow(self, signs, prefix: list[Program], domain: Node) -> tuple[list[Program], Node]:
        """Each sign g of an |a| in the flow is chosen before it, so that g*a = |a| there
        (lifting.py, `signed`). If the flow moves a, the domain keeps g*a > 0, and the side
        condition `domain -> a != 0` must be proved (after the roots' statements, whose pins a
        may read)."""
        pins, known = [], []
        for a, g, moving, call in signs:
            shown = self.shown(a)
            positive = (a > 0) if moving else (a >= 0)
            prefix.append(choice((f"{call}: {positive}", seq(assign(g, 1), test(positive))),
                                 (f"{call}: {shown} < 0", seq(assign(g, -1), test(a < 0)))))
            if moving:
                self.lift_conditions.append((f"the flow keeps `{shown}` != 0 ({call} keeps one sign)",
                                             Implies(And(domain, *known), cmp("!=", a, 0))))
                pins.append(g * a > 0)
            known += [g * a > 0, cmp("==", g * g, 1)] if moving else [cmp("==", g * g, 1)]  # for later signs
        return prefix, And(domain, *pins) if pins else domain

    def _annotations_with_olds(self, notes: list[Tree], env,
                               differential: bool = False) -> tuple[list[Node], dict[str, Node]]:
        """A loop's or an ODE's annotations, and the `old(e)` they use: fresh name -> e."""
        outer, self.olds = self.olds, {}
        try:
            return self._annotations(notes, env, differential), self.olds
        finally:
            self.olds = outer

    def _annotations(self, notes: list[Tree], env, differential: bool = False) -> list[Node]:
        out: list[Node] = []
        for note in notes:
            kind, *formulas = note.children
            if str(kind) != "@invariant":
                continue  # @variant: for diamond proofs, which do not use it
            for f in formulas:
                out.append(self._bool(f, env))
                if differential and not _comparisons_only(out[-1]):
                    raise self.fail(f, "a differential invariant must be a conjunction of comparisons "
                                    "(optionally guarded, `C -> a`); `abs`, `min`, `max`, `|` and `!` "
                                    "split it into cases: write `abs(e) <= c` as `-c <= e & e <= c`, "
                                    "or give each case its own invariant")
        return out


def _comparisons_only(f: Node) -> bool:
    """What the ODE rules take as a differential invariant: comparisons, joined by `&`, each
    possibly under a guard `C -> ...`."""
    if f.op in ("and", "true"):
        return all(_comparisons_only(a) for a in f.args)
    if f.op == "implies":
        return _comparisons_only(f.args[1])
    return f.op == "cmp"


def _as_written(build, op: str, parts: list[Node]) -> Node:
    """build(*parts), unless a constant decides it (`P | true`, `P & false`, `P -> true`) and
    a part it drops divides: then the connective as written, so that the division is still
    checked defined where it is evaluated (wd.py reads the parts left to right: in
    `y/y = 1 | true` y/y is evaluated, in `true | y/y = 1` it is not)."""
    built = build(*parts)
    if built.op in ("true", "false") and any(p.op not in ("true", "false") and divides(p) for p in parts):
        return Node(op, tuple(parts), BOOL)
    return built


def _last_statement(p: Program) -> Program:
    while isinstance(p, Seq) and p.parts:
        p = p.parts[-1]
    return p


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




def _binds(f: Node) -> set[str]:
    """Symbols bound somewhere inside f: its quantifiers' variables, what the programs in its
    modalities write, and what the formulas inside those programs bind."""
    out: set[str] = set()
    if f.op in ("forall", "exists"):
        out |= {v.payload for v in f.payload}
    if f.op in ("box", "diamond"):
        out |= set(written(f.payload)) | _program_binds(f.payload)
    for a in f.args:
        out |= _binds(a)
    return out


def _program_binds(p: Program) -> set[str]:
    formulas = {Test: lambda q: [q.cond], ODE: lambda q: [q.domain, *q.invariants],
                Loop: lambda q: [q.invariant] if q.invariant is not None else []}
    out: set[str] = set()
    for f in formulas.get(type(p), lambda q: [])(p):
        out |= _binds(f)
    for q in children(p):
        out |= _program_binds(q)
    return out
