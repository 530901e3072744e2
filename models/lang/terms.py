"""Terms and formulas: one immutable node type, built with Python operators.

A `Node` is a term (sort Real, Int, an index sort, an array sort) or a formula (sort Bool).
Nodes are compared structurally through `key`; `==` on two nodes builds the *formula*
`a = b`, so never put nodes in sets or use them as dict keys directly: use `node.key`.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cached_property
from typing import Any, Iterable

from certiloop.models.lang.printing import show

MAX_EXPONENT = 10_000  # the largest natural exponent of a power in a model


class ModelError(ValueError):
    """A model is ill-formed; the message names the place and the fix. Raised when a term,
    program or `Theorem` is built, so a bad model fails where it is written."""


# --------------------------------------------------------------------------- sorts


@dataclass(frozen=True, eq=False)
class Sort:
    name: str
    domain: tuple["Sort", ...] = ()  # array sorts: index sorts
    range: "Sort | None" = None  # array sorts: element sort

    # by value, but the usual case (REAL against REAL) first: sorts are compared at every
    # node the prover translates, where dataclass equality's field tuples cost a tenth of the translation
    def __eq__(self, other: object) -> bool:
        if self is other:
            return True
        if not isinstance(other, Sort):
            return NotImplemented
        return self.name == other.name and self.domain == other.domain and self.range == other.range

    def __hash__(self) -> int:
        return hash((self.name, self.domain, self.range))

    @property
    def is_array(self) -> bool:
        return self.range is not None

    @property
    def is_numeric(self) -> bool:
        return self.name in ("Real", "Int")

    def __str__(self) -> str:
        return self.text

    def __getstate__(self) -> dict:
        """A copy of the fields and the cached `text` (see Node.__getstate__)."""
        return self.__dict__.copy()

    @cached_property
    def text(self) -> str:
        """The sort as printed (and in every node's key): computed once per sort."""
        if self.is_array:
            return f"{'×'.join(map(str, self.domain))}→{self.range}"
        return self.name


REAL = Sort("Real")  # real numbers: the default sort of a symbol
INT = Sort("Int")  # integers: loop counters, array indices
BOOL = Sort("Bool")  # truth values: formulas, and Bool symbols and families such as done(i)


def IndexSort(name: str) -> Sort:
    """An uninterpreted finite sort whose elements index a family (e.g. boundaries): the
    proof holds for every finite size. `B = IndexSort("B")`, then `Family("nx", B)`."""
    if name in ("Real", "Int", "Bool"):
        raise ModelError(f"index sort name {name!r} clashes with a built-in sort")
    return Sort(name)


def ArraySort(domain: Sort | tuple[Sort, ...], range: Sort) -> Sort:
    domain = domain if isinstance(domain, tuple) else (domain,)
    return Sort("Array", domain, range)


QUANTIFIERS = ("forall", "exists")
MODALITIES = ("box", "diamond")


def _as_fraction(value: Any) -> Fraction:
    if isinstance(value, bool):
        raise ModelError("a Python bool is not a number here; use true/false formulas")
    if isinstance(value, float):
        if value != value or value in (float("inf"), float("-inf")):
            raise ModelError(f"{value} is not a real number; a model's constants must be finite")
        # Floats are exact binary fractions; users who write 0.1 almost always mean 1/10.
        return Fraction(str(value))
    return Fraction(value)


# --------------------------------------------------------------------------- nodes


@dataclass(frozen=True, eq=False)
class Node:
    """A term or formula. Build them with Python operators, never by hand:

    `x + y`, `x - y`, `2 * x`, `x / y` (real division), `-x`, `x**2` (natural exponents)
    give terms; `x <= y`, `x < y`, `x == y`, `x != y` give formulas (so `==` never tests
    Python equality: compare with `.same()` or `.key`); on formulas `p & q`, `p | q`, `~p`
    and `p >> q` (implication) are `And`, `Or`, `Not` and `Implies`; `a[i]`, `a[i][j]` and
    `nx(i)` read arrays and families. Formulas have no Python truth value, so a chained
    `0 <= x <= D` is an error: write `And(0 <= x, x <= D)`.

    op: 'const' | 'var' | 'select' | 'store' | arithmetic | 'cmp' | connective | ...
    payload: the value (const), name (var), comparison operator (cmp), exponent (^),
    bound variables (quantifiers) or the program (modalities).
    """

    op: str
    args: tuple["Node", ...]
    sort: Sort
    payload: Any = None

    # ---- identity
    def __getstate__(self) -> dict:
        """A copy of the fields and caches: a process pool pickles a submitted theorem on its
        feeder thread while this thread may fill a cache (_key, _free); pickling the live
        __dict__ then failed ("dictionary changed size during iteration", seen with both cores
        busy). The copy is one step under the GIL; the caches travel, so workers need not
        recompute them."""
        return self.__dict__.copy()

    @property
    def key(self) -> tuple:
        cached = self.__dict__.get("_key")
        if cached is None:
            pay = self.payload
            if self.op in QUANTIFIERS:
                pay = tuple(v.key for v in pay)
            elif self.op in MODALITIES:
                pay = pay.key
            cached = (self.op, self.sort.text, pay, tuple([a.key for a in self.args]))
            object.__setattr__(self, "_key", cached)
        return cached

    def __hash__(self) -> int:
        return hash(self.key)

    def same(self, other: "Node") -> bool:
        return self.key == other.key

    def __bool__(self) -> bool:
        if self.sort == BOOL:
            raise ModelError(
                f"the formula `{self}` has no Python truth value; chained comparisons such as "
                "`0 <= x <= D` silently drop a part: write `And(0 <= x, x <= D)` instead"
            )
        raise ModelError(f"the term `{self}` has no Python truth value")

    def _not_a_number(self, *_args) -> Any:
        """float(x), int(x), math.sin(x), round(x), abs(x): a symbolic term is no number."""
        raise ModelError(
            f"`{self}` is a symbolic term, not a number: Python's math functions (math.sin, math.exp, "
            "math.sqrt, float, int, round, abs) cannot take it, and transcendental functions are not "
            "supported in models; use +, -, *, / and ** with a natural exponent (abs(e) <= c is "
            "And(-c <= e, e <= c); min and max are assign_min or a choice)")

    __float__ = __int__ = __index__ = __complex__ = _not_a_number
    __round__ = __trunc__ = __floor__ = __ceil__ = __abs__ = _not_a_number

    def _no_operator(self, *_args) -> Any:
        """x % 2, x // 2, 2 ** x, x @ y: operators the models' arithmetic does not have."""
        raise ModelError(
            f"`{self}` is a model term: %, //, divmod, @ and a symbolic exponent (2 ** x) are not "
            "part of the models' arithmetic; use +, -, *, / (real division) and ** with a natural "
            "number literal as the exponent")

    __mod__ = __rmod__ = __floordiv__ = __rfloordiv__ = __divmod__ = __rdivmod__ = _no_operator
    __matmul__ = __rmatmul__ = __rpow__ = _no_operator

    def __str__(self) -> str:
        return show(self)

    __repr__ = __str__

    def _repr_latex_(self) -> str:
        """Notebook display: the term or formula as LaTeX math."""
        from certiloop.models.lang import notation  # display only: not in the checker's base
        return f"${notation.term(self)}$"

    @property
    def name(self) -> str:
        if self.op != "var":
            raise ModelError(f"`{self}` is not a symbol")
        return self.payload

    # ---- arithmetic
    def _num(self) -> "Node":
        if not self.sort.is_numeric:
            raise ModelError(f"`{self}` of sort {self.sort} used in arithmetic")
        return self

    def __add__(self, o):
        return add(self, o)

    def __radd__(self, o):
        return add(o, self)

    def __sub__(self, o):
        return add(self, neg(o))

    def __rsub__(self, o):
        return add(o, neg(self))

    def __mul__(self, o):
        return mul(self, o)

    def __rmul__(self, o):
        return mul(o, self)

    def __truediv__(self, o):
        return div(self, o)

    def __rtruediv__(self, o):
        return div(o, self)

    def __neg__(self):
        return neg(self)

    def __pos__(self):
        return self

    def __pow__(self, n):
        if not isinstance(n, int) or isinstance(n, bool) or n < 0:
            raise ModelError(f"exponent of `{self}` must be a natural number literal, got {n!r}")
        if n > MAX_EXPONENT:  # x^(10^11) is no model, and expanding it takes hours
            raise ModelError(f"exponent {n:,} of `{self}` is larger than the {MAX_EXPONENT:,} supported; "
                             "write the model with smaller powers")
        return Node("^", (term(self)._num(),), _arith_sort((self,)), n)

    # ---- comparisons build formulas
    def __lt__(self, o):
        return cmp("<", self, o)

    def __le__(self, o):
        return cmp("<=", self, o)

    def __gt__(self, o):
        return cmp(">", self, o)

    def __ge__(self, o):
        return cmp(">=", self, o)

    def __eq__(self, o):  # type: ignore[override]
        return cmp("==", self, o)

    def __ne__(self, o):  # type: ignore[override]
        return cmp("!=", self, o)

    # ---- connectives on formulas
    def __and__(self, o):
        return And(self, o)

    def __rand__(self, o):
        return And(o, self)

    def __or__(self, o):
        return Or(self, o)

    def __ror__(self, o):
        return Or(o, self)

    def __invert__(self):
        return Not(self)

    def __rshift__(self, o):
        return Implies(self, o)

    # ---- arrays and families: a[i], a[i][j], a(i)
    def __getitem__(self, index):
        indices = index if isinstance(index, tuple) else (index,)
        return select(self, *indices)

    def __call__(self, *indices):
        return select(self, *indices)


# --------------------------------------------------------------------------- constructors


def const(value: Any) -> Node:
    f = _as_fraction(value)
    return Node("const", (), INT if f.denominator == 1 and isinstance(value, int) else REAL, f)


def term(x: Any) -> Node:
    """Lift Python numbers to constant nodes."""
    if isinstance(x, Node):
        return x
    if isinstance(x, (int, float, Fraction)) and not isinstance(x, bool):
        return const(x)
    raise ModelError(f"cannot use {x!r} ({type(x).__name__}) in a model term")


def Var(name: str, sort: Sort = REAL) -> Node:
    """A symbol of any sort: `Var("i", B)` for an element of the index sort `B`."""
    if not isinstance(name, str) or not name:
        raise ModelError(f"a symbol needs a non-empty name, got {name!r}")
    return Node("var", (), sort, name)


def Real(name: str) -> Node:
    """A real symbol: `v = Real("v")`."""
    return Var(name, REAL)


def Int(name: str) -> Node:
    """An integer symbol (loop counters, array indices): `k = Int("k")`."""
    return Var(name, INT)


def Bool(name: str) -> Node:
    """A Boolean symbol, usable as a formula: `braking = Bool("braking")`."""
    return Var(name, BOOL)


def Reals(names: str) -> list[Node]:
    """Several real symbols from space-separated names: `p, v, a = Reals("p v a")`."""
    return [Real(n) for n in names.split()]


def Ints(names: str) -> list[Node]:
    """Several integer symbols from space-separated names: `i, j = Ints("i j")`."""
    return [Int(n) for n in names.split()]


def Array(name: str, domain: Sort | tuple[Sort, ...], range: Sort = REAL) -> Node:
    """An array symbol over integer (or index-sort) indices; `a[i][j]` reads it,
    `assign(a[i][j], e)` writes it: `P = Array("P", (INT, INT, INT))`."""
    return Var(name, ArraySort(domain, range))


def Family(name: str, index: Sort, range: Sort = REAL) -> Node:
    """A function over an index sort, e.g. a boundary normal component `nx(i)`:
    `nx = Family("nx", B)`; `Family("done", B, BOOL)` marks elements."""
    return Var(name, ArraySort(index, range))


def _arith_sort(args: Iterable[Node]) -> Sort:
    return INT if all(a.sort == INT for a in args) else REAL


def add(*xs: Any) -> Node:
    args: list[Node] = []
    for x in map(term, xs):
        x._num()
        args.extend(x.args if x.op == "+" else (x,))
    return Node("+", tuple(args), _arith_sort(args))


def mul(*xs: Any) -> Node:
    args: list[Node] = []
    for x in map(term, xs):
        x._num()
        args.extend(x.args if x.op == "*" else (x,))
    return Node("*", tuple(args), _arith_sort(args))


def neg(x: Any) -> Node:
    x = term(x)._num()
    if x.op == "const":
        return Node("const", (), x.sort, -x.payload)
    return Node("neg", (x,), x.sort)


def div(a: Any, b: Any) -> Node:
    a, b = term(a)._num(), term(b)._num()
    if b.op == "const" and b.payload == 0:
        raise ModelError(f"division of `{a}` by the constant 0")
    return Node("/", (a, b), REAL)


def select(array: Node, *indices: Any) -> Node:
    """Read array (or family) `array` at `indices`; a[i][j] reads a 2-D array step by step."""
    if array.op == "select" and len(array.args) - 1 < len(_root(array).sort.domain):
        base, done = array.args[0], array.args[1:]
        return select(base, *done, *indices)
    srt = array.sort
    if not srt.is_array:
        raise ModelError(f"`{array}` is not an array or family, so it cannot be indexed")
    idx = tuple(term(i) for i in indices)
    if len(idx) > len(srt.domain):
        raise ModelError(f"`{array}` takes {len(srt.domain)} index(es), got {len(idx)}")
    for want, got in zip(srt.domain, idx):
        if got.sort != want and not (want == INT and got.sort == INT):
            raise ModelError(f"index `{got}` of `{array}` has sort {got.sort}, expected {want}")
    if len(idx) < len(srt.domain):
        # a partial read such as P[k][i]; completed by the next [ ]
        return Node("select", (array, *idx), ArraySort(srt.domain[len(idx):], srt.range))
    return Node("select", (array, *idx), srt.range)


def _root(n: Node) -> Node:
    while n.op == "select":
        n = n.args[0]
    return n


def store(array: Node, indices: tuple[Node, ...], value: Node) -> Node:
    return Node("store", (array, *indices, value), array.sort)


def cmp(op: str, a: Any, b: Any) -> Node:
    a, b = term(a), term(b)
    if op in ("==", "!="):
        if (a.sort.is_numeric and b.sort.is_numeric) or a.sort == b.sort:
            return Node("cmp", (a, b), BOOL, op)
        raise ModelError(f"cannot compare `{a}` ({a.sort}) with `{b}` ({b.sort})")
    a._num(), b._num()
    return Node("cmp", (a, b), BOOL, op)


TRUE = Node("true", (), BOOL)  # the formula true (also: an ODE's default domain)
FALSE = Node("false", (), BOOL)  # the formula false


def formula(x: Any) -> Node:
    if isinstance(x, bool):
        return TRUE if x else FALSE
    if not isinstance(x, Node) or x.sort != BOOL:
        raise ModelError(f"expected a formula, got `{x}`")
    return x


def And(*xs: Any) -> Node:
    """Conjunction of any number of formulas (`And()` is true): `And(x >= 0, x <= D)`."""
    args: list[Node] = []
    for x in map(formula, xs):
        if x.op == "false":
            return FALSE
        if x.op != "true":
            args.extend(x.args if x.op == "and" else (x,))
    if not args:
        return TRUE
    return args[0] if len(args) == 1 else Node("and", tuple(args), BOOL)


def Or(*xs: Any) -> Node:
    """Disjunction of any number of formulas (`Or()` is false): `Or(v == 0, a < 0)`."""
    args: list[Node] = []
    for x in map(formula, xs):
        if x.op == "true":
            return TRUE
        if x.op != "false":
            args.extend(x.args if x.op == "or" else (x,))
    if not args:
        return FALSE
    return args[0] if len(args) == 1 else Node("or", tuple(args), BOOL)


def Not(x: Any) -> Node:
    """Negation of a formula; `~f` is the same: `Not(x > D)`."""
    x = formula(x)
    if x.op == "true":
        return FALSE
    if x.op == "false":
        return TRUE
    return Node("not", (x,), BOOL)


def Implies(a: Any, b: Any) -> Node:
    """Implication `a -> b`; `a >> b` is the same: `Implies(done(j), safe(j))`."""
    a, b = formula(a), formula(b)
    if a.op == "true" or b.op == "true":
        return b
    if a.op == "false":
        return TRUE
    return Node("implies", (a, b), BOOL)


def Iff(a: Any, b: Any) -> Node:
    """Equivalence `a <-> b`: `Iff(braking, v > vmax)`."""
    return Node("iff", (formula(a), formula(b)), BOOL)


def _binder(op: str, variables: Node | Iterable[Node], body: Any) -> Node:
    vs = (variables,) if isinstance(variables, Node) else tuple(variables)
    for v in vs:
        if v.op != "var" or v.sort.is_array:
            raise ModelError(f"can only quantify over a plain symbol, not `{v}`")
    return Node(op, (formula(body),), BOOL, vs)


def ForAll(variables: Node | Iterable[Node], body: Any) -> Node:
    """Universal quantifier over one symbol or a list of them (reals, integers or an index
    sort): `ForAll(j, d0(j) >= 0)` for every boundary j."""
    return _binder("forall", variables, body)


def Exists(variables: Node | Iterable[Node], body: Any) -> Node:
    """Existential quantifier, as `ForAll`: `Exists(t, And(t >= 0, p + v * t == m))`."""
    return _binder("exists", variables, body)


def Box(program: Any, post: Any) -> Node:
    """`[program] post`: post holds after every run of program (a formula, so it can sit in
    assumptions or guarantees): `Box(ode({x: v}), x >= x0)`."""
    return Node("box", (formula(post),), BOOL, program)


def Diamond(program: Any, post: Any) -> Node:
    """`<program> post`: some run of program ends where post holds:
    `Diamond(ode({x: 1}), x >= 10)`."""
    return Node("diamond", (formula(post),), BOOL, program)


# --------------------------------------------------------------------------- traversal


def free_vars(n: Node, bound: frozenset[str] = frozenset()) -> dict[str, Node]:
    """Free symbols of a term/formula (box/diamond included), by name, in the order they first
    occur. A node's are kept on it, and a walk takes those of any subterm asked before (the
    weakenings ask for the atoms' and then the whole formula's; obligations share hypotheses)."""
    if bound:
        return _free_vars(n, bound)
    cached = n.__dict__.get("_free")
    if cached is None:
        cached = _free_vars(n, bound)
        object.__setattr__(n, "_free", cached)
    return dict(cached)  # a copy: callers may add to it


def _free_vars(n: Node, bound: frozenset[str]) -> dict[str, Node]:
    out: dict[str, Node] = {}

    def walk(x: Node, b: frozenset[str]) -> None:
        known = x.__dict__.get("_free")
        if known is not None:
            for name, v in known.items():
                if name not in b:
                    out.setdefault(name, v)
            return
        if x.op == "var":
            if x.payload not in b:
                out.setdefault(x.payload, x)
            return
        if x.op in QUANTIFIERS:
            b = b | {v.payload for v in x.payload}
        if x.op in MODALITIES:
            for name, v in x.payload.symbols().items():
                if name not in b:
                    out.setdefault(name, v)
        for a in x.args:
            walk(a, b)

    walk(n, bound)
    return out


def substitute(n: Node, env: dict[str, Node]) -> Node:
    """Replace free symbols by terms. Bound variables are renamed apart to avoid capture."""
    if not env:
        return n
    if n.op == "var":
        return env.get(n.payload, n)
    if n.op in ("const", "true", "false"):
        return n
    if n.op in QUANTIFIERS:
        inner = dict(env)
        new_vars = []
        used = {nm for t in env.values() for nm in free_vars(t)}
        for v in n.payload:
            inner.pop(v.payload, None)
            if v.payload in used:
                fresh = Var(_unused_name(v.payload, used), v.sort)
                inner[v.payload] = fresh
                new_vars.append(fresh)
            else:
                new_vars.append(v)
        return Node(n.op, (substitute(n.args[0], inner),), BOOL, tuple(new_vars))
    if n.op in MODALITIES:
        raise ModelError(f"cannot substitute into the modal formula `{n}`; expand it first")
    return rebuild(n, tuple(substitute(a, env) for a in n.args))


def rebuild(n: Node, args: tuple[Node, ...]) -> Node:
    """Same node with new children, re-running the smart constructors' simplifications.
    Unchanged children give back the node itself: its cached key is reused, not rebuilt."""
    if len(args) == len(n.args) and all(a is b for a, b in zip(args, n.args)):
        return n
    op = n.op
    if op == "+":
        return add(*args)
    if op == "*":
        return mul(*args)
    if op == "neg":
        return neg(args[0])
    if op == "/":
        return Node("/", args, REAL)
    if op == "^":
        return Node("^", args, _arith_sort(args), n.payload)
    if op == "cmp":
        return Node("cmp", args, BOOL, n.payload)
    if op == "and":
        return And(*args)
    if op == "or":
        return Or(*args)
    if op == "not":
        return Not(args[0])
    if op == "implies":
        return Implies(*args)
    if op == "select":
        return Node("select", args, n.sort)
    if op == "store":
        return Node("store", args, n.sort)
    return Node(op, args, n.sort, n.payload)


def _unused_name(base: str, used: set[str]) -> str:
    """A deterministic bound-variable name (user names cannot contain '@')."""
    root, k = base.split("@")[0], 0
    while f"{root}@b{k}" in used:
        k += 1
    return f"{root}@b{k}"
