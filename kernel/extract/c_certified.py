"""The C side of float-sound extraction (the scheme and its contract: `certified`; the Python
runtime it mirrors: `certiloop.kernel.filtered`). `RUNTIME` is the block of static inline
helpers every generated C file carries (no globals, libm only), and the functions below give
the C code of terms (values with error bounds, type `cl_real`) and formulas (three-valued:
1 holds, 0 fails, -1 the floats cannot decide).

Two passes, as the Python has a float pass and an exact pass:

* the FILTER (careful = 0): exactly the formulas of `filtered.add/sub/mul/div/certain/tight/
  lower`, with the same constants, so its decisions and outputs are the Python filter's;
* where a decision (or an output's tightness) is not certain, the whole step runs again with
  careful = 1: operations on exact operands use error-free transformations (TwoSum; the fma
  residual of a product or a quotient), so a result that is exactly representable stays
  exact — a tool exactly on a plane (d0 = 0), a force exactly parallel to it (fn = 0 from
  non-zero products), the issue's 2.1e-162 components — and any other result carries its
  exact rounding error as its bound. A value with bound 0 is exact.
* where even the careful pass cannot decide, the function returns -1 (UNDECIDED): no
  decision is taken, the caller falls back as for "no run" (ctrl2's fixture commands k = 0).
  C has no rationals; this is the only place where it differs from the Python kernel, which
  decides such rows exactly. Conformance (tests/test_extract_c.py): wherever C decides, its
  decision is the reals' (so the Python kernel's); undecided states are counted and checked
  to be near-ties.

sqrt (the roots of a quadratic) has no helper in `filtered`; `cl_sqrt` bounds it by
|√x - √y| <= |x - y| / √min(x, y) (or √|x - y|), documented here only."""

from __future__ import annotations

from fractions import Fraction

from certiloop.kernel.extract import certified
from certiloop.kernel.extract.errors import _refuse
from certiloop.models.lang.terms import Node

