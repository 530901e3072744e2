/* certiloop_runtime.h -- the certified arithmetic every C kernel `certiloop extract --lang c`
   writes includes: values with error bounds and the three-valued comparisons built on them
   (the C counterpart of certiloop.kernel.filtered; the proof sketches are in
   certiloop/kernel/extract/c/certified.py). Static inline functions and macros only: no
   globals, libm alone. Shipped with certiloop and written beside each extracted kernel. */
#ifndef CERTILOOP_RUNTIME_H
#define CERTILOOP_RUNTIME_H

#include <math.h>
#include <stdint.h> /* uint64_t: the range test on a family's elements (cl_range) */

/* ---- certified arithmetic: a value v with a bound on |v - x| for its real value x
   (certiloop.kernel.extract.c.certified; the C counterpart of certiloop.kernel.filtered) ----
   A value is STATIC (k >= 0: |v - x| <= k U m, m the term evaluated on magnitudes) or
   DYNAMIC (k < 0: |v - x| <= e, the running bound of filtered.py). Exact values are static
   with k = 0, m = |v|. The filter keeps +, -, * and / by an exact value static: a count and a
   magnitude per operation, which the compiler folds (k is a constant for every value that
   does not come out of a choice), instead of a running bound. */
typedef struct { double v, e, m, k, d; int exact; } cl_real; /* d: a static value's degree */

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
#define CL_TINY 0x1p-1020             /* a static product's magnitude at least this: underflow is covered */
#define CL_LEAF_MIN 0x1p-48           /* the filter's inputs: 0 or magnitudes in [2^-48, 2^48] ... */
#define CL_LEAF_MAX 0x1p48
#define CL_DEGREE_MAX 21.0            /* ... so a product of up to 21 of them is >= 2^-1008 > CL_TINY */
/* a decision the floats cannot take: run the careful pass, else give up (return -1) */
#define CL_UNSURE do { if (!careful) return -2; goto undecided; } while (0)
#define CL_TEST(c) do { int cl_c = (c); if (cl_c < 0) CL_UNSURE; if (!cl_c) goto blocked; } while (0)

CL_INLINE int cl_in_range(double x)
{
    double a = fabs(x);
    return (a == 0.0) | ((a >= CL_LEAF_MIN) & (a <= CL_LEAF_MAX)); /* no branch: vectorised loops */
}

/* The same range test on a family's elements, inside the loop over them: each element's bits
   with the sign shifted out, b, are 0 or in [bits(2^-48), bits(2^48)] (for numbers >= 0 the
   bits order as the values; NaN and infinities lie above). Folded over a boundary's elements as
   hi = max b (<= CL_LEAF_MAX_BITS) and lo = min (b - 1) in unsigned arithmetic (b = 0 wraps to
   the largest value, so it passes; b in (0, CL_LEAF_MIN_BITS) fails): integer operations,
   beside the floating-point work of the step. */
#define CL_LEAF_MIN_BITS 0x79E0000000000000ULL /* the bits of CL_LEAF_MIN shifted up by one */
#define CL_LEAF_MAX_BITS 0x85E0000000000000ULL /* the bits of CL_LEAF_MAX shifted up by one */
CL_INLINE void cl_range(double x, uint64_t *hi, uint64_t *lo)
{
    union { double d; uint64_t u; } c;
    uint64_t b;
    c.d = x;
    b = c.u << 1;
    *hi = b > *hi ? b : *hi;
    *lo = b - 1 < *lo ? b - 1 : *lo;
}
CL_INLINE int cl_range_ok(uint64_t hi, uint64_t lo)
{
    return (hi <= CL_LEAF_MAX_BITS) & (lo >= CL_LEAF_MIN_BITS - 1);
}

