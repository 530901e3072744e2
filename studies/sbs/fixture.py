"""The virtual-fixture kernel: the verified ctrl2 controller, ready to call every period.

    fixture = VirtualFixture([(point, normal), ...], gain=G, buffer=D, period=eps)
    k, velocity = fixture.step(p, f, fp)      # velocity = G * k * f

The gain comes from `ctrl2.py`, the code `certiloop extract sbs.ctrl2` generated from the
proved model; a runtime monitor (monitor.py) checks inputs, command and measured motion
and commands the safe fallback k = 0 whenever something is off. Never NaN, never an
unchecked command. Imports numpy only.

Two back ends run the same step. backend="c" (the default "auto" picks it when a C compiler
is present, see native.py) calls kernel/c, the C the extractor generated from the same model
(hash-checked) behind the C version of the monitor: microseconds per step. Any step the C
does not pass -- a fallback, or a near-tie its floats cannot decide -- is run again by the
numpy path (backend="python"), which decides near-ties exactly and gives the reason, so the
C only ever adds speed: what it commands is a gain its own certified controller and monitor
accepted, and everything else is the numpy kernel's answer.
"""

from __future__ import annotations

from typing import Callable, Iterable, Sequence

import numpy as np

from certiloop.studies.sbs import monitor, native
from certiloop.studies.sbs.generated import ctrl2

ROUNDING = 1e-12  # a negative k above -ROUNDING: a tool past a plane by rounding only


class Command:
    """k, the velocity G k f, ok (False: the fallback was commanded), the reason of a
    fallback, and the distances d0 to the planes (computed when first read: the compiled
    step does not need them)."""

    __slots__ = ("k", "velocity", "ok", "reason", "_distances")

    def __init__(self, k: float, velocity: np.ndarray, ok: bool = True, reason: str = "",
                 distances: np.ndarray | Callable[[], np.ndarray] | None = None) -> None:
        self.k, self.velocity, self.ok, self.reason = k, velocity, ok, reason
        self._distances = np.zeros(0) if distances is None else distances

    @property
    def distances(self) -> np.ndarray:
        if callable(self._distances):
            self._distances = self._distances()
        return self._distances

    def __iter__(self):  # k, velocity = fixture.step(...)
        return iter((self.k, self.velocity))

    def __repr__(self) -> str:
        return f"Command(k={self.k!r}, velocity={self.velocity!r}, ok={self.ok!r}, reason={self.reason!r})"


