"""Our own SMT-LIB 2.6 printer (not z3's `to_smt2()`): a standalone script per obligation.

`script(formula)` asserts the NEGATION of `formula`, so a solver's `unsat` means the
obligation is valid. The text is strictly typed SMT-LIB 2.6, accepted by cvc5 (also with
`strict-parsing`) and z3:

* Symbols. In SMT-LIB `|true|` and `true` are the *same* symbol, so quoting alone cannot
  stop a model symbol named `true`, `and`, `select`, `pi`, `exp` ... from clashing with a
  theory symbol (both solvers reject such declarations). Every certiloop symbol `x` is
  therefore printed as `|v:x|` and every index sort `B` as `|s:B|`; the prefix makes the
  mapping injective and clash-free, and `original_name` undoes it. Names may contain
  anything a quoted symbol can (`x@1`, `F[i@3]`, `a b`) but not `|` or `\\` (ValueError).
* Numbers. Integer-sorted terms meeting real ones get `to_real`; constants print as `3` in
  Int context and `3.0` in Real context, rationals as `(/ 3.0 4.0)`, negatives as
  `(- 3.0)`. Node division is real division: Int operands get `to_real`.
* `t^n` is repeated multiplication (`1` for n = 0); a compound base is `let`-bound.
* Arrays: SMT-LIB arrays have one index, so a model array over I1×I2 -> R is printed curried,
  `(Array I1 (Array I2 R))` (isomorphic under extensionality); reads and writes follow.
* Logic: the narrowest name of the form [QF_][A][UF][L|N][IA|RA|IRA] that covers the
  script (QF_NRA, NRA, QF_UFNRA, AUFNIRA, ...), `QF_UF`/`UF` without arithmetic, `ALL` for
  arrays without arithmetic.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from fractions import Fraction

from certiloop.models.lang.terms import BOOL, INT, QUANTIFIERS, REAL, Node, Sort

VAR_PREFIX = "v:"
SORT_PREFIX = "s:"
_LET_PREFIX = "l:"  # let-bound names: cannot clash with v:/s: symbols

_MANGLED = re.compile(r"\|([vs]):([^|\\]*)\|")


def _check_name(name: str, what: str) -> str:
    if not isinstance(name, str) or not name:
        raise ValueError(f"SMT-LIB: {what} needs a non-empty name, got {name!r}")
    bad = [c for c in name if c in "|\\" or ord(c) < 32 or ord(c) == 127]
    if bad:
        raise ValueError(
            f"SMT-LIB: the {what} name {name!r} contains {bad[0]!r}, which cannot appear in an "
            "SMT-LIB quoted symbol (|...| excludes '|' and '\\' and control characters); "
            "rename the symbol")
    return name


def symbol(name: str) -> str:
    """The SMT-LIB symbol that stands for the certiloop symbol `name`."""
    return f"|{VAR_PREFIX}{_check_name(name, 'symbol')}|"


def sort_symbol(name: str) -> str:
    return f"|{SORT_PREFIX}{_check_name(name, 'sort')}|"


def original_name(smt_symbol: str) -> str:
    """Inverse of `symbol`/`sort_symbol`; accepts the text with or without the bars."""
    s = smt_symbol[1:-1] if smt_symbol.startswith("|") and smt_symbol.endswith("|") else smt_symbol
    for prefix in (VAR_PREFIX, SORT_PREFIX):
        if s.startswith(prefix):
            return s[len(prefix):]
    return s


def readable(text: str) -> str:
    """Solver output with our mangled symbols turned back into certiloop names."""
    return _MANGLED.sub(lambda m: m.group(2), text)


def sort_text(s: Sort) -> str:
    if s == REAL:
        return "Real"
    if s == INT:
        return "Int"
    if s == BOOL:
        return "Bool"
    if s.is_array:
        return f"(Array {sort_text(s.domain[0])} {sort_text(_after(s, 1))})"
    return sort_symbol(s.name)


def _after(s: Sort, k: int) -> Sort:
    """The sort left after reading k indices of the array sort s."""
    if k >= len(s.domain):
        return s.range  # type: ignore[return-value]
    return Sort("Array", s.domain[k:], s.range)


def int_literal(value: Fraction | int) -> str:
    f = Fraction(value)
    if f.denominator != 1:
        raise ValueError(f"SMT-LIB: {f} is not an integer")
    n = f.numerator
    return f"(- {-n})" if n < 0 else str(n)


def real_literal(value: Fraction | int) -> str:
    f = Fraction(value)
    mag = abs(f)
    text = (f"{mag.numerator}.0" if mag.denominator == 1
            else f"(/ {mag.numerator}.0 {mag.denominator}.0)")
    return f"(- {text})" if f < 0 else text


@dataclass
class _Features:
    quantifiers: bool = False
    arrays: bool = False
    sorts: bool = False
    ints: bool = False
    reals: bool = False
    nonlinear: bool = False


@dataclass
class Printed:
    """A script and what it is made of."""

    text: str
    logic: str
    symbols: dict[str, Sort] = field(default_factory=dict)  # free symbols, certiloop names
    sorts: list[str] = field(default_factory=list)  # index sorts, certiloop names


def _ground(n: Node) -> bool:
    return n.op == "const" or (n.op in ("+", "*", "neg", "/", "^") and all(_ground(a) for a in n.args))


class _Printer:
    def __init__(self) -> None:
        self.f = _Features()
        self.free: dict[str, Sort] = {}
        self.index_sorts: dict[str, None] = {}
        self.lets = 0

    # ---- sorts and symbols
    def use_sort(self, s: Sort) -> None:
        if s == REAL:
            self.f.reals = True
        elif s == INT:
            self.f.ints = True
        elif s == BOOL:
            pass
        elif s.is_array:
            self.f.arrays = True
            for d in s.domain:
                self.use_sort(d)
            self.use_sort(s.range)  # type: ignore[arg-type]
        else:
            sort_symbol(s.name)
            self.f.sorts = True
            self.index_sorts.setdefault(s.name, None)

    def var(self, n: Node, bound: dict[str, Sort]) -> str:
        name = n.payload
        if name not in bound:
            have = self.free.get(name)
            if have is None:
                self.use_sort(n.sort)
                self.free[name] = n.sort
            elif have != n.sort:
                raise ValueError(f"SMT-LIB: the symbol {name!r} is used with two sorts, {have} and {n.sort}")
        return symbol(name)

    # ---- terms of a wanted sort
    def term(self, n: Node, want: Sort, bound: dict[str, Sort]) -> str:
        if want == BOOL:
            if n.sort != BOOL:
                raise ValueError(f"SMT-LIB: `{n}` of sort {n.sort} where a formula is expected")
            return self.fml(n, bound)
        if want in (REAL, INT):
            return self.num(n, want, bound)
        if n.sort != want:
            raise ValueError(f"SMT-LIB: `{n}` has sort {n.sort}, expected {want}")
        return self.plain(n, bound)

    def plain(self, n: Node, bound: dict[str, Sort]) -> str:
        """A term of an index or array sort (or any sort, printed in its own sort)."""
        if n.op == "var":
            return self.var(n, bound)
        if n.op == "select":
            return self.select(n, bound)
        if n.op == "store":
            return self.store(n, bound)
        if n.sort in (REAL, INT):
            return self.num(n, n.sort, bound)
        if n.sort == BOOL:
            return self.fml(n, bound)
        raise ValueError(f"SMT-LIB: cannot print `{n}` (op {n.op}) of sort {n.sort}")

    def select(self, n: Node, bound: dict[str, Sort]) -> str:
        base, *indices = n.args
        srt = base.sort
        if not srt.is_array or len(indices) > len(srt.domain):
            raise ValueError(f"SMT-LIB: bad array read `{n}`")
        text = self.plain(base, bound)
        for k, idx in enumerate(indices):
            text = f"(select {text} {self.term(idx, srt.domain[k], bound)})"
        return text

    def store(self, n: Node, bound: dict[str, Sort]) -> str:
        base, *indices, value = n.args
        srt = base.sort
        if not srt.is_array or not indices or len(indices) > len(srt.domain):
            raise ValueError(f"SMT-LIB: bad array write `{n}`")
        return self._store(self.plain(base, bound), srt, indices, value, 0, bound)

    def _store(self, base: str, srt: Sort, indices: list[Node], value: Node, k: int,
               bound: dict[str, Sort]) -> str:
        idx = self.term(indices[k], srt.domain[k], bound)
        if k == len(indices) - 1:
            return f"(store {base} {idx} {self.term(value, _after(srt, k + 1), bound)})"
        # a[i][j] := v on a curried array: a[i] := (a[i])[j] := v, sharing `a` through a let
        name = self._fresh()
        inner = self._store(f"(select {name} {idx})", srt, indices, value, k + 1, bound)
        return f"(let (({name} {base})) (store {name} {idx} {inner}))"

    def _fresh(self) -> str:
        self.lets += 1
        return f"|{_LET_PREFIX}{self.lets}|"

    # ---- arithmetic
    def num(self, n: Node, want: Sort, bound: dict[str, Sort]) -> str:
        if n.sort == INT and want == REAL:
            if n.op == "const":
                self.f.reals = True
                return real_literal(n.payload)
            self.f.reals = True
            return f"(to_real {self.num(n, INT, bound)})"
        if n.sort == REAL and want == INT:
            if n.op == "const" and n.payload.denominator == 1:
                self.f.ints = True
                return int_literal(n.payload)
            raise ValueError(f"SMT-LIB: the real term `{n}` is used where an integer is expected")
        if n.sort not in (REAL, INT):
            raise ValueError(f"SMT-LIB: `{n}` of sort {n.sort} used in arithmetic")
        self.use_sort(want)
        op, args = n.op, n.args
        if op == "const":
            return int_literal(n.payload) if want == INT else real_literal(n.payload)
        if op == "var":
            return self.var(n, bound)
        if op == "select":
            return self.select(n, bound)
        if op == "+":
            if not args:
                return self.num(Node("const", (), INT, Fraction(0)), want, bound)
            parts = [self.num(a, want, bound) for a in args]
            return parts[0] if len(parts) == 1 else f"(+ {' '.join(parts)})"
        if op == "*":
            if not args:
                return self.num(Node("const", (), INT, Fraction(1)), want, bound)
            if sum(not _ground(a) for a in args) > 1:
                self.f.nonlinear = True
            parts = [self.num(a, want, bound) for a in args]
            return parts[0] if len(parts) == 1 else f"(* {' '.join(parts)})"
        if op == "neg":
            return f"(- {self.num(args[0], want, bound)})"
        if op == "/":
            if want != REAL:
                raise ValueError(f"SMT-LIB: the division `{n}` is used where an integer is expected")
            if not _ground(args[1]):
                self.f.nonlinear = True
            return f"(/ {self.num(args[0], REAL, bound)} {self.num(args[1], REAL, bound)})"
        if op == "^":
            k = n.payload
            if k == 0:
                return self.num(Node("const", (), INT, Fraction(1)), want, bound)
            base = self.num(args[0], want, bound)
            if k == 1:
                return base
            if not _ground(args[0]):
                self.f.nonlinear = True
            if args[0].op in ("var", "const"):
                return f"(* {' '.join([base] * k)})"
            name = self._fresh()
            return f"(let (({name} {base})) (* {' '.join([name] * k)}))"
        raise ValueError(f"SMT-LIB: cannot print the term `{n}` (op {op})")

    # ---- formulas
    def fml(self, n: Node, bound: dict[str, Sort]) -> str:
        op, args = n.op, n.args
        if op == "true":
            return "true"
        if op == "false":
            return "false"
        if op == "var":
            return self.var(n, bound)
        if op == "select":
            return self.select(n, bound)
        if op == "cmp":
            a, b = args
            if a.sort.is_numeric and b.sort.is_numeric:
                want = INT if a.sort == INT and b.sort == INT else REAL
            elif a.sort == b.sort:
                want = a.sort
            else:
                raise ValueError(f"SMT-LIB: cannot compare `{a}` ({a.sort}) with `{b}` ({b.sort})")
            ta, tb = self.term(a, want, bound), self.term(b, want, bound)
            rel = n.payload
            if rel == "==":
                return f"(= {ta} {tb})"
            if rel == "!=":
                return f"(not (= {ta} {tb}))"
            if rel in ("<", "<=", ">", ">="):
                if not want.is_numeric:
                    raise ValueError(f"SMT-LIB: ordering comparison on sort {want} in `{n}`")
                return f"({rel} {ta} {tb})"
            raise ValueError(f"SMT-LIB: unknown comparison {rel!r}")
        if op in ("and", "or"):
            if not args:
                return "true" if op == "and" else "false"
            parts = [self.fml(a, bound) for a in args]
            return parts[0] if len(parts) == 1 else f"({op} {' '.join(parts)})"
        if op == "not":
            return f"(not {self.fml(args[0], bound)})"
        if op == "implies":
            return f"(=> {self.fml(args[0], bound)} {self.fml(args[1], bound)})"
        if op == "iff":
            return f"(= {self.fml(args[0], bound)} {self.fml(args[1], bound)})"
        if op in QUANTIFIERS:
            variables = n.payload
            if not variables:
                return self.fml(args[0], bound)
            self.f.quantifiers = True
            inner = dict(bound)
            decls = []
            for v in variables:
                if v.sort.is_array:
                    raise ValueError(f"SMT-LIB: quantified array symbol `{v}`")
                self.use_sort(v.sort)
                inner[v.payload] = v.sort
                decls.append(f"({symbol(v.payload)} {sort_text(v.sort)})")
            return f"({op} ({' '.join(decls)}) {self.fml(args[0], inner)})"
        if op in ("box", "diamond"):
            raise ValueError(f"SMT-LIB: cannot print the modal formula `{n}`; expand it first")
        raise ValueError(f"SMT-LIB: cannot print the formula `{n}` (op {op})")

    # ---- logic
    def logic(self) -> str:
        f = self.f
        qf = "" if f.quantifiers else "QF_"
        arith = ""
        if f.ints or f.reals:
            kind = "IRA" if f.ints and f.reals else "IA" if f.ints else "RA"
            arith = ("N" if f.nonlinear else "L") + kind
        if f.arrays and not arith:
            return "ALL"  # QF_AX has no UF part; an unusual mix, let the solver take it all
        if not arith:
            return qf + "UF"
        return qf + ("A" if f.arrays else "") + ("UF" if f.sorts else "") + arith


def _comment(text: str) -> str:
    return "".join(f"; {line}\n" for line in text.splitlines()) if text else ""


def printed(formula: Node, comment: str = "") -> Printed:
    """The script for `formula` together with its logic and declared symbols."""
    if formula.sort != BOOL:
        raise ValueError(f"SMT-LIB: `{formula}` is a term of sort {formula.sort}, not a formula")
    p = _Printer()
    body = p.fml(formula, {})
    lines = [_comment(comment) + "; unsat means the formula is valid (its negation is asserted)",
             "(set-info :smt-lib-version 2.6)",
             f"(set-logic {p.logic()})"]
    lines += [f"(declare-sort {sort_symbol(s)} 0)" for s in p.index_sorts]
    lines += [f"(declare-const {symbol(name)} {sort_text(s)})" for name, s in p.free.items()]
    lines += [f"(assert (not {body}))", "(check-sat)"]
    return Printed("\n".join(lines) + "\n", p.logic(), dict(p.free), list(p.index_sorts))


def script(formula: Node, comment: str = "") -> str:
    """A standalone SMT-LIB 2.6 script asserting the negation of `formula`; `unsat` proves it."""
    return printed(formula, comment).text
