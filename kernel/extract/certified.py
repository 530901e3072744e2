"""Float-sound, float-total decisions: how extracted code turns the model's real-valued
tests into floating-point code that takes exactly the model's decisions (the scheme; the
runtime helpers are `certiloop.kernel.filtered`, numpy and stdlib only).

THE CONTRACT (every back end — Python now, C in `--lang c` — keeps it):

1. Inputs are finite float64 numbers; as rationals they are a state of the real model.
   A non-finite input is outside the model's domain: the code reports no run.
2. Every decision — each comparison `a op b` in a test or case guard (op in <, <=, >, >=, =,
   !=), hence which alternative of a choice is taken first and whether the step has a run
   at all — is the decision the model takes IN THE REALS on those rational inputs. So two
   back ends that keep the contract take bit-for-bit the same decisions, whatever their
   float evaluation order: the decision is a property of the inputs, not of the code.
3. Output values (a gain k) are floats on the safe side of the model's real value: for a
   real output, the value returned is <= the real value the model computes (rounded toward
   -inf, a lower bound within relative error TIGHT = 2^-20, usually within a few ulps).
   This is safe where the output is a ceiling — a gain reduced by a min over boundaries,
   whose safety condition (Table 2's safe-for-step, linear in k, true at k = 0) holds for
   every smaller non-negative value; a model whose output must be rounded the other way
   would need an annotation (none in the library does).

HOW (the classic filtered exact predicate):

* Filter. Every arithmetic term is evaluated in float64 together with an error bound e,
  |v - x| <= e for its real value x, by forward error analysis one operation at a time
  (`filtered.add/sub/mul/div`): inputs are exact (e = 0); a sum adds u|v| (a sum small enough
  to underflow is exact); a product adds |a|eb + |b|ea + ea·eb, u|v| and ETA = 2^-1000 for
  underflow (nothing where an exact factor is 0: the product is exactly 0); a quotient adds
  (ea + |a/b| eb)/(|b| - eb) (infinite where |b| <= eb: the divisor's sign is unknown), its
  rounding and ETA. u is taken as U = 2^-52 (twice float64's unit roundoff, which also
  covers the rounding of U|v|), and every bound is inflated by INFL = 1 + 2^-40 at its use,
  which covers the relative rounding of the bound arithmetic itself for terms of fewer than
  a few hundred operations; ETA covers each bound operation's own underflow loss (< 2^-1075).
  A comparison is CERTAIN where |fl(a - b)| > (ea + eb)·INFL (then the sign of a - b in the
  reals is the float's), or where both sides are exact (e = 0, compared exactly). Overflow,
  0/0 and a divisor of unknown sign give inf/NaN bounds: never certain.
* Exact path. A row (a member of the family of boundaries) where any comparison was not
  certain, or whose output's bound is not within TIGHT, is recomputed EXACTLY: the same
  generated statements run on `fractions.Fraction` values of the float inputs (a division
  by zero gives NaN, and the model's own guard `b != 0` then fails), and the real output
  is rounded down to a float (`filtered.floor`). For a step that is a min-reduction over a
  family (ctrl2), rows are independent: only the uncertain rows are redone and the result
  is min(float rows, exact rows); otherwise the whole step is redone exactly. The exact
  path only runs on near-ties (a tool exactly on a plane with rounded inputs, a force
  exactly parallel to it, a subnormal component), never on a generic state.
* Which uncertainties matter. A case guard is a conjunction, its conjuncts in the model's
  order; a conjunct's uncertainty is flagged only on the rows where the conjuncts before it
  hold in floats (the first conjunct that fails in floats is then flagged if it is
  uncertain itself, so a row is unflagged only if its guard is certainly true or certainly
  false). Every alternative of every choice is checked this way (also those after the one
  taken: conservative). A test outside a choice is flagged everywhere. An output value is
  flagged where its bound is not within TIGHT (`filtered.loose`).
* The generated module: `controller` (the entry) calls `_filtered` (floats and bounds:
  returns the outputs over the unflagged rows, enabled, and ok = not flagged) and, where
  some row is flagged, `_exact` (the same statements on Fractions) for those rows only
  when the step is row-separable (scalar set-up, then foreach loops over every member whose
  min-reductions are the outputs: ctrl2, ctrl2_2d), else for the whole step (ctrl2_dynamic).
  The cost: the exact path is ~0.1-0.5 ms a row, and a tool exactly on a plane (d0 = 0 to
  the bit) is such a row (the bound of a product of an inexact-but-zero factor is not 0).
* Float-total follows from 2: the code reports no run only where the real model has none.
  Float-sound follows from 2 and 3: every decision is the model's, every output is one the
  model allows (a smaller gain than its own).

WHAT BIT-FOR-BIT CONFORMANCE MEANS for a back end without exact rationals (C): it runs the
same filter (same formulas, same constants, IEEE-754 double with round-to-nearest and no
contraction into fused multiply-adds: `-ffp-contract=off`). Where the filter is certain
(the overwhelming case) its decisions equal the Python kernel's and the reals'. Where it
is not, it may either decide exactly (double-double / expansion arithmetic: then it equals
Python again) or take the safe side — report the row uncertain and command the fallback
k = 0 — which is then counted as a conservative stop, never as a different decision;
conformance tests compare decisions on rows both back ends certify, and check that every
row the C side leaves uncertain is one where Python took its exact path.

This module holds the code generator's side: constants as (value, error) code, the names
the generated code uses for the helpers, and the per-operation helper call.
"""

from __future__ import annotations

from fractions import Fraction

HELPERS = "_f"  # the generated module's name for certiloop.kernel.filtered
IMPORT = "from certiloop.kernel import filtered as _f"
EXACT = "_F"  # the generated module's name for fractions.Fraction
IMPORT_EXACT = "from fractions import Fraction as _F"
OPS = {"+": "add", "-": "sub", "*": "mul", "/": "div"}


def constant(c: Fraction) -> tuple[str, str | None]:
    """A model constant as float code and its error code (None: exactly representable)."""
    f = float(c)
    text = f"{int(f)}.0" if f.is_integer() and abs(f) < 2 ** 53 else repr(f)
    if Fraction(f) == c:
        return text, None
    import math

    err = abs(Fraction(f) - c)
    bound = float(err)
    if Fraction(bound) < err:
        bound = math.nextafter(bound, math.inf)
    return text, repr(bound)


def exact_constant(c: Fraction) -> str:
    """A model constant as exact rational code for the exact path."""
    return f"{EXACT}({c.numerator})" if c.denominator == 1 else f"{EXACT}({c.numerator}, {c.denominator})"


def operation(op: str, a: tuple[str, str | None], b: tuple[str, str | None]) -> str:
    """The helper call computing (value, error) of `a op b`."""
    return f"{HELPERS}.{OPS[op]}({a[0]}, {a[1] or 'None'}, {b[0]}, {b[1] or 'None'})"


def check(a: tuple[str, str | None], b: tuple[str, str | None]) -> str | None:
    """Code of the mask where the comparison of a and b is NOT certain (None: never)."""
    if a[1] is None and b[1] is None:
        return None
    return f"{HELPERS}.uncertain({a[0]}, {a[1] or 'None'}, {b[0]}, {b[1] or 'None'})"
