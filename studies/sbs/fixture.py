"""The virtual-fixture kernel: the verified ctrl2 controller, ready to call every period.

    fixture = VirtualFixture([(point, normal), ...], gain=G, buffer=D, period=eps)
    k, velocity = fixture.step(p, f, fp)      # velocity = G * k * f
    steps = fixture.step_many(rows)           # rows (T, 9): p, f, fp per period; steps.k, .velocity, .ok

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

The compiled step costs the C's work plus one call: planes, parameters and memory sit in a C
context filled when they change, the inputs go by value (no array is converted), and the
command's velocity and distances are built when first read. `step_many` runs a simulation's
periods in one C loop.
"""

from __future__ import annotations

from typing import Callable, Iterable, Sequence

import numpy as np

from certiloop.studies.sbs import monitor, native
from certiloop.studies.sbs.generated import ctrl2

ROUNDING = 1e-12  # a negative k above -ROUNDING: a tool past a plane by rounding only


class Command:
    """k, the velocity G k f, ok (False: the fallback was commanded), the reason of a
    fallback, and the distances d0 to the planes. The compiled step gives their factors
    instead (G k, f, p and the planes), and they are built when first read: a control loop
    that reads k only pays for no array."""

    __slots__ = ("k", "_velocity", "ok", "reason", "_distances", "_factors")

    def __init__(self, k: float, velocity: np.ndarray | None, ok: bool = True, reason: str = "",
                 distances: np.ndarray | Callable[[], np.ndarray] | None = None,
                 factors: tuple | None = None) -> None:
        """factors: (G k, f, p, points, normals), for a velocity or distances given as None."""
        self.k, self._velocity, self.ok, self.reason = k, velocity, ok, reason
        self._distances, self._factors = distances, factors

    @property
    def velocity(self) -> np.ndarray:
        v = self._velocity
        if v is None:  # multiplied as the numpy path does: (G * k) * f
            gk, f = self._factors[0], self._factors[1]
            try:
                v = np.array((gk * f[0], gk * f[1], gk * f[2]), dtype=float)
            except TypeError:  # a number type float does not multiply (it converts, as numpy does)
                v = gk * np.asarray(f, dtype=float)
            self._velocity = v
        return v

    @property
    def distances(self) -> np.ndarray:
        d = self._distances
        if d is None:
            if self._factors is None:
                return _NO_PLANES
            p, r, n = self._factors[2:]
            d = self._distances = np.einsum("ij,ij->i", np.asarray(p, dtype=float) - r, n)
        elif callable(d):
            d = self._distances = d()
        return d

    def __iter__(self):  # k, velocity = fixture.step(...)
        return iter((self.k, self.velocity))

    def __repr__(self) -> str:
        return (f"Command(k={self.k!r}, velocity={self.velocity!r}, ok={self.ok!r}, "
                f"reason={self.reason!r})")


_NO_PLANES = np.zeros(0)
_NO_PLANES.flags.writeable = False


class Steps:
    """What `VirtualFixture.step_many` commanded over T periods: gains k (T,), velocities
    (T, 3), ok (T,) and the reason of each fallback ('' where none)."""

    __slots__ = ("k", "velocity", "ok", "reasons")

    def __init__(self, k: np.ndarray, velocity: np.ndarray, ok: np.ndarray, reasons: list[str]) -> None:
        self.k, self.velocity, self.ok, self.reasons = k, velocity, ok, reasons

    def __len__(self) -> int:
        return len(self.k)


class _Parameter:
    """gain, buffer, period, position_tolerance: the compiled step's context holds a copy, which
    setting one updates (as when each call passed them)."""

    def __set_name__(self, owner, name: str) -> None:
        self.name, self.slot = name, "_" + name
        self.field = {"gain": "G", "buffer": "D", "period": "e"}.get(name, name)

    def __get__(self, fixture, owner=None):
        return self if fixture is None else getattr(fixture, self.slot)

    def __set__(self, fixture, value) -> None:
        setattr(fixture, self.slot, value)
        context = fixture.__dict__.get("_context")
        if context is not None:
            setattr(context, self.field, value)


