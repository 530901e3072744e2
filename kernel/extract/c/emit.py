"""`extract_c(theorem)`: the model's control step as C99 — a source `<name>.c` and a header
`<name>.h` (name: the model's name with dots as underscores, `sbs_ctrl2`).

The entry function has the Python kernel's semantics (see the package docstring):

    int sbs_ctrl2_controller(double px, ..., const double *rx, ..., size_t n_B, double *out_k);

scalar inputs in the Python order (INPUTS), then the families (FAMILIES) as pointers, then one
length per index sort (`n_B`: every family over B has that many elements), then one pointer
per output. It returns 1 (a run) and writes the outputs; 0 where the model has no run (no
enabled alternative, a failed test) or an input is not finite; -1 (UNDECIDED) where the floats
cannot certify a decision (see c_certified); on 0 and -1 every scalar output is NaN and the
caller must fall back. No allocation, no globals, libm only; the header pins the model's
content hash (`SBS_CTRL2_MODEL_HASH`).

Decisions are float-sound (c_certified): wherever C decides, the decision is the model's in
the reals, so the float-sound Python kernel's; where the Python kernel's float pass decides
alone, C runs the same filter and its outputs are the Python's bit for bit. Compile with
`-ffp-contract=off` (c/syntax.py, CFLAGS): the bounds assume one rounding per operation."""

from __future__ import annotations

from certiloop.kernel.extract.analysis import split, uses_families
from certiloop.kernel.extract.c.certified import RUNTIME, RUNTIME_HEADER
from certiloop.kernel.extract.c.syntax import (
    CFLAGS,
    HEADER_H,
    c_comment,
    c_comment_text,
    c_element_type,
    c_name,
    c_string_text,
    c_type,
    check_c_names,
    without_dead,
)
from certiloop.kernel.extract.errors import ExtractError
from certiloop.kernel.extract.template import SCALAR, VECTORISED
from certiloop.models.lang.terms import BOOL, REAL, ModelError
from certiloop.models.lang.theorem import Theorem


def extract_c(theorem: Theorem) -> dict[str, str]:
    """{file name: text} of the C kernel: `<name>.h` and `<name>.c`. Raises ExtractError,
    with a one-line reason naming the model, for a shape it cannot write in C."""
    from certiloop.kernel.extract.names import c_unsafe, generate_renamed

    try:
        files = generate_renamed(theorem, lambda name: c_unsafe(name, c_name(theorem.name)), _extract_c)
        return _python_names_in_macros(theorem, files)
    except ModelError as exc:
        message = " ".join(str(exc).split())
        if not message.startswith(f"{theorem.name}:"):
            message = f"{theorem.name}: {message}"
        raise ExtractError(message) from None