/* an input (the filter has checked its range), or a constant in range */
CL_INLINE cl_real cl_exact(double x)
{
    cl_real r; r.v = x; r.e = 0.0; r.m = fabs(x); r.k = 0.0; r.d = 1.0; r.exact = 1; return r;
}
/* a model constant: degree 1 if in range, else one that fences every product it enters */
CL_INLINE cl_real cl_const(double x)
{
    cl_real r = cl_exact(x);
    r.d = cl_in_range(x) ? 1.0 : 1e9;
    return r;
}

/* Static bounds (the filter only). Without underflow, a term evaluated in floats is its real
   value with every monomial multiplied by at most d factors (1 + delta), |delta| <= u, d the
   roundings on its path: |v - x| <= gamma_d m (Higham, Accuracy and Stability, 3.1), m the
   real magnitude term. A product or quotient t whose computed magnitude is >= CL_TINY (or 0:
   an exact zero factor, no rounding at all) underflows by at most 2^-1075 <= 2^-54 m(t) <= u
   m(t), which reaches the root multiplied by t's cofactors: at most u m, counted as one more
   rounding (k + 2 per product). k U m = 2 k u m covers gamma_k m and the rounding of m itself
   (m_computed >= m (1 - u)^k). m(t) >= CL_TINY or 0 holds by construction where t's degree d
   (leaves and 1/divisor count 1) is at most CL_DEGREE_MAX: the filter runs only on inputs 0 or
   in [2^-48, 2^48] (else straight to the careful pass), so a non-zero monomial of m(t) is at
   least 2^(-48 d). The compiler folds d like k; beyond CL_DEGREE_MAX the magnitude is checked:
   one below CL_TINY becomes infinite (never certain) unless a factor's magnitude is 0 (`zero`:
   then the value is exactly 0; a product of non-zero magnitudes may have underflowed to 0). */
CL_INLINE cl_real cl_static(double v, double m, double k, double d, int zero)
{
    cl_real r;
    r.v = v; r.e = 0.0; r.k = k; r.d = d; r.exact = 0;
    r.m = (d <= CL_DEGREE_MAX || m >= CL_TINY || zero) ? m : INFINITY;
    return r;
}

/* A value merged from a choice's branches (each static or dynamic, each with its own k and
   d) as ONE static shape, k = CL_WIDE_K and d = CL_WIDE_D, so that the code after the choice
   folds like the code before it. Sound because the static rules need only |x| <= m and
   |v - x| <= gamma_k m, and the degree bound m >= 2^(-48 d): m is raised to the largest of a
   bound on |x|, e/(k u) for the value's error bound e, and 2^(-48 d). The exact flag stays
   (an exact 1 stays exact). The careful pass keeps the value as it is. */
#define CL_WIDE_K 32.0
#define CL_WIDE_D 4.0
CL_INLINE double cl_bound(cl_real a);
CL_INLINE cl_real cl_widen(cl_real x, int careful)
{
    double e, m;
    if (careful)
        return x;
    e = cl_bound(x);
    if (!(e < INFINITY) || !(fabs(x.v) < INFINITY)) {
        m = INFINITY;
    } else {
        m = (x.k >= 0 ? x.m : fabs(x.v) + e) * CL_INFL;  /* >= |x| */
        if (e * (2.0 / (CL_WIDE_K * CL_U)) * CL_INFL > m)
            m = e * (2.0 / (CL_WIDE_K * CL_U)) * CL_INFL; /* gamma_K m >= K u m >= e */
        if (m < 0x1p-192) /* 2^(-48 CL_WIDE_D) */
            m = 0x1p-192;
    }
    x.e = 0.0; x.m = m; x.k = CL_WIDE_K; x.d = CL_WIDE_D;
    return x;
}

/* the bound on |v - x| of any value; infinite for a static value that overflowed (m may not
   have: only a finite v is within k U m of x) */
CL_INLINE double cl_bound(cl_real a)
{
    return a.k < 0 ? a.e : fabs(a.v) < INFINITY ? a.k * CL_U * a.m : INFINITY;
}

