"""The compiled virtual-fixture step: kernel/c (the C that `certiloop extract sbs.ctrl2
--lang c` generated, behind its C monitor) built once into a shared library and called
through cffi (ABI mode: no extension module to build; a call costs ~1 µs where ctypes takes
~4), so that `VirtualFixture.step` costs microseconds instead of hundreds of numpy calls.

Optional: `load()` returns None (and `why_not()` says why) when cffi is not installed (extra
certiloop[native]), there is no C compiler, the build fails, CERTILOOP_KERNEL=python is set,
or the C was extracted from another model version than kernel/ctrl2.py; the fixture then
runs its numpy path. The library is cached under $CERTILOOP_CACHE (default
~/.cache/certiloop) in a folder named by the hash of the sources and flags, so a changed
source is rebuilt, never mixed up. No numpy here.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

SOURCES = ("sbs_ctrl2.c", "sbs_ctrl2_fixture.c", "sbs_ctrl2_fixture_calls.c")
HEADERS = ("sbs_ctrl2.h", "sbs_ctrl2_fixture.h", "sbs_ctrl2_fixture_calls.h")
KERNEL_C = Path(__file__).resolve().parent / "c"
# the project's C flags (kernel.extract.c_syntax.CFLAGS; a test keeps the two equal)
FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2", "-ffp-contract=off"]

OK, UNDECIDED = 0, 9  # enum sbs_ctrl2_reason in sbs_ctrl2_fixture.h
# the declarations of sbs_ctrl2_fixture.h that Python calls (a test checks them against it)
CDEF = """
typedef struct { int has_previous; double p[3], f[3], fp[3], k; } sbs_ctrl2_memory;
int sbs_ctrl2_fixture_step(const double p[3], const double f[3], const double fp[3],
                           const double *rx, const double *ry, const double *rz,
                           const double *nx, const double *ny, const double *nz, size_t n,
                           double G, double D, double e, double dt, double position_tolerance,
                           sbs_ctrl2_memory *memory, double *k);
"""
# the declarations of sbs_ctrl2_fixture_calls.h (a test checks them against it): one context
# filled once, inputs by value, and a loop over many periods -- a call with few arguments
CDEF_CALLS = """
typedef struct {
    const double *rx, *ry, *rz, *nx, *ny, *nz;
    size_t n;
    double G, D, e, position_tolerance;
    sbs_ctrl2_memory memory;
    sbs_ctrl2_memory before;
    double k;
} sbs_ctrl2_fixture_context;
int sbs_ctrl2_fixture_step_values(sbs_ctrl2_fixture_context *c, double px, double py, double pz, double fx,
                                  double fy, double fz, double fpx, double fpy, double fpz, double dt);
size_t sbs_ctrl2_fixture_step_many(sbs_ctrl2_fixture_context *c, const double *inputs, size_t rows,
                                   const double *dt, size_t dt_stride, double *k, int *reason);
"""


class Native:
    """The loaded library: `step` is sbs_ctrl2_fixture_step, `step_values` and `step_many` those
    of sbs_ctrl2_fixture_calls.h; `doubles(address)` a C pointer to float64 data at an address (a
    numpy array's .ctypes.data; the caller keeps the array alive), `memory()` a fresh
    sbs_ctrl2_memory, `context()` a fresh sbs_ctrl2_fixture_context, `out()` a double to write
    into, `buffer(kind, array)` a C pointer into a numpy array's data (kept alive with it)."""

    def __init__(self, ffi, lib) -> None:
        self.ffi, self.lib = ffi, lib
        self.step = lib.sbs_ctrl2_fixture_step
        self.step_values = lib.sbs_ctrl2_fixture_step_values
        self.step_many = lib.sbs_ctrl2_fixture_step_many

    def doubles(self, address: int):
        return self.ffi.cast("double *", address)

    def memory(self):
        return self.ffi.new("sbs_ctrl2_memory *")

    def out(self):
        return self.ffi.new("double *")

    def context(self):
        return self.ffi.new("sbs_ctrl2_fixture_context *")

    def buffer(self, kind: str, array):
        return self.ffi.from_buffer(kind, array)


_state: dict = {}


def model_hash(header: str) -> str | None:
    m = re.search(r'^#define SBS_CTRL2_MODEL_HASH "([0-9a-f]+)"', header, re.MULTILINE)
    return m.group(1) if m else None


def why_not() -> str:
    """Why `load()` returned None ('' if it did not)."""
    load()
    return _state.get("why", "")


def load(expected_hash: str | None = None) -> Native | None:
    """The loaded C step, or None with the reason in `why_not()`.
    expected_hash: the model hash the Python kernel was extracted from; the C must match."""
    if "fn" not in _state:
        _state["fn"], _state["why"] = _load()
    fn = _state["fn"]
    if fn is not None and expected_hash is not None and _state["hash"] != expected_hash:
        return None
    return fn


def _load():
    if os.environ.get("CERTILOOP_KERNEL", "").lower() == "python":
        return None, "CERTILOOP_KERNEL=python"
    try:
        import cffi  # optional: the numpy path needs none of this
    except ImportError:
        return None, "cffi is not installed (pip install 'certiloop[native]')"
    try:
        texts = {name: (KERNEL_C / name).read_text() for name in SOURCES + HEADERS}
    except OSError as exc:
        return None, f"the C kernel sources are missing: {exc}"
    _state["hash"] = model_hash(texts["sbs_ctrl2.h"])
    digest = hashlib.sha256("\0".join([*FLAGS, *(texts[n] for n in sorted(texts))]).encode()).hexdigest()[:16]
    cache = Path(os.environ.get("CERTILOOP_CACHE", Path.home() / ".cache" / "certiloop"))
    library = cache / "native" / digest / "libsbs_ctrl2_fixture.so"
    if not library.exists():
        why = _build(texts, library)
        if why:
            return None, why
    ffi = cffi.FFI()
    ffi.cdef(CDEF)
    ffi.cdef(CDEF_CALLS)
    try:
        lib = ffi.dlopen(str(library))
    except OSError as exc:
        return None, f"cannot load {library}: {exc}"
    return Native(ffi, lib), ""


def _build(texts: dict[str, str], library: Path) -> str:
    """Compile into `library` (atomically: a half-written file is never loaded); '' or why not."""
    cc = next((shutil.which(n) for n in (os.environ.get("CC"), "cc", "gcc") if n and shutil.which(n)), None)
    if cc is None:
        return "no C compiler found (set CC, or install gcc)"
    try:
        library.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=library.parent) as tmp:
            for name, text in texts.items():
                (Path(tmp) / name).write_text(text)
            out = Path(tmp) / library.name
            done = subprocess.run([cc, *FLAGS, "-fPIC", "-shared", *SOURCES, "-o", str(out), "-lm"], cwd=tmp,
                                  capture_output=True, text=True, timeout=120)
            if done.returncode != 0 or done.stderr.strip():
                return f"the C kernel did not build: {done.stderr.strip().splitlines()[:1]}"
            os.replace(out, library)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"the C kernel did not build: {exc}"
    return ""
