"""z3 back end: model terms -> z3, one fresh solver per obligation, models -> plain values."""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, Callable

try:
    import z3
except ImportError as exc:  # pragma: no cover - exercised by the CLI's missing-solver test
    raise ImportError("z3 is not installed: pip install z3-solver") from exc

from certiloop.models.lang.terms import BOOL, REAL, Node
from certiloop.proofs.core import isolated
from certiloop.proofs.core.answers import SolverAnswer
from certiloop.proofs.core.instantiate import has_quantifier
from certiloop.proofs.core.interval import Interval
from certiloop.proofs.core.onepoint import eliminate_defined
from certiloop.proofs.core.simplify import simplify
from certiloop.proofs.core.z3terms import Z3Translator


def _quantifier_free(n: Node) -> bool:
    return not has_quantifier(n)


def _no_sorts(n: Node) -> bool:
    """Only numbers and truth values (a model of them is plain values, no z3 handles)."""
    return all(s.sort.is_numeric or s.sort == BOOL for s in _symbols(n))


def _nonlinear(n: Node) -> bool:
    """A product of two terms that are not constants, a power or a division by a variable."""
    def moving(x: Node) -> bool:
        return x.op != "const"

    if n.op == "*" and sum(1 for a in n.args if moving(a)) >= 2:
        return True
    if (n.op == "/" and moving(n.args[1])) or (n.op == "^" and moving(n.args[0]) and n.payload != 1):
        return True
    return any(_nonlinear(a) for a in n.args)


def _pure_real(tr: Z3Translator, n: Node) -> bool:
    return not tr.sorts and all(s.sort == REAL or s.sort == BOOL for s in _symbols(n))


def _symbols(n: Node) -> list[Node]:
    out: list[Node] = []

    def walk(x: Node) -> None:
        if x.op == "var":
            out.append(x)
        for a in x.args:
            walk(a)
        if x.op in ("forall", "exists"):
            out.extend(x.payload)

    walk(n)
    return out


def check_valid(formula: Node, rlimit: int, wall_s: float = 600.0) -> SolverAnswer:
    """Ask z3 whether `formula` is valid by checking its negation in a fresh context.

    `rlimit` (z3 resource units) decides when to give up, so the answer does not depend on
    the machine or its load; `wall_s` is only a safety net against a hung solver, and an
    answer cut off by it says so. Constant comparisons are folded first: z3 can stall on a
    claim that a false assumption such as `2 <= 1` makes trivially valid; quantified symbols
    the formula defines by an equation are replaced by their definitions (onepoint.py). A
    quantified nonlinear check runs in a child with an allocation budget too (isolated.py)."""
    formula = simplify(formula)
    if formula.op == "true":
        return SolverAnswer("unsat")
    if not _quantifier_free(formula):
        formula = eliminate_defined(formula)
    quantified = not _quantifier_free(formula)
    if quantified and isolated.available() and _nonlinear(formula) and _no_sorts(formula):
        return isolated.check_in_child(check_here, formula, rlimit, wall_s, max_allocs(rlimit))
    return check_here(formula, rlimit, wall_s)


# The allocation budget of a check that runs in a child (isolated.py), from its unit budget.
# Calibrated on every quantified nonlinear check of the library's gate and KeYmaera X's
# archives: a finished check allocates about 320,000 times to start and up to 23 times per unit
# (the largest: 5.7 million allocations for 494,695 units), while a stall allocates up to 250
# million times a second without spending units. So twice the worst rate seen, plus the start,
# for at most UNIT_CAP units: no quantified check that finished needed more than 500,000, and a
# run search's sixfold unit budget would only let a stall run longer. (Some stalls allocate
# only 2 million times a second: ACAS X's Theorem 1 before onepoint.py removed its cause.)
ALLOC_BASE = 10_000_000
ALLOCS_PER_UNIT = 50
UNIT_CAP = 2_000_000


def max_allocs(rlimit: int) -> int:
    """z3 allocations a check in a child may make, for a budget of `rlimit` units."""
    return ALLOC_BASE + ALLOCS_PER_UNIT * min(rlimit, UNIT_CAP)


def check_here(formula: Node, rlimit: int, wall_s: float | None) -> SolverAnswer:
    """check_valid's answer, from z3 in this process."""
    tr = Z3Translator()
    try:
        return _check(formula, tr, rlimit, wall_s)
    finally:
        tr.release()


def _check(formula: Node, tr: Z3Translator, rlimit: int, wall_s: float | None) -> SolverAnswer:
    goal = z3.Not(tr(formula))
    if _quantifier_free(formula) and _pure_real(tr, formula):
        solver = z3.SolverFor("QF_NRA", ctx=tr.ctx)
    else:
        solver = z3.Solver(ctx=tr.ctx)
    solver.set("rlimit", max(1, int(rlimit)))
    if wall_s is not None:  # a child (isolated.py) has its net in the parent, and no z3 timer
        solver.set("timeout", max(1, int(wall_s * 1000)))
    solver.add(goal)
    try:
        result = solver.check()
    except z3.Z3Exception as exc:  # z3 crashed on this input
        return SolverAnswer("unknown", f"z3 error: {exc}")
    spent = _spent(solver)
    if result == z3.unsat:
        return SolverAnswer("unsat", spent=spent)
    if result == z3.sat:
        model = solver.model()
        evaluated = model.eval(tr(formula), model_completion=True)
        falsifies = True if z3.is_false(evaluated) else False if z3.is_true(evaluated) else None
        return SolverAnswer("sat", model=read_model(model, tr), model_falsifies=falsifies,
                            spent=spent)
    reason = solver.reason_unknown()
    if "resource limit" in reason or spent >= rlimit:
        reason = f"resource budget spent ({int(rlimit):,} z3 units)"
    elif reason in ("timeout", "canceled"):
        reason = (f"wall-clock safety net reached after {wall_s:g} s (z3 stalled where its resource "
                  "count does not reach, or the machine is overloaded; not a verdict of the budget)")
    else:
        reason = f"z3 gave up: {reason}"
    return SolverAnswer("unknown", reason, spent=spent)


