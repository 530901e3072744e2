"""The C side of float-sound extraction (the scheme and its contract: `certified`; the Python
runtime it mirrors: `certiloop.kernel.filtered`). `RUNTIME` is the header
`certiloop_runtime.h` (static inline helpers, no globals, libm only) that every generated C
file includes and extraction writes beside it, and the functions below give
the C code of terms (values with error bounds, type `cl_real`) and formulas (three-valued:
1 holds, 0 fails, -1 the floats cannot decide).

Two passes, as the Python has a float pass and an exact pass:

* the FILTER (careful = 0), semi-static: on inputs 0 or of magnitude in [2^-48, 2^48], a
  value of a polynomial term (and of one divided by an input) is bounded by k·U·m -- k a count
  of roundings the compiler folds, m the term evaluated on magnitudes, one extra operation per
  operation (proof sketch at `cl_static`); a value merged from a choice's branches is
  widened to one static shape (`cl_widen`); values past a division by a computed value carry
  the running bound of `filtered.add/sub/mul/div`.
  Guards are conjunctions evaluated left to right up to the first that fails (`cl_guard`).
  Its decisions are the reals' (so the Python filter's wherever both decide), its outputs
  floats at most the real values, not necessarily the Python's floats;
* where a decision (or an output's tightness) is not certain, the whole step runs again with
  careful = 1: operations on exact operands use error-free transformations (TwoSum; the fma
  residual of a product or a quotient), so a result that is exactly representable stays
  exact — a tool exactly on a plane (d0 = 0), a force exactly parallel to it (fn = 0 from
  non-zero products), the issue's 2.1e-162 components — and any other result carries its
  exact rounding error as its bound. A value with bound 0 is exact.
* where even the careful pass cannot decide, the function returns -1 (UNDECIDED): no
  decision is taken, the caller falls back as for "no run" (ctrl2's fixture commands k = 0).
  C has no rationals; this is the only place where it differs from the Python kernel, which
  decides such rows exactly. Conformance (tests/kernel/test_extract_c.py): wherever C decides, its
  decision is the reals' (so the Python kernel's); undecided states are counted and checked
  to be near-ties.

sqrt (the roots of a quadratic) has no helper in `filtered`; `cl_sqrt` bounds it by
|√x - √y| <= |x - y| / √min(x, y) (or √|x - y|), documented here only."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

from certiloop.kernel.extract import certified
from certiloop.kernel.extract.errors import refuse
from certiloop.models.lang.terms import Node

RUNTIME_HEADER = "certiloop_runtime.h"  # shipped beside this module, written beside every kernel
RUNTIME = (Path(__file__).parent / RUNTIME_HEADER).read_text()

COMPARE = {"<": "cl_lt", "<=": "cl_le", ">": "cl_gt", ">=": "cl_ge", "==": "cl_eq", "!=": "cl_ne"}


def cl_constant(n: Node) -> str:
    """A model constant as a certified value: exact where the double is the rational."""
    value, error = certified.constant(Fraction(n.payload))
    if value in ("inf", "-inf", "nan"):
        raise refuse(n, "a constant outside the double range")
    return f"cl_const({value})" if error is None else f"cl_approx({value}, {error}, careful)"


def cl_op(n: Node, a: list[str]) -> str:
    """C for an operator node, given its arguments' C code: terms as cl_real, formulas
    three-valued; n-ary sums and products left to right, as the Python."""
    op = n.op
    if op == "*":  # a factor of exactly ±1 changes only the sign: no rounding, no bound (as vectorised)
        unit = [x.op == "const" and Fraction(x.payload) in (1, -1) for x in n.args]
        negative = sum(1 for x, u in zip(n.args, unit) if u and Fraction(x.payload) == -1)
        a = [code for code, u in zip(a, unit) if not u] or ["cl_exact(1.0)"]
        if negative % 2:
            a[0] = f"cl_neg({a[0]})"
    if op in ("+", "*"):
        fn = "cl_add" if op == "+" else "cl_mul"
        code = a[0]
        for x in a[1:]:
            code = f"{fn}({code}, {x}, careful)"
        return code
    if op == "neg":
        return f"cl_neg({a[0]})"
    if op == "/":
        return f"cl_div({a[0]}, {a[1]}, careful)"
    if op == "^":
        from certiloop.kernel.extract.template import MAX_POWER

        k = n.payload
        if not (isinstance(k, int) and 1 <= k <= MAX_POWER):
            raise refuse(n, f"only natural powers up to {MAX_POWER} are written in C")
        code = a[0]
        for _ in range(k - 1):
            code = f"cl_mul({code}, {a[0]}, careful)"
        return code
    if op == "cmp":
        return f"{COMPARE[n.payload]}({a[0]}, {a[1]})"
    if op in ("and", "or"):
        if not a:
            return "1" if op == "and" else "0"
        code = a[0]
        for x in a[1:]:
            code = f"cl_{op}({code}, {x})"
        return code
    if op == "not":
        return f"cl_not({a[0]})"
    if op == "implies":
        return f"cl_or(cl_not({a[0]}), {a[1]})"
    if op == "iff":
        return f"cl_iff({a[0]}, {a[1]})"
    raise refuse(n, "not an arithmetic term or a quantifier-free formula")


def cl_all(conds: list[str]) -> str:
    """The conjunction of three-valued conditions."""
    conds = [c for c in conds if c != "1"]
    if not conds:
        return "1"
    code = conds[0]
    for c in conds[1:]:
        code = f"cl_and({code}, {c})"
    return code


def cl_guard(conds: list[str]) -> str:
    """The condition of `if (...)` that sets cl_t to the conjunction of three-valued
    conditions and holds where it is not 0, evaluating them left to right and stopping at the
    first that fails (the terms are pure: skipping them changes nothing but the time; the
    filter's divisions and bounds of later conjuncts are the most costly part of a step)."""
    conds = [c for c in conds if c != "1"]
    if not conds:
        return "(cl_t = 1) != 0"
    steps = [f"(cl_t = {conds[0]}) != 0"] + [f"(cl_t = cl_and(cl_t, {c})) != 0" for c in conds[1:]]
    return " && ".join(steps)