def _extract_c(theorem: Theorem) -> dict[str, str]:
    step = split(theorem)
    base = c_name(theorem.name)
    sizes: list[str] = []
    families: dict = {}
    tail: list[str] = []
    if uses_families(step.parts):
        if step.where in ("modes", "switched", "algorithm"):
            raise ExtractError("a family of boundaries in a switched plant or an algorithm is not vectorised")
        from certiloop.kernel.extract.c.family import c_family, pinned_output

        lines, params, families, outputs, em = c_family(theorem, step)
        if len(em.sizes) > 1:
            raise ExtractError("families over two index sorts are not written in C")
        scalar_shape = False
        for v, sort in outputs:
            if sort.is_array:
                tail += pinned_output(em, v, sort)
        sizes = list(dict.fromkeys(em.sizes.values()))
        decls, blocks, how = [], em.blocks, VECTORISED
    else:
        from certiloop.kernel.extract.c.scalar import c_scalar

        lines, params, outputs, decls, blocks = c_scalar(theorem, step)
        scalar_shape = True
        how = SCALAR[step.where]
    names = [*params, *families, *(v for v, _ in outputs)]
    check_c_names(theorem.name, names + [f"out_{v}" for v, _ in outputs] + sizes)
    signature = [f"{c_type(s)} {v}" for v, s in params.items()]
    signature += [f"const {c_element_type(s.range)} *{v}" for v, s in families.items()]
    signature += [f"size_t {n}" for n in sizes]
    signature += [f"{c_element_type(s.range) if s.is_array else c_type(s)} *out_{v}" for v, s in outputs]
    # one pass, inlined twice: careful = 0 (the filter) and careful = 1 (error-free
    # transformations), each specialised by the compiler for its constant
    body = [c_comment("one pass of the step: returns 1 (a run), 0 (no run), -1 (undecided) or, in the "
                      "filter pass, -2 (run the careful pass)"),
            f"CL_INLINE int {base}_pass(int careful, {', '.join(signature)})", "{",
            "    int cl_t = 0;", "    (void)cl_t;"]
    reals = [v for v, s in params.items() if s == REAL]
    real_families = [v for v, s in families.items() if s.range == REAL]
    # families read only inside foreach loops are range-checked there, element by element, before
    # the loop's body reads them (see below); read elsewhere too, here, before the step
    in_loops = bool(real_families) and not scalar_shape and not em.outside_reads and bool(em.loop_heads)
    if in_loops:
        for head, index in reversed(em.loop_heads):
            pad = lines[head][:len(lines[head]) - len(lines[head].lstrip())] + "    "
            note = ("this boundary's inputs 0 or in [2^-48, 2^48] before the body reads them, else the "
                    "careful pass")
            check = [pad + "if (!careful) { " + c_comment(note),
                     pad + "    uint64_t cl_hi = 0, cl_lo = ~(uint64_t)0;"]
            check += [pad + f"    cl_range({fam}[{index}], &cl_hi, &cl_lo);" for fam in real_families]
            check += [pad + "    if (!cl_range_ok(cl_hi, cl_lo)) return -2;", pad + "}"]
            lines[head + 1:head + 1] = check
    if reals or real_families:
        # the filter's static bounds need inputs in range (see cl_static), which are finite; the
        # careful pass checks finiteness (a non-finite input fails the range: careful pass)
        size = next(iter(sizes), None)  # one index sort: checked by c_family
        body.append("    if (!careful) { " + c_comment("inputs 0 or in [2^-48, 2^48], else the careful pass"))
        body.append(f"        int cl_r = {' & '.join(f'cl_in_range({v})' for v in reals) or '1'};")
        for fam in [] if in_loops else real_families:  # no early exit: no branch per element
            body.append(f"        for (size_t cl_i = 0; cl_i < {size}; cl_i++)")
            body.append(f"            cl_r &= cl_in_range({fam}[cl_i]);")
        body.append("        if (!cl_r) return -2;")
        body.append("    } else { " + c_comment("inputs finite, or outside the model's domain: no run"))
        if reals:
            body.append(f"        if (!({' && '.join(f'isfinite({v})' for v in reals)})) goto blocked;")
        for fam in real_families:
            body.append(f"        for (size_t cl_i = 0; cl_i < {size}; cl_i++)")
            body.append(f"            if (!isfinite({fam}[cl_i])) goto blocked;")
        body.append("    }")
    for v, s in params.items():
        if s == REAL:
            body.append(f"    cl_real cl_{v} = cl_exact({v});")
        elif scalar_shape:
            body.append(f"    int cl_{v} = ({v} != 0);")
    copies = [v for v, s in params.items() if s == REAL or scalar_shape]
    if copies:
        unused = " ".join(f"(void)cl_{v};" for v in copies)
        body.append(f"    {unused} {c_comment('some are only set')}")
    body += ["    " + d for d in decls]
    body += without_dead(lines, keep={f"cl_{v}" for v, _ in outputs} | {f"cl_{v}" for v in params})
    body.append("    " + c_comment("an output is returned rounded down to a float <= its real value"))
    for v, s in outputs:
        if s == REAL:
            body.append(f"    if (!cl_tight(cl_{v})) CL_UNSURE;")
        elif s == BOOL:
            body.append(f"    if (cl_{v} < 0) CL_UNSURE;")
    body += ["    " + t for t in tail]
    body += [f"    *out_{v} = {'cl_lower(cl_' + v + ')' if s == REAL else 'cl_' + v};" for v, s in outputs
             if not s.is_array]
    body.append("    return 1;")
    text = "\n".join(body)
    if "blocked" in text:
        body.append("blocked:")
        body += [f"    *out_{v} = {'NAN' if s == REAL else '0'};" for v, s in outputs if not s.is_array]
        body.append("    return 0;")
    if "CL_UNSURE" in text or "CL_TEST" in text:
        body.append("undecided:")
        body += [f"    *out_{v} = {'NAN' if s == REAL else '0'};" for v, s in outputs if not s.is_array]
        body.append("    return -1;")
    else:
        body.insert(body.index("    int cl_t = 0;"), "    (void)careful;")
    body.append("}")
    args = ", ".join(name.rsplit("*", 1)[-1].split()[-1] for name in signature)
    body += ["", f"int {base}_controller({', '.join(signature)})", "{",
             f"    int rc = {base}_pass(0, {args});",
             f"    return rc == -2 ? {base}_pass(1, {args}) : rc;", "}"]
    what = "algorithm" if step.where == "algorithm" else "discrete controller"
    doc = _doc(outputs, families, sizes)
    header = HEADER_H.format(
        model=c_comment_text(theorem.name), model_string=c_string_text(theorem.name), what=what,
        description=c_comment_text(theorem.description),
        how=how.replace("Python", "C").replace("numpy", "C").replace("\n", "\n   "),
        flags=" ".join(CFLAGS), base=base, upper=base.upper(), hash=theorem.content_hash,
        inputs=" ".join(params), families=" ".join(families), outputs=" ".join(v for v, _ in outputs),
        doc=doc, params=", ".join(signature))
    shown = c_comment_text(theorem.name)
    source = (f"/* Generated by `certiloop extract {shown} --lang c` -- do not edit; re-extract "
              f"instead.\n   Model {shown}, content hash {theorem.content_hash}; see {base}.h. */\n"
              f"#include <math.h>\n\n#include \"{base}.h\"\n#include \"{RUNTIME_HEADER}\"\n\n"
              + "\n".join(body) + "\n")
    return {f"{base}.h": header, f"{base}.c": source, RUNTIME_HEADER: RUNTIME}