def _spent(solver) -> int:
    stats = solver.statistics()
    for key in stats.keys():
        if key == "rlimit count":
            return int(stats.get_key_value(key))
    return 0


# --------------------------------------------------------------------------- models


def _value(v: z3.ExprRef, model: z3.ModelRef) -> Any:
    if z3.is_true(v):
        return True
    if z3.is_false(v):
        return False
    if z3.is_int_value(v):
        return v.as_long()
    if z3.is_rational_value(v):
        return Fraction(v.numerator_as_long(), v.denominator_as_long())
    if z3.is_algebraic_value(v):
        return algebraic_interval(v)
    if z3.is_array(v) or z3.is_K(v) or z3.is_store(v):
        return _array_value(v, model)
    if v.sort().kind() == z3.Z3_UNINTERPRETED_SORT:
        return str(v)
    return str(v)


def algebraic_interval(v: z3.AlgebraicNumRef, digits: int = 30) -> Interval:
    """A rational interval of width 2·10^-digits that contains the algebraic number."""
    mid = v.approx(digits)
    m = Fraction(mid.numerator_as_long(), mid.denominator_as_long())
    eps = Fraction(1, 10**digits)
    coeffs = tuple(c.as_long() for c in v.poly())
    return Interval(m - eps, m + eps, decimal=v.as_decimal(12).rstrip("?"),
                    poly=coeffs, root_index=v.index())


@dataclass
class ArrayValue:
    """A finite map with a default, as z3 models arrays and families.

    `lookup` (only inside the process that holds the z3 model) answers reads that the
    finite part does not cover, for arrays z3 describes by a lambda term.
    """

    entries: dict[tuple, Any]
    default: Any
    lookup: Callable[[tuple], Any] | None = field(default=None, compare=False, repr=False)

    def get(self, idx: tuple) -> Any:
        if idx in self.entries:
            return self.entries[idx]
        return self.lookup(idx) if self.lookup is not None else self.default

    def __str__(self) -> str:
        parts = [f"{','.join(map(_short, k))}: {_short(v)}" for k, v in self.entries.items()]
        if self.default is not None:
            parts.append(f"else: {_short(self.default)}")
        return "[" + "; ".join(parts) + "]"


def _short(x: Any) -> str:
    from certiloop.proofs.core.interval import show_value

    return show_value(x)


def _array_value(v: z3.ExprRef, model: z3.ModelRef) -> ArrayValue | str:
    entries: dict[tuple, Any] = {}
    while z3.is_store(v):
        arr, *rest = v.children()
        idx, val = rest[:-1], rest[-1]
        key = tuple(_value(i, model) for i in idx)
        entries.setdefault(key, _value(val, model))
        v = arr
    if z3.is_K(v):
        return ArrayValue(entries, _value(v.arg(0), model))
    if z3.is_as_array(v):
        interp = model[z3.get_as_array_func(v)]
        for entry in interp.as_list()[:-1]:
            *idx, val = entry
            entries.setdefault(tuple(_value(i, model) for i in idx), _value(val, model))
        return ArrayValue(entries, _value(interp.else_value(), model))
    base = v

    def lookup(idx: tuple) -> Any:
        args = [_z3_index(x, base.sort().domain_n(k) if base.sort().arity() > 1 else base.sort().domain())
                for k, x in enumerate(idx)]
        return _value(model.eval(z3.Select(base, *args), model_completion=True), model)

    return ArrayValue(entries, None, lookup)


def _z3_index(x: Any, sort: z3.SortRef) -> z3.ExprRef:
    ctx = sort.ctx
    if isinstance(x, bool):
        return z3.BoolVal(x, ctx)
    if isinstance(x, int):
        return z3.IntVal(x, ctx)
    if isinstance(x, Fraction):
        return z3.RealVal(f"{x.numerator}/{x.denominator}", ctx)
    raise ValueError(f"cannot index a z3 array by {x!r}")


def read_model(model: z3.ModelRef, tr: Z3Translator) -> dict[str, Any]:
    """Values by symbol name; `#universe:S` lists the elements of each index sort S (a z3
    model interprets an uninterpreted sort as a finite set, so ∀ over it can be checked)."""
    out: dict[str, Any] = {}
    for name, sort in tr.sorts.items():
        universe = model.get_universe(sort)
        if universe is not None:
            out[f"#universe:{name}"] = [str(e) for e in universe]
    for name, sym in tr.symbols.items():
        val = model.eval(sym, model_completion=True)
        out[name] = _value(val, model)
    return out
