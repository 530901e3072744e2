"""Any identifier works: a model symbol whose name the generated code cannot use as it is (a
Python or C keyword, a C library name, a name the generated code uses itself or one that looks
like it) is renamed `u_<name>` in the generated code, everywhere, before generation.

The scheme is injective: a name is renamed iff it is unsafe, and every name starting with
`u_` is unsafe, so a renamed `u_x` (from `x`) never meets a symbol kept as it is (no kept name
starts with `u_`), and two renamed names differ as their originals do. The generated names
themselves (`cl_*`, `CL_*`, `out_*`, `n_*`, the entry's prefix) never start with `u_`."""

from __future__ import annotations

import builtins
import keyword
import re
from dataclasses import replace
from functools import lru_cache

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import Node, Var, free_vars, substitute
from certiloop.models.lang.theorem import Theorem

PREFIX = "u_"

# the C library's names a C file may see through <math.h>, <stddef.h>, <stdint.h> and the common
# libc and compiler names (a variable may not shadow a function the generated code calls, and
# `main` may not be a variable at file scope)
C_LIBRARY = {
    "acos", "acosh", "asin", "asinh", "atan", "atan2", "atanh", "cbrt", "ceil", "copysign", "cos", "cosh",
    "erf", "erfc", "exp", "exp2", "expm1", "fabs", "fdim", "floor", "fma", "fmax", "fmin", "fmod", "frexp",
    "hypot", "ilogb", "ldexp", "lgamma", "llrint", "llround", "log", "log10", "log1p", "log2", "logb",
    "lrint", "lround", "modf", "nan", "nearbyint", "nextafter", "nexttoward", "pow", "remainder", "remquo",
    "rint", "round", "scalbln", "scalbn", "sin", "sinh", "sqrt", "tan", "tanh", "tgamma", "trunc",
    "isfinite", "isinf", "isnan", "isnormal", "signbit", "fpclassify", "isgreater", "isless",
    "math_errhandling",
    "INFINITY", "NAN", "HUGE_VAL", "HUGE_VALF", "HUGE_VALL", "M_PI", "M_E", "FP_NAN", "FP_INFINITE",
    "FP_ZERO", "FP_NORMAL", "FP_SUBNORMAL", "MATH_ERRNO", "MATH_ERREXCEPT", "float_t", "double_t",
    "size_t", "ptrdiff_t", "wchar_t", "max_align_t", "NULL", "offsetof", "main", "errno", "abs", "labs",
    "exit", "abort", "malloc", "free", "printf", "assert", "bool", "true", "false", "alignof", "alignas",
    "noreturn", "static_assert", "thread_local", "complex", "imaginary", "I", "y0", "y1", "yn", "j0",
    "j1", "jn", "gamma", "signgam", "drem", "finite", "significand", "unix", "linux", "i386", "asm",
    "typeof", "_Bool", "_Complex", "_Imaginary", "_Alignas", "_Alignof", "_Atomic", "_Generic",
    "_Noreturn", "_Static_assert", "_Thread_local", "restrict", "inline",
    # object-like macros of the C libraries' <math.h> outside their own families below (glibc in
    # its default GNU mode, BSD/macOS and the old System V interface)
    "HUGE", "MAXFLOAT", "DOMAIN", "SING", "OVERFLOW", "UNDERFLOW", "TLOSS", "PLOSS", "X_TLOSS",
    "FLT_EVAL_METHOD", "DECIMAL_DIG",
}
# The macro families <math.h>, <stddef.h> and <stdint.h> define (in the compiler's default GNU
# mode too, where `cc -Wall -Wextra -Werror -pedantic` compiles the file: M_SQRT2, INT8_MAX,
# FP_ILOGB0, ...), the types <stdint.h> names, and the `is...` classification macros: a model
# symbol of such a form would be replaced by the preprocessor, so it is renamed whether or not
# this platform's headers define it.
C_MACRO_FAMILY = re.compile(
    r"M_\w+|FP_\w+|MATH_\w+|HUGE_\w+|FLT_\w+|DBL_\w+|LDBL_\w+"
    r"|(?:U?INT\w*|PTRDIFF|SIZE|SIG_ATOMIC|WCHAR|WINT)_(?:MAX|MIN|WIDTH|C)"
    r"|u?int(?:_least|_fast)?\d+_t|u?int(?:max|ptr)_t|float_t|double_t|is[a-z]\w*")


def _python_unsafe(name: str, reserved: set[str]) -> bool:
    return (keyword.iskeyword(name) or keyword.issoftkeyword(name) or name in reserved
            or name in dir(builtins) or name.startswith(("_", PREFIX))
            or re.fullmatch(r"t\d+|case_\w+|\w+_dot", name) is not None or not name.isidentifier())


def python_unsafe(name: str) -> bool:
    from certiloop.kernel.extract.template import RESERVED

    # and the controller monitor's own parameters and modules
    return _python_unsafe(name, RESERVED | {"state", "command", "math", "types"})


