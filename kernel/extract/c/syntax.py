"""C syntax shared by the two C code shapes: constants, operators, types, the names the
generated C uses itself (checked against the model's symbols), the compiler flags the
conformance tests and benchmarks build with, and the header (.h) template.

Every operation is written so that C evaluates it exactly as the Python kernel does: the
same expression tree (the generators build both from the same syntax tree, left to right),
one IEEE double operation per +, -, *, /, sqrt, and x^n as repeated multiplication (see
`template._power`). `-ffp-contract=off` forbids fused multiply-adds, which would round once
where Python rounds twice; -ffast-math would reorder sums and must never be used."""

from __future__ import annotations

import re

from certiloop.kernel.extract.errors import ExtractError
from certiloop.models.lang.terms import BOOL, INT, REAL

CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off"]

C_KEYWORDS = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum",
    "extern", "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return",
    "short", "signed", "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void",
    "volatile", "while", "_Bool", "_Complex", "_Imaginary",
}
# libm and <stddef.h> names the generated code calls, and its own variables
C_RESERVED = C_KEYWORDS | {
    "sqrt", "isnan", "isfinite", "NAN", "INFINITY", "size_t", "NULL", "enabled", "taken", "skipped",
    "careful", "again", "blocked", "undecided", "fma", "nextafter",
    "i", "j", "pow", "fabs", "HUGE_VAL", "uint64_t",
}


def c_comment_text(text: str) -> str:
    """A model's name or description as it may stand inside a C comment: one printable line,
    no `*/` (which would end the comment) and no `??` (a trigraph under -std=c99)."""
    printable = "".join(ch if ch.isprintable() else " " for ch in text)
    return printable.replace("*/", "* /").replace("/*", "/ *").replace("??", "? ?")


def c_string_text(text: str) -> str:
    """The text as the body of a C string literal with the same UTF-8 bytes: quotes, backslashes
    and `?` (trigraphs) escaped, every other byte outside printable ASCII as an octal escape."""
    out = []
    for byte in text.encode("utf-8"):
        ch = chr(byte)
        if ch in '"\\?':
            out.append("\\" + ch)
        elif 32 <= byte < 127:
            out.append(ch)
        else:
            out.append(f"\\{byte:03o}")
    return "".join(out)


C_NAME_LENGTH = 48  # longer model names are cut, with a digest of the whole name kept apart


def c_name(model: str) -> str:
    """sbs.ctrl2 -> sbs_ctrl2: the prefix of every C symbol the model's kernel defines and the
    files' name, always an identifier (a leading digit gets `m_`) short enough for any file
    system (a long name is cut and ends in a digest of the whole name)."""
    import hashlib

    base = re.sub(r"[^0-9A-Za-z_]", "_", model)
    if base[:1].isdigit():
        base = "m_" + base
    if len(base) > C_NAME_LENGTH:
        digest = hashlib.sha256(model.encode()).hexdigest()[:10]
        base = f"{base[:C_NAME_LENGTH - 11]}_{digest}"
    return base


def c_type(sort) -> str:
    if sort == REAL:
        return "double"
    if sort == INT:
        return "long long"
    if sort == BOOL:
        return "int"
    raise ExtractError(f"values of sort {sort} have no C type here")


def c_element_type(sort) -> str:
    """The element type of a family or array passed by pointer (Bool: one byte, as numpy's bool)."""
    return "unsigned char" if sort == BOOL else c_type(sort)


_ASSIGNMENT = re.compile(r"^\s*(?:double |int |long long |unsigned char |cl_real )?(\w+) = [^;]*;"
                         r"(?: /\*.*\*/)?$")


def without_dead(lines: list[str], keep: set[str]) -> list[str]:
    """Drop assignments to locals nothing else reads (the helper values tmp and xtr once
    the gain is computed, as the Python generator does): they cannot change the result,
    and the compiler would warn that they are set but not used."""
    while True:
        targets = {}
        for n, text in enumerate(lines):
            m = _ASSIGNMENT.match(text)
            if m:
                targets.setdefault(m.group(1), []).append(n)
        dead = set()
        for name, rows in targets.items():
            if name in keep:
                continue
            pattern = re.compile(rf"\b{re.escape(name)}\b")
            used = any(pattern.search(_ASSIGNMENT.match(text).group(0).split("=", 1)[1]) if n in rows
                       else pattern.search(text) for n, text in enumerate(lines))
            if not used:
                dead.update(rows)
        if not dead:
            return lines
        lines = [text for n, text in enumerate(lines) if n not in dead]


def c_comment(text: str) -> str:
    return "/* " + c_comment_text(text) + " */"


def check_c_names(model: str, names) -> None:
    for name in names:
        prefixed = name.startswith(("__", "cl_", "CL_"))
        if name in C_RESERVED or prefixed or not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise ExtractError(f"{model}: the symbol `{name}` clashes with a name the generated C uses; "
                               "rename it to extract C")


HEADER_H = """\
/* Generated by `certiloop extract {model} --lang c` -- do not edit; re-extract instead.

   The verified {what} of `{model}` ({description}),
   {how}

   C99, no allocation, no globals, libm only. Build with
       cc {flags} -c {base}.c
   (-ffp-contract=off: no fused multiply-add, so every operation rounds as in the Python
   kernel; never -ffast-math). */
#ifndef CERTILOOP_{upper}_H
#define CERTILOOP_{upper}_H

#include <stddef.h>

#define {upper}_MODEL "{model_string}"
#define {upper}_MODEL_HASH "{hash}" /* the model's content hash when this code was extracted */
#define {upper}_INPUTS "{inputs}"
#define {upper}_FAMILIES "{families}"
#define {upper}_OUTPUTS "{outputs}"

{doc}
int {base}_controller({params});

#endif
"""
