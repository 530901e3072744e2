"""The compiled virtual-fixture step: generated/c (the C that `certiloop extract sbs.ctrl2
--lang c` generated, behind its C monitor) built once into a shared library and called
through cffi (ABI mode: no extension module to build; a call costs ~1 µs where ctypes takes
~4), so that `VirtualFixture.step` costs microseconds instead of hundreds of numpy calls.

Optional: `load()` returns None (and `why_not()` says why) when cffi is not installed (extra
certiloop[native]), there is no C compiler, the build fails, CERTILOOP_KERNEL=python is set,
or the C was extracted from another model version than studies/sbs/generated/ctrl2.py; the fixture then
runs its numpy path. The library is cached under $CERTILOOP_CACHE (default
~/.cache/certiloop) in a folder named by the hash of the sources and flags, so a changed
source is rebuilt, never mixed up. No numpy here.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import os
import re
import shutil
import subprocess
import sysconfig
import tempfile
from pathlib import Path

SOURCES = ("sbs_ctrl2.c", "sbs_ctrl2_fixture.c", "sbs_ctrl2_fixture_calls.c")
HEADERS = ("sbs_ctrl2.h", "sbs_ctrl2_fixture.h", "sbs_ctrl2_fixture_calls.h")
KERNEL_C = Path(__file__).resolve().parent / "generated" / "c"  # sbs_ctrl2.[ch], extracted from sbs.ctrl2
FIXTURE_C = Path(__file__).resolve().parent / "native_c"  # the hand-written fixture step around it
# the project's C flags (kernel.extract.c.syntax.CFLAGS; a test keeps the two equal)
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
        texts = {name: (FIXTURE_C if 'fixture' in name else KERNEL_C).joinpath(name).read_text()
                 for name in SOURCES + HEADERS}
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
    module = _extension(cffi, texts, library.parent)
    if module is not None:
        return Native(module.ffi, module.lib), ""
    ffi = cffi.FFI()
    ffi.cdef(CDEF)
    ffi.cdef(CDEF_CALLS)
    try:
        lib = ffi.dlopen(str(library))
    except OSError as exc:
        return None, f"cannot load {library}: {exc}"
    return Native(ffi, lib), ""


EXTENSION = "_certiloop_sbs_ctrl2"


def _extension(cffi, texts: dict[str, str], folder: Path):
    """The same C as a compiled cffi extension module (API mode: a call costs ~0.2 µs where the
    shared library through libffi takes ~1), built once beside the library; None where it cannot
    be built (no Python headers, no setuptools: the library then serves, and the failure is
    remembered so that it is not retried on every start)."""
    tag = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    path, failed = folder / f"{EXTENSION}{tag}", folder / f"{EXTENSION}{tag}.failed"
    if not path.exists() and not failed.exists():
        try:
            _build_extension(cffi, texts, path)
        except subprocess.TimeoutExpired:  # a busy machine: try again next time
            return None
        except Exception as exc:  # noqa: BLE001 (any build failure: the shared library serves)
            failed.write_text(f"{type(exc).__name__}: {exc}\n")
            return None
    if not path.exists():
        return None
    try:
        spec = importlib.util.spec_from_file_location(EXTENSION, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except ImportError:
        return None
    return module


def _build_extension(cffi, texts: dict[str, str], path: Path) -> None:
    """Our C compiled with the project's flags, the cffi glue around it with the compiler's
    defaults (it does no arithmetic); the module moved into place atomically."""
    cc = next((shutil.which(n) for n in (os.environ.get("CC"), "cc", "gcc") if n and shutil.which(n)), None)
    if cc is None:
        raise OSError("no C compiler")
    with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
        for name, text in texts.items():
            (Path(tmp) / name).write_text(text)
        objects = []
        for source in SOURCES:
            obj = str(Path(tmp) / (source[:-2] + ".o"))
            done = subprocess.run([cc, *FLAGS, "-fPIC", "-c", source, "-o", obj], cwd=tmp,
                                  capture_output=True, text=True, timeout=120)
            if done.returncode != 0:
                raise OSError(done.stderr.strip()[:200])
            objects.append(obj)
        ffi = cffi.FFI()
        ffi.cdef(CDEF)
        ffi.cdef(CDEF_CALLS)
        ffi.set_source(EXTENSION, '#include "sbs_ctrl2_fixture_calls.h"', include_dirs=[tmp],
                       extra_objects=objects, libraries=["m"])
        with open(os.devnull, "w") as quiet, contextlib.redirect_stdout(quiet), \
                contextlib.redirect_stderr(quiet):
            built = ffi.compile(tmpdir=tmp, verbose=False)
        os.replace(built, path)


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