CL_INLINE cl_real cl_approx(double v, double e, int careful)
{
    cl_real r;
    if (careful && e == 0.0 && isfinite(v))
        return cl_exact(v); /* |v - x| <= 0: exact. The filter keeps it inexact, as filtered.py does,
                               so that its exactness flags are known when the code is compiled */
    r.v = v; r.e = e; r.m = 0.0; r.k = -1.0; r.d = 0.0; r.exact = 0;
    return r;
}

CL_INLINE cl_real cl_add_body(cl_real a, cl_real b, int careful)
{
    double v = a.v + b.v, e;
    if (!careful && a.k >= 0 && b.k >= 0)
        return cl_static(v, a.m + b.m, (a.k > b.k ? a.k : b.k) + 1.0, a.d > b.d ? a.d : b.d, 1);
    if (careful && a.exact && b.exact && isfinite(v)) { /* TwoSum: the exact rounding error */
        double bb = v - a.v;
        return cl_approx(v, fabs((a.v - (v - bb)) + (b.v - bb)), careful);
    }
    e = fabs(v) * CL_U;
    if (!a.exact) e = e + cl_bound(a);
    if (!b.exact) e = e + cl_bound(b);
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
    double v = a.v * b.v, e, ea, eb;
    if (!careful && a.k >= 0 && b.k >= 0)
        return cl_static(v, a.m * b.m, a.k + b.k + 2.0, a.d + b.d, a.m == 0.0 || b.m == 0.0);
    if (careful && a.exact && b.exact && isfinite(v)) {
        if (a.v == 0.0 || b.v == 0.0)
            return cl_exact(v);
        if (fabs(v) >= CL_EFT_MIN) /* the fma residual is the exact rounding error */
            return cl_approx(v, fabs(fma(a.v, b.v, -v)), careful);
    }
    ea = cl_bound(a);
    eb = cl_bound(b);
    e = fabs(v) * CL_U;
    if (a.exact || b.exact) /* ETA unless an exact factor is 0 (then the product is exactly 0) */
        e = e + (((a.exact && a.v == 0.0) || (b.exact && b.v == 0.0)) ? 0.0 : CL_ETA);
    else
        e = e + CL_ETA;
    if (!b.exact) e = e + fabs(a.v) * eb;
    if (!a.exact) e = e + fabs(b.v) * ea;
    if (!a.exact && !b.exact) e = e + ea * eb;
    return cl_approx(v, e, careful);
}
CL_SLOW cl_real cl_mul_careful(cl_real a, cl_real b) { return cl_mul_body(a, b, 1); }
CL_INLINE cl_real cl_mul(cl_real a, cl_real b, int careful)
{
    return careful ? cl_mul_careful(a, b) : cl_mul_body(a, b, 0);
}

CL_INLINE cl_real cl_div_body(cl_real a, cl_real b, int careful)
{
    double v = a.v / b.v, e, den, num, ea, eb;
    if (!careful && a.k >= 0 && b.exact && b.v != 0.0) /* by an exact divisor: a rounding, as a product */
        return cl_static(v, a.m / fabs(b.v), a.k + 2.0, a.d + b.d, a.m == 0.0);
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
    ea = cl_bound(a);
    eb = cl_bound(b);
    den = b.exact ? fabs(b.v) : fabs(b.v) - eb;
    num = (fabs(v) * (1.0 + CL_U) + CL_ETA) * (b.exact ? 0.0 : eb);
    if (!a.exact) num = num + ea;
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
    double v = sqrt(a.v), e, lo, ea = cl_bound(a);
    /* a = v v exactly: the residual a - v v is a multiple of about 2^-105 a, representable
       (not lost to underflow) only when a >= 2^-900, as for the quotient */
    if (careful && a.exact && a.v >= CL_EFT_MIN && v >= CL_EFT_MIN && fma(v, v, -a.v) == 0.0)
        return cl_exact(v);
    e = fabs(v) * CL_U + CL_ETA;
    if (!a.exact) {
        lo = (a.v - ea * CL_INFL) - (fabs(a.v) + ea) * CL_U;
        e = e + (lo > 0 ? ea * CL_INFL / sqrt(lo) : sqrt(ea * CL_INFL)) * (1.0 + 4 * CL_U);
    }
    return cl_approx(v, e, careful);
}
CL_SLOW cl_real cl_sqrt_careful(cl_real a) { return cl_sqrt_body(a, 1); }
CL_INLINE cl_real cl_sqrt(cl_real a, int careful)
{
    return careful ? cl_sqrt_careful(a) : cl_sqrt_body(a, 0);
}