class VirtualFixture:
    """Forbidden-region virtual fixture over a set of planes, each given by a point on it
    and its unit normal pointing to the safe side."""

    gain, buffer, period, position_tolerance = _Parameter(), _Parameter(), _Parameter(), _Parameter()

    def __init__(self, planes: Iterable[tuple[Sequence[float], Sequence[float]]] = (), *, gain: float,
                 buffer: float, period: float, check_model: bool = True,
                 position_tolerance: float = 1e-6, backend: str = "auto") -> None:
        if backend not in ("auto", "c", "python"):
            raise ValueError(f"backend must be 'auto', 'c' or 'python', got {backend!r}")
        self._gain, self._buffer, self._period = float(gain), float(buffer), float(period)
        self._position_tolerance = position_tolerance
        self._ids: list[int] = []
        self._points = np.zeros((0, 3))
        self._normals = np.zeros((0, 3))
        self._next_id = 0
        # the last passed step's (p, f, fp, k), for the plant monitor; after a compiled step it
        # is the C context's memory instead (read on demand by `_previous`)
        self._last = None
        self._last_position = None
        self._memory_in_c = False
        if check_model:
            _check_extracted()
        self._native = None if backend == "python" else native.load(ctrl2.MODEL_HASH)
        if backend == "c" and self._native is None:
            raise ValueError(f"backend='c' is not available: {native.why_not() or 'model hash differs'}")
        if self._native is not None:
            # one context the C step reads everything from but the inputs: filled here and
            # whenever the planes change, so a step passes ten floats and nothing is converted
            self._context = self._native.context()
            self._call = self._native.step_values
            self._reason = self._native.ffi.new("int *")
        self._memory_stale = False  # the numpy path ran last: copy its memory before calling C
        self._columns()
        for point, normal in planes:
            self._append(point, normal)

    @property
    def _previous(self):
        """(p, f, fp, k) of the last passed step, or None (the numpy path's view of the memory)."""
        if self._memory_in_c:
            self._last, self._last_position = _memory_tuple(self._context.memory)
            self._memory_in_c = False
        return self._last

    @_previous.setter
    def _previous(self, value) -> None:
        self._memory_in_c, self._last = False, value

    @property
    def _position(self):
        self._previous  # noqa: B018 (brings the C memory over)
        return self._last_position

    @_position.setter
    def _position(self, value) -> None:
        self._previous  # noqa: B018
        self._last_position = value

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
            c = self._context
            c.rx, c.ry, c.rz, c.nx, c.ny, c.nz = (self._native.doubles(col.ctypes.data) for col in self._cols)
            c.n = len(self._ids)
            c.G, c.D, c.e = self._gain, self._buffer, self._period
            c.position_tolerance = self._position_tolerance

    # ------------------------------------------------------------------ the control step
    def step(self, p, f, fp, dt: float | None = None) -> Command:
        """Gain and commanded velocity for tool position p, surgeon force f and its rate fp.
        dt: time since the previous step (default: the period ε) for the motion check."""
        if self._native is not None:
            if self._memory_stale:
                self._sync_memory()
            try:  # three numbers each, passed to C by value (an array's as a list: no numpy scalars)
                px, py, pz = p.tolist() if type(p) is _ARRAY else p
                fx, fy, fz = f.tolist() if type(f) is _ARRAY else f
                fpx, fpy, fpz = fp.tolist() if type(fp) is _ARRAY else fp
                reason = self._call(self._context, px, py, pz, fx, fy, fz, fpx, fpy, fpz,
                                    self._period if dt is None else dt)
            except Exception:  # noqa: BLE001 (anything else: converted as numpy converts it, or refused)
                values = _three_each(p, f, fp)
                reason = None
                if values is not None:
                    (px, py, pz), (fx, fy, fz), (fpx, fpy, fpz) = values
                    reason = self._call(self._context, px, py, pz, fx, fy, fz, fpx, fpy, fpz,
                                        self._period if dt is None else dt)
            if reason == 0:  # native.OK
                self._memory_in_c = True
                k = self._context.k
                return Command(k, None, True, "", None,
                               (self._gain * k, (fx, fy, fz), (px, py, pz), self._points, self._normals))
            if reason is not None:
                self._take_memory_before()
        self._memory_stale = True  # whatever the numpy path keeps, C must start from it
        return self._step_python(p, f, fp, dt)

    def step_many(self, inputs, dt=None) -> Steps:
        """`step` over T periods in one call: inputs (T, 9), each row p, f, fp; dt None (the
        period), one number, or T numbers. The same commands, fallbacks and memory as T calls
        of `step` (the compiled loop hands any step it does not pass to the numpy path)."""
        rows = _rows(inputs)
        count = len(rows)
        dts = _dts(dt, self.period, count)
        k, ok, reasons = np.zeros(count), np.ones(count, dtype=bool), [""] * count
        i = 0
        while i < count:
            if self._native is not None:
                if self._memory_stale:
                    self._sync_memory()
                buffer = self._native.buffer
                stride = 0 if len(dts) == 1 and count > 1 else 1
                passed = self._native.step_many(self._context, buffer("double[]", rows[i:]), count - i,
                                                buffer("double[]", dts[i * stride:]), stride,
                                                buffer("double[]", k[i:]), self._reason)
                if passed:
                    self._memory_in_c = True
                i += passed
                if i == count:
                    break
                self._take_memory_before()
            row = rows[i]
            self._memory_stale = True
            command = self._step_python(row[0:3].copy(), row[3:6].copy(), row[6:9].copy(),
                                        float(dts[i if len(dts) > 1 else 0]))
            k[i], ok[i], reasons[i] = command.k, command.ok, command.reason
            i += 1
        velocity = (self.gain * k)[:, None] * rows[:, 3:6]
        velocity[~ok] = 0.0  # the fallback commands zero velocity, whatever the force
        return Steps(k, velocity, ok, reasons)

    def _take_memory_before(self) -> None:
        """C did not pass the step: its memory before it is the numpy path's starting point."""
        if self._memory_in_c:
            self._last, self._last_position = _memory_tuple(self._context.before)
            self._memory_in_c = False

    def _sync_memory(self) -> None:
        m = self._context.memory
        previous = self._previous
        m.has_previous = previous is not None
        if previous is not None:
            p, f, fp, k = previous
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


