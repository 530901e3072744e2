"""Building and calling an extracted C kernel from Python (tooling for the conformance tests
and the benchmarks; the runtime never needs it): `compiler()` finds the system C compiler,
`build(files, folder)` writes and compiles the kernel into a shared library with the project's
flags (warnings are errors), and `load(...)` wraps its entry function with ctypes so that it
is called like the Python kernel's `controller(*INPUTS, *FAMILIES)` and returns
`(*outputs, enabled)`."""

from __future__ import annotations

import ctypes
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

from certiloop.kernel.extract.c.syntax import CFLAGS


class BuildError(RuntimeError):
    """The compiler rejected the generated C (a warning counts: -Werror)."""


def compiler() -> str | None:
    """The C compiler to use: $CC, else cc or gcc on the PATH; None if there is none."""
    for name in (os.environ.get("CC"), "cc", "gcc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def build(files: dict[str, str], folder: Path, extra: list[str] = ()) -> Path:
    """Write the kernel's files into `folder` and compile the .c into a shared library;
    returns its path. Raises BuildError with the compiler's messages."""
    cc = compiler()
    if cc is None:
        raise BuildError("no C compiler found (set CC, or install gcc)")
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text)
    source = next(name for name in files if name.endswith(".c"))
    library = folder / (source[:-2] + ".so")
    command = [cc, *CFLAGS, "-fPIC", "-shared", *extra, source, "-o", library.name, "-lm"]
    done = subprocess.run(command, cwd=folder, capture_output=True, text=True)
    if done.returncode != 0 or done.stderr.strip():
        raise BuildError(f"{' '.join(command)}:\n{done.stderr}")
    return library


_CTYPES = {"double": ctypes.c_double, "long long": ctypes.c_longlong, "int": ctypes.c_int}
_DTYPES = {"double": np.float64, "long long": np.int64, "int": np.intc, "unsigned char": np.uint8}


class Kernel:
    """An extracted C kernel loaded with ctypes, called like the Python kernel."""

    def __init__(self, library: Path, header: str) -> None:
        m = re.search(r"^int (\w+)_controller\((.*)\);$", header, re.MULTILINE)
        if m is None:
            raise BuildError("no controller prototype in the header")
        self.base = m.group(1)
        self.library = library
        self.params = [_param(p) for p in m.group(2).split(", ")]
        self.lib = ctypes.CDLL(str(library))
        self.fn = getattr(self.lib, f"{self.base}_controller")
        self.fn.restype = ctypes.c_int
        self.fn.argtypes = [_CTYPES[c] if kind == "scalar" else ctypes.c_size_t if kind == "size"
                            else ctypes.c_void_p for kind, c, _ in self.params]
        upper = self.base.upper()
        macros = dict(re.findall(r'^#define (\w+) "([^"]*)"', header, re.MULTILINE))
        self.model, self.model_hash = macros[f"{upper}_MODEL"], macros[f"{upper}_MODEL_HASH"]
        self.inputs = macros[f"{upper}_INPUTS"].split()
        self.families = macros[f"{upper}_FAMILIES"].split()
        self.outputs = macros[f"{upper}_OUTPUTS"].split()

    def __call__(self, *args):
        """controller(*INPUTS, *FAMILIES) -> (*outputs, enabled), as the Python kernel; after
        the call, `undecided` says whether enabled is False because the C could not decide
        (return code -1) rather than because the model has no run (0)."""
        given = dict(zip(self.inputs + self.families, args))
        if len(given) != len(args) or len(args) != len(self.inputs) + len(self.families):
            raise TypeError(f"{self.base}_controller takes {self.inputs + self.families}")
        length = len(np.atleast_1d(given[self.families[0]])) if self.families else 0
        # in the prototype's order, which is INPUTS then FAMILIES (a C parameter may be renamed)
        scalars, families = iter(args[:len(self.inputs)]), iter(args[len(self.inputs):])
        call, keep, outs = [], [], []
        for kind, ctype, name in self.params:
            if kind == "scalar":
                call.append(next(scalars))
            elif kind == "family":
                a = np.ascontiguousarray(next(families), dtype=_DTYPES[ctype])
                if a.shape != (length,):
                    raise ValueError(f"family {name} has shape {a.shape}, expected ({length},)")
                keep.append(a)
                call.append(a.ctypes.data)
            elif kind == "size":
                call.append(length)
            else:  # an output: a one-element array for a scalar, else a whole family
                a = np.zeros(1 if ctype in _CTYPES else length, dtype=_DTYPES.get(ctype, np.int32))
                outs.append((ctype in _CTYPES, a))
                call.append(a.ctypes.data)
        rc = self.fn(*call)
        self.undecided = rc < 0  # a near-tie the floats could not decide: the caller falls back
        enabled = rc == 1
        values = [a[0].item() if scalar else a.astype(bool) if a.dtype == np.uint8 else a
                  for scalar, a in outs]
        return (*values, enabled)


def _param(text: str) -> tuple[str, str, str]:
    """('scalar' | 'family' | 'size' | 'out', C element type, name) of one parameter."""
    text = text.strip()
    if text.startswith("size_t "):
        return "size", "size_t", text.split()[-1]
    if text.startswith("const "):
        ctype, name = text[len("const "):].rsplit(" *", 1)
        return "family", ctype, name
    if " *" in text:
        ctype, name = text.rsplit(" *", 1)
        return "out", ctype, name
    ctype, name = text.rsplit(" ", 1)
    return "scalar", ctype, name


def load(files: dict[str, str], folder: Path) -> Kernel:
    """Build the kernel in `folder` and load it."""
    library = build(files, folder)
    header = next(text for name, text in files.items() if name.endswith(".h"))
    return Kernel(library, header)