class VirtualFixture:
    """Forbidden-region virtual fixture over a set of planes, each given by a point on it
    and its unit normal pointing to the safe side."""

    def __init__(self, planes: Iterable[tuple[Sequence[float], Sequence[float]]] = (), *, gain: float,
                 buffer: float, period: float, check_model: bool = True,
                 position_tolerance: float = 1e-6, backend: str = "auto") -> None:
        if backend not in ("auto", "c", "python"):
            raise ValueError(f"backend must be 'auto', 'c' or 'python', got {backend!r}")
        self.gain, self.buffer, self.period = float(gain), float(buffer), float(period)
        self.position_tolerance = position_tolerance
        self._ids: list[int] = []
        self._points = np.zeros((0, 3))
        self._normals = np.zeros((0, 3))
        self._next_id = 0
        self._previous = None  # (p, f, fp, k) of the last step, for the plant monitor
        self._position = None
        if check_model:
            _check_extracted()
        self._native = None if backend == "python" else native.load(ctrl2.MODEL_HASH)
        if backend == "c" and self._native is None:
            raise ValueError(f"backend='c' is not available: {native.why_not() or 'model hash differs'}")
        if self._native is not None:
            self._memory, self._k = self._native.memory(), self._native.out()
            self._inputs = np.zeros(9)  # p, f, fp as C reads them
            self._input_ptrs = [self._native.doubles(self._inputs.ctypes.data + 24 * j) for j in range(3)]
        self._memory_stale = False  # the numpy path ran last: copy its memory before calling C
        self._columns()
        for point, normal in planes:
            self._append(point, normal)

    # ------------------------------------------------------------------ planes
    @property
    def backend(self) -> str:
        """'c' or 'python': which step runs first."""
        return "python" if self._native is None else "c"

    @property
    def planes(self) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        return {i: (p.copy(), n.copy()) for i, p, n in zip(self._ids, self._points, self._normals)}

    def add_plane(self, point, normal, tool=None) -> int:
        """Add a boundary between steps; only when the tool (its last position, or `tool`)
        is on the plane's safe side, as the dynamic model requires. Returns its id."""
        where = self._position if tool is None else _vector(tool, "tool position")
        if where is None:
            raise ValueError("add_plane: the tool position is unknown; pass tool=(x, y, z)")
        pt, n = _vector(point, "plane point"), _unit(normal)
        if float(np.dot(where - pt, n)) < 0:
            raise ValueError("add_plane: the tool is on the forbidden side of this plane")
        return self._append(pt, n)

    def remove_plane(self, plane_id: int) -> None:
        """Remove a boundary (allowed at any step)."""
        if plane_id not in self._ids:
            raise KeyError(f"no plane with id {plane_id}")
        keep = [j for j, i in enumerate(self._ids) if i != plane_id]
        self._ids = [self._ids[j] for j in keep]
        self._points, self._normals = self._points[keep], self._normals[keep]
        self._columns()

    def _append(self, point, normal) -> int:
        pt, n = _vector(point, "plane point"), _unit(normal)
        self._points = np.vstack([self._points, pt])
        self._normals = np.vstack([self._normals, n])
        self._ids.append(self._next_id)
        self._next_id += 1
        self._columns()
        return self._ids[-1]

    def _columns(self) -> None:
        """The planes as C wants them: rx, ry, rz, nx, ny, nz, each contiguous."""
        self._cols = [np.ascontiguousarray(a[:, j]) for a in (self._points, self._normals) for j in range(3)]
        if self._native is not None:
            self._col_ptrs = [self._native.doubles(c.ctypes.data) for c in self._cols]

    # ------------------------------------------------------------------ the control step
    def step(self, p, f, fp, dt: float | None = None) -> Command:
        """Gain and commanded velocity for tool position p, surgeon force f and its rate fp.
        dt: time since the previous step (default: the period ε) for the motion check."""
        if self._native is not None:
            command = self._step_c(p, f, fp, dt)
            if command is not None:
                return command
        self._memory_stale = True  # whatever the numpy path keeps, C must start from it
        return self._step_python(p, f, fp, dt)

    def _step_c(self, p, f, fp, dt) -> Command | None:
        """The compiled step; None where it did not pass (the numpy path then decides)."""
        try:
            p, f, fp = (np.asarray(x, dtype=float).reshape(-1) for x in (p, f, fp))
        except (TypeError, ValueError):
            return None
        if p.shape != (3,) or f.shape != (3,) or fp.shape != (3,):
            return None
        inputs = self._inputs
        inputs[0:3], inputs[3:6], inputs[6:9] = p, f, fp
        if self._memory_stale:
            self._sync_memory()
        reason = self._native.step(*self._input_ptrs, *self._col_ptrs, len(self._ids), self.gain, self.buffer,
                                   self.period, self.period if dt is None else dt, self.position_tolerance,
                                   self._memory, self._k)
        if reason != native.OK:
            self._memory_stale = True  # C fell back; the numpy path's verdict and memory count
            return None
        k = self._k[0]
        self._previous, self._position = (p, f, fp, k), p
        r, n = self._points, self._normals
        return Command(k, self.gain * k * f, True, "", lambda: np.einsum("ij,ij->i", p - r, n))

    def _sync_memory(self) -> None:
        m = self._memory
        m.has_previous = self._previous is not None
        if self._previous is not None:
            p, f, fp, k = self._previous
            m.p, m.f, m.fp, m.k = list(map(float, p)), list(map(float, f)), list(map(float, fp)), k
        self._memory_stale = False

    def _step_python(self, p, f, fp, dt) -> Command:
        try:
            p, f, fp = (np.asarray(x, dtype=float).reshape(-1) for x in (p, f, fp))
        except (TypeError, ValueError) as exc:
            return self._fallback(f"inputs are not numbers: {exc}")
        verdict = monitor.check_inputs(p, f, fp, self._normals, self._points, self.gain, self.buffer,
                                       self.period)
        if verdict.ok:
            verdict = monitor.check_motion(self._previous, p, self.gain,
                                           self.period if dt is None else dt, self.position_tolerance)
        if not verdict.ok:
            return self._fallback(verdict.reason, p)
        n, r = self._normals, self._points
        k, enabled = ctrl2.controller(*p, *fp, *f, self.buffer, self.period, self.gain,
                                      r[:, 0], n[:, 0], r[:, 1], n[:, 1], r[:, 2], n[:, 2])
        k = float(k)  # the real model's gain rounded down (ctrl2.py decides every case exactly)
        if -ROUNDING <= k < 0:
            # a tool past a plane by rounding (d0 = -1e-17, within the input check's tolerance)
            # is outside the model's invariant, and its k = -d0·tmp is a tiny negative number:
            # command 0 (a lower gain is always allowed; k = 0 stops the tool)
            k = 0.0
        if not enabled:
            return self._fallback("the verified controller has no enabled case for this state", p)
        d0 = np.einsum("ij,ij->i", p - r, n)
        verdict = monitor.check_command(k, d0, n @ f, n @ fp, self.gain, self.period)
        if not verdict.ok:
            return self._fallback(verdict.reason, p)
        self._previous, self._position = (p, f, fp, k), p
        return Command(k, self.gain * k * f, True, "", d0)

    def _fallback(self, reason: str, p=None) -> Command:
        """k = 0: the tool stops where it is, which no boundary can object to."""
        if p is not None and p.shape == (3,) and np.all(np.isfinite(p)):
            self._previous, self._position = (p, np.zeros(3), np.zeros(3), 0.0), p
        else:
            self._previous = None
        return Command(0.0, np.zeros(3), False, reason)


def _vector(x, what: str) -> np.ndarray:
    v = np.asarray(x, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be three finite numbers, got {x!r}")
    return v


def _unit(normal) -> np.ndarray:
    n = _vector(normal, "plane normal")
    length = float(np.linalg.norm(n))
    if length == 0:
        raise ValueError("a plane normal must not be zero")
    if abs(length - 1.0) > monitor.UNIT_TOLERANCE:
        raise ValueError(f"a plane normal must have length 1, got {length:.6g}")
    # kept as given, however tiny a component: the controller decides near-ties exactly
    return n / np.linalg.norm(n)


_checked = False


def _check_extracted() -> None:
    """Refuse to run code extracted from a model that has changed since."""
    global _checked
    if _checked:
        return
    from certiloop.models import library

    current = library.get(ctrl2.MODEL).content_hash
    if current != ctrl2.MODEL_HASH:
        raise RuntimeError(f"studies/sbs/generated/ctrl2.py was extracted from an older {ctrl2.MODEL} (hash "
                           f"{ctrl2.MODEL_HASH}, now {current}); run `certiloop extract {ctrl2.MODEL} "
                           "-o studies/sbs/generated/ctrl2.py`")
    _checked = True