_ARRAY = np.ndarray


def _three_each(p, f, fp) -> list[list[float]] | None:
    """p, f, fp as numpy reads them (any shape of three numbers), or None where they are not."""
    try:
        arrays = [np.asarray(x, dtype=float).reshape(-1) for x in (p, f, fp)]
    except (TypeError, ValueError):
        return None
    if any(a.shape != (3,) for a in arrays):
        return None
    return [a.tolist() for a in arrays]


def _memory_tuple(m) -> tuple:
    """((p, f, fp, k), p) from a C memory, or (None, None) where it has no previous step."""
    if not m.has_previous:
        return None, None
    p = np.array(list(m.p))
    return (p, np.array(list(m.f)), np.array(list(m.fp)), m.k), p


def _rows(inputs) -> np.ndarray:
    try:
        rows = np.ascontiguousarray(inputs, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"step_many: inputs must be numbers, (T, 9) rows of p, f, fp: {exc}") from None
    if rows.ndim != 2 or rows.shape[1] != 9:
        raise ValueError(f"step_many: inputs must have shape (T, 9) (rows of p, f, fp), got {rows.shape}")
    return rows


def _dts(dt, period: float, count: int) -> np.ndarray:
    dts = np.ascontiguousarray(period if dt is None else dt, dtype=float).reshape(-1)
    if len(dts) not in (1, count):
        raise ValueError(f"step_many: dt must be one number or one per row ({count}), got {len(dts)}")
    return dts


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
                           f"{ctrl2.MODEL_HASH}, now {current}); run "
                           "`python -m certiloop.studies regenerate`")
    _checked = True