/* a value's bound inside a comparison, inflated by CL_INFL (the margin for the rounding of the
   bound's own computation): for a static value m (k U INFL), m times a constant the compiler
   folds, >= k U m (INFL = 1 + 2^-40 outweighs the two roundings, of the constant and of the
   product, each at most 1 - 2^-53; the constant is exact for k < 2^12). No finiteness test, which
   cl_certain needs not: a - b is finite only if a and b are (inf - x, x - inf, NaN - x are not),
   and a comparison whose difference is not finite is never certain */
CL_INLINE double cl_cmp_bound(cl_real a)
{
    return a.k < 0 ? a.e * CL_INFL : a.m * (a.k * (CL_U * CL_INFL));
}

/* filtered.certain: the sign of a - b in the reals is the float's. |fl(a - b)| > E >= e_a + e_b
   implies |a - b| > e_a + e_b (rounding is monotonic), and the subtraction keeps the sign */
CL_INLINE int cl_certain(cl_real a, cl_real b)
{
    double e;
    if (a.exact && b.exact)
        return 1;
    e = a.exact ? cl_cmp_bound(b) : b.exact ? cl_cmp_bound(a) : cl_cmp_bound(a) + cl_cmp_bound(b);
    return (fabs(a.v - b.v) > e || e == 0) && fabs(a.v - b.v) < INFINITY;
}

CL_INLINE int cl_lt(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v < b.v : -1; }
CL_INLINE int cl_le(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v <= b.v : -1; }
CL_INLINE int cl_gt(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v > b.v : -1; }
CL_INLINE int cl_ge(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v >= b.v : -1; }
CL_INLINE int cl_eq(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v == b.v : -1; }
CL_INLINE int cl_ne(cl_real a, cl_real b) { return cl_certain(a, b) ? a.v != b.v : -1; }

/* three-valued connectives: 1 holds, 0 fails, -1 unknown */
/* (on {-1, 1}, a | b is -1 where either is -1; on {-1, 0}, where either is) */
CL_INLINE int cl_and(int a, int b) { return (a == 0 || b == 0) ? 0 : a | b; }
CL_INLINE int cl_or(int a, int b) { return (a == 1 || b == 1) ? 1 : a | b; }
CL_INLINE int cl_not(int a) { return a < 0 ? -1 : !a; }
CL_INLINE int cl_iff(int a, int b) { return (a < 0 || b < 0) ? -1 : a == b; }

/* filtered.tight and filtered.lower: an output is returned as a float <= its real value */
CL_INLINE int cl_tight(cl_real x)
{
    if (x.exact)
        return isfinite(x.v);
    return cl_bound(x) * CL_INFL <= fabs(x.v) * CL_TIGHT && isfinite(x.v);
}

CL_INLINE double cl_lower(cl_real x)
{
    double e = cl_bound(x);
    return (x.exact || e == 0) ? x.v : nextafter(x.v - e * CL_INFL, -INFINITY);
}

/* cl_lower(x) < k for a float k, without the libm call: the float below y is < k iff y <= k */
CL_INLINE int cl_lower_below(cl_real x, double k)
{
    double e = cl_bound(x);
    return (x.exact || e == 0) ? x.v < k : x.v - e * CL_INFL <= k;
}

#endif /* CERTILOOP_RUNTIME_H */