def _python_names_in_macros(theorem: Theorem, files: dict[str, str]) -> dict[str, str]:
    """The header's INPUTS / FAMILIES / OUTPUTS macros name the symbols as the Python kernel does
    (its INPUTS), whatever C had to rename (a C parameter `u_c` is the model's `c`)."""
    import re

    from certiloop.kernel.extract.names import PREFIX, c_unsafe, python_unsafe, renaming

    base = c_name(theorem.name)
    back = {new: old for old, new in renaming(theorem, lambda n: c_unsafe(n, base)).items()}
    if not back:
        return files

    def name(word: str) -> str:
        old = back.get(word, word)
        return PREFIX + old if python_unsafe(old) else old

    def macro(m: re.Match) -> str:
        return m.group(1) + " ".join(name(w) for w in m.group(2).split()) + '"'

    pattern = re.compile(rf'^(#define {base.upper()}_(?:INPUTS|FAMILIES|OUTPUTS) ")([^"]*)"', re.M)
    return {k: pattern.sub(macro, v) if k.endswith(".h") else v for k, v in files.items()}


def _doc(outputs, families, sizes) -> str:
    outs = ", ".join(f"*out_{v}" for v, _ in outputs)
    text = (f"/* Writes {outs} -- the values the verified model computes for this state (where several "
            "alternatives of a choice are enabled, the first in the model's order), real outputs "
            "rounded down to a float <= the real value -- and returns 1. Returns 0 where the model has "
            "no run (no enabled alternative, a failed test) or an input is not finite, and -1 "
            "(UNDECIDED) where the floats cannot certify a decision (a near-tie, an overflow): scalar "
            "outputs are then NaN and the caller must fall back. Every decision taken is the "
            "model's in the reals.")
    if families:
        text += (f" Families are arrays of {' / '.join(sizes)} elements (Bool families: one byte each, "
                 "non-zero = true).")
    if any(s.is_array for _, s in outputs):
        text += " Output families are written only when the function returns 1."
    words, rows, row = text.split(), [], ""
    for w in words:
        if row and len(row) + 1 + len(w) > 92:
            rows.append(row)
            row = w
        else:
            row = f"{row} {w}" if row else w
    rows.append(row)
    return "\n   ".join(rows) + " */"


def compile_error(files: dict[str, str]) -> str | None:
    """The first diagnostic of the C compiler on the generated files (with -Werror, under
    -std=c99, -std=c11 and the compiler's default), None where they compile or no compiler is
    on the PATH: the last guard that extract never writes C that does not build."""
    import subprocess
    import tempfile
    from pathlib import Path

    from certiloop.kernel.extract.c.build import compiler

    cc = compiler()
    if cc is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            (Path(tmp) / name).write_text(text)
        source = next(name for name in files if name.endswith(".c"))
        # the compiler's default (GNU) mode too: `cc -Wall -Wextra -Werror -pedantic` as a user
        # types it, where <math.h> defines more macros (M_SQRT2) than under -std=c99
        for std in ("-std=c99", "-std=c11", None):
            flags = [f for f in CFLAGS if not f.startswith("-std=")] + [std, "-fsyntax-only"][std is None:]
            done = subprocess.run([cc, *flags, source], cwd=tmp, capture_output=True, text=True)
            if done.returncode != 0 or done.stderr.strip():
                lines = [line for line in done.stderr.splitlines() if "error" in line or "warning" in line]
                return (lines or done.stderr.splitlines() or ["exit status " + str(done.returncode)])[0]
    return None