def c_unsafe(name: str, base: str) -> bool:
    """Unsafe in C: a keyword, a library name, a name whose local copy `cl_<name>` the runtime or
    the generators write themselves (cl_t, cl_lower, cl_add), an output's `out_<name>`, a length
    `n_<sort>`, the entry's prefix, or anything a C compiler reserves (`__x`, `_X`). Not i and j:
    the model's own index of a family is its loop variable, and a scalar's cl_i is shadowed only
    by the range checks' own loop counters, which read nothing else."""
    from certiloop.kernel.extract.c.syntax import C_RESERVED

    return (name in C_RESERVED - {"i", "j"} or name in C_LIBRARY or name in _c_generated() - {"i", "j"}
            or C_MACRO_FAMILY.fullmatch(name) is not None
            or name in ("rc", "careful") or re.fullmatch(r"c\d+", name) is not None  # cl_c0: a choice's flag
            or name.startswith(("_", PREFIX, "cl_", "CL_", "out_", "n_", f"{base}_", f"{base.upper()}_"))
            or _python_unsafe(name, set()) or not re.fullmatch(r"[A-Za-z_]\w*", name))


@lru_cache(maxsize=1)
def _c_generated() -> frozenset[str]:
    """Every x of a `cl_x` the C runtime or the C generators write themselves: read from the C
    printer's sources (as text: the printer imports this module, so it is not imported here)."""
    from pathlib import Path

    text = "".join(path.read_text() for path in sorted((Path(__file__).parent / "c").glob("*.py")))
    return frozenset(re.findall(r"\bcl_(\w+)", text))


def renaming(theorem: Theorem, unsafe) -> dict[str, str]:
    """{old: new} for every symbol of the model the predicate calls unsafe."""
    symbols = {**free_vars(theorem.assumptions), **theorem.program.symbols(), **free_vars(theorem.guarantee)}
    return {name: PREFIX + name for name in symbols if unsafe(name)}


def generate_renamed(theorem: Theorem, unsafe, generate):
    """`generate(model)` on the model with its unsafe symbols renamed; the text (or every file
    of a dict) keeps the original model's content hash."""
    mapping = renaming(theorem, unsafe)
    if not mapping:
        return generate(theorem)
    model = renamed(theorem, mapping)
    out = generate(model)
    if isinstance(out, dict):
        return {k: v.replace(model.content_hash, theorem.content_hash) for k, v in out.items()}
    return out.replace(model.content_hash, theorem.content_hash)


def renamed(theorem: Theorem, mapping: dict[str, str]) -> Theorem:
    """The same model with its symbols renamed (the content hash is the caller's to keep)."""
    if not mapping:
        return theorem
    symbols = {**free_vars(theorem.assumptions), **theorem.program.symbols(), **free_vars(theorem.guarantee)}
    env = {old: Var(new, symbols[old].sort) for old, new in mapping.items()}

    def term(n: Node | None) -> Node | None:
        return None if n is None else substitute(n, env)

    def program(p: Program) -> Program:
        if isinstance(p, Assign):
            return replace(p, target=term(p.target), value=term(p.value))
        if isinstance(p, Havoc):
            return replace(p, target=term(p.target))
        if isinstance(p, Test):
            return replace(p, cond=term(p.cond))
        if isinstance(p, Seq):
            return replace(p, parts=tuple(program(q) for q in p.parts))
        if isinstance(p, Choice):
            return replace(p, alternatives=tuple(program(q) for q in p.alternatives))
        if isinstance(p, Loop):
            each = p.each and replace(p.each, index=term(p.each.index), done=term(p.each.done),
                                      member=term(p.each.member))
            count = p.count and replace(p.count, counter=term(p.count.counter), limit=term(p.count.limit))
            return replace(p, body=program(p.body), invariant=term(p.invariant), each=each, count=count)
        if isinstance(p, ODE):
            return replace(p, eqs=tuple((term(x), term(e)) for x, e in p.eqs), domain=term(p.domain),
                           invariants=tuple(term(i) for i in p.invariants))
        raise TypeError(f"unknown statement {type(p).__name__}")

    changes = dict(assumptions=term(theorem.assumptions), program=program(theorem.program),
                   guarantee=term(theorem.guarantee))
    changes["abbreviations"] = {mapping.get(k, k): term(v) for k, v in theorem.abbreviations.items()}
    changes["constants"] = tuple(term(c) for c in theorem.constants)
    if theorem.roles is not None:
        roles = theorem.roles
        changes["roles"] = replace(roles, environment=tuple(term(v) for v in roles.environment),
                                   controls=tuple(term(v) for v in roles.controls))
    # proof hints and the refuter's scenarios do not reach the generated code
    changes.update(scenarios=(), well_defined=(), defined_if=(), witnesses=(), ghosts=())
    return replace(theorem, **changes)