RUNTIME = r"""
/* ---- certified arithmetic: a value v with a bound e on |v - x| for its real value x
   (certiloop.kernel.extract.c_certified; the C counterpart of certiloop.kernel.filtered) ---- */
typedef struct { double v, e; int exact; } cl_real;

#if defined(__GNUC__)
#define CL_INLINE static inline __attribute__((always_inline)) /* a call per operation is 20x slower */
#define CL_SLOW static __attribute__((noinline, unused)) /* the careful pass: one copy, out of line */
#else
#define CL_INLINE static inline
#define CL_SLOW static inline
#endif

#define CL_U 0x1p-52                  /* filtered.U */
#define CL_ETA 0x1p-1000              /* filtered.ETA (far above underflow: bounds stay normal numbers) */
#define CL_INFL (1.0 + 0x1p-40)       /* filtered.INFL */
#define CL_TIGHT 0x1p-20              /* filtered.TIGHT */
#define CL_EFT_MIN 0x1p-900           /* above this, a rounding residual is representable */
/* a decision the floats cannot take: run the careful pass, else give up (return -1) */
#define CL_UNSURE do { if (!careful) return -2; goto undecided; } while (0)
#define CL_TEST(c) do { int cl_c = (c); if (cl_c < 0) CL_UNSURE; if (!cl_c) goto blocked; } while (0)

CL_INLINE cl_real cl_exact(double x) { cl_real r; r.v = x; r.e = 0.0; r.exact = 1; return r; }

CL_INLINE cl_real cl_approx(double v, double e, int careful)
{
    cl_real r;
    if (careful && e == 0.0 && isfinite(v))
        return cl_exact(v); /* |v - x| <= 0: exact. The filter keeps it inexact, as filtered.py does,
                               so that its exactness flags are known when the code is compiled */
    r.v = v; r.e = e; r.exact = 0;
    return r;
}

CL_INLINE cl_real cl_add_body(cl_real a, cl_real b, int careful)
{
    double v = a.v + b.v, e;
    if (careful && a.exact && b.exact && isfinite(v)) { /* TwoSum: the exact rounding error */
        double bb = v - a.v;
        return cl_approx(v, fabs((a.v - (v - bb)) + (b.v - bb)), careful);
    }
    e = fabs(v) * CL_U;
    if (!a.exact) e = e + a.e;
    if (!b.exact) e = e + b.e;
    return cl_approx(v, e, careful);
}
CL_SLOW cl_real cl_add_careful(cl_real a, cl_real b) { return cl_add_body(a, b, 1); }
CL_INLINE cl_real cl_add(cl_real a, cl_real b, int careful)
{
    return careful ? cl_add_careful(a, b) : cl_add_body(a, b, 0);
}

CL_INLINE cl_real cl_neg(cl_real a) { a.v = -a.v; return a; }

CL_INLINE cl_real cl_mul_body(cl_real a, cl_real b, int careful)
{
    double v = a.v * b.v, e;
    if (careful && a.exact && b.exact && isfinite(v)) {
        if (a.v == 0.0 || b.v == 0.0)
            return cl_exact(v);
        if (fabs(v) >= CL_EFT_MIN) /* the fma residual is the exact rounding error */
            return cl_approx(v, fabs(fma(a.v, b.v, -v)), careful);
    }
    e = fabs(v) * CL_U;
    if (a.exact || b.exact) /* ETA unless an exact factor is 0 (then the product is exactly 0) */
        e = e + (((a.exact && a.v == 0.0) || (b.exact && b.v == 0.0)) ? 0.0 : CL_ETA);
    else
        e = e + CL_ETA;
    if (!b.exact) e = e + fabs(a.v) * b.e;
    if (!a.exact) e = e + fabs(b.v) * a.e;
    if (!a.exact && !b.exact) e = e + a.e * b.e;
    return cl_approx(v, e, careful);
}
CL_SLOW cl_real cl_mul_careful(cl_real a, cl_real b) { return cl_mul_body(a, b, 1); }
CL_INLINE cl_real cl_mul(cl_real a, cl_real b, int careful)
{
    return careful ? cl_mul_careful(a, b) : cl_mul_body(a, b, 0);
}

CL_INLINE cl_real cl_div_body(cl_real a, cl_real b, int careful)
{
    double v = a.v / b.v, e, den, num;
    if (careful && a.exact && b.exact && b.v != 0.0 && isfinite(v)) {
        if (a.v == 0.0)
            return cl_exact(v);
        if (fabs(v) >= CL_EFT_MIN && fabs(a.v) >= CL_EFT_MIN && fabs(b.v) >= CL_EFT_MIN
            && fma(-v, b.v, a.v) == 0.0)
            return cl_exact(v); /* a = v b exactly */
    }
    e = fabs(v) * CL_U + (a.exact ? (a.v == 0.0 ? 0.0 : CL_ETA) : CL_ETA);
    if (a.exact && b.exact)
        return cl_approx(v, e, careful);
    den = b.exact ? fabs(b.v) : fabs(b.v) - b.e;
    num = (fabs(v) * (1.0 + CL_U) + CL_ETA) * (b.exact ? 0.0 : b.e);
    if (!a.exact) num = num + a.e;
    e = e + (den > 0 ? num / den : INFINITY); /* the divisor's sign unknown: never certain */
    return cl_approx(v, e, careful);
}
CL_SLOW cl_real cl_div_careful(cl_real a, cl_real b) { return cl_div_body(a, b, 1); }
CL_INLINE cl_real cl_div(cl_real a, cl_real b, int careful)
{
    return careful ? cl_div_careful(a, b) : cl_div_body(a, b, 0);
}

CL_INLINE cl_real cl_sqrt_body(cl_real a, int careful)
{
    double v = sqrt(a.v), e, lo;
    if (careful && a.exact && v >= CL_EFT_MIN && fma(v, v, -a.v) == 0.0)
        return cl_exact(v);
    e = fabs(v) * CL_U + CL_ETA;
    if (!a.exact) {
        lo = (a.v - a.e * CL_INFL) - (fabs(a.v) + a.e) * CL_U;
        e = e + (lo > 0 ? a.e * CL_INFL / sqrt(lo) : sqrt(a.e * CL_INFL)) * (1.0 + 4 * CL_U);
    }
    return cl_approx(v, e, careful);
}
CL_SLOW cl_real cl_sqrt_careful(cl_real a) { return cl_sqrt_body(a, 1); }
CL_INLINE cl_real cl_sqrt(cl_real a, int careful)
{
    return careful ? cl_sqrt_careful(a) : cl_sqrt_body(a, 0);
}

/* filtered.certain: the sign of a - b in the reals is the float's */
CL_INLINE int cl_certain(cl_real a, cl_real b)
{
    double e;
    if (a.exact && b.exact)
        return 1;
    e = a.exact ? b.e : b.exact ? a.e : a.e + b.e;
    return fabs(a.v - b.v) > e * CL_INFL || e == 0;
}

CL_INLINE int cl_lt(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v < b.v : -1; }
CL_INLINE int cl_le(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v <= b.v : -1; }
CL_INLINE int cl_gt(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v > b.v : -1; }
CL_INLINE int cl_ge(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v >= b.v : -1; }
CL_INLINE int cl_eq(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v == b.v : -1; }
CL_INLINE int cl_ne(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v != b.v : -1; }

/* three-valued connectives: 1 holds, 0 fails, -1 unknown */
CL_INLINE int cl_and(int a, int b) { return (a == 0 || b == 0) ? 0 : (a < 0 || b < 0) ? -1 : 1; }
CL_INLINE int cl_or(int a, int b) { return (a == 1 || b == 1) ? 1 : (a < 0 || b < 0) ? -1 : 0; }
CL_INLINE int cl_not(int a) { return a < 0 ? -1 : !a; }
CL_INLINE int cl_iff(int a, int b) { return (a < 0 || b < 0) ? -1 : a == b; }

/* filtered.tight and filtered.lower: an output is returned as a float <= its real value */
CL_INLINE int cl_tight(cl_real x)
{
    if (x.exact)
        return isfinite(x.v);
    return x.e * CL_INFL <= fabs(x.v) * CL_TIGHT && isfinite(x.v);
}

CL_INLINE double cl_lower(cl_real x)
{
    return (x.exact || x.e == 0) ? x.v : nextafter(x.v - x.e * CL_INFL, -INFINITY);
}
"""

COMPARE = {"<": "cl_lt", "<=": "cl_le", ">": "cl_gt", ">=": "cl_ge", "==": "cl_eq", "!=": "cl_ne"}


def cl_constant(n: Node) -> str:
    """A model constant as a certified value: exact where the double is the rational."""
    value, error = certified.constant(Fraction(n.payload))
    if value in ("inf", "-inf", "nan"):
        raise _refuse(n, "a constant outside the double range")
    return f"cl_exact({value})" if error is None else f"cl_approx({value}, {error}, careful)"


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
            raise _refuse(n, f"only natural powers up to {MAX_POWER} are written in C")
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
    raise _refuse(n, "not an arithmetic term or a quantifier-free formula")


def cl_all(conds: list[str]) -> str:
    """The conjunction of three-valued conditions."""
    conds = [c for c in conds if c != "1"]
    if not conds:
        return "1"
    code = conds[0]
    for c in conds[1:]:
        code = f"cl_and({code}, {c})"
    return code
