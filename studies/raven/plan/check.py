"""Re-check a planned path's certificate independently (mpmath intervals over the DH chain).

What is checked, for one run of a `certiloop plan` JSON file:

* the path starts at the scene's start and ends at its goal (exact float equality), and its
  certificate has one entry per segment whose breakpoints rise from 0 to 1 (exact fractions);
* on every piece [t0, t1] of every segment, the joint box qa + [t0, t1] (qb - qa) lies in the
  scene's joint limits, and for every clause some plane has n·wrist - c - margin >= 0 and
  n·tip - c - margin >= 0 over the whole box. The wrist (frame 5) and the tip (frame 6) are
  enclosed by applying the six Craig link transforms Rot_x(alpha) Trans_x(a) Rot_z(theta)
  Trans_z(d) to the frame origin in mpmath's interval arithmetic, from the DH table written
  out below in exact degrees and millimetres. A piece that fails is halved up to
  CHECK_DEPTH times before the segment is declared bad (a deterministic budget);
* the planes, margin and joint limits are those of the library scene the file names
  (checked last, so that a certificate against altered planes still names its bad segment).

Nothing here comes from the planner's own proof (`certify.py`: numpy floats with outward
rounding over a closed-form reduction of the same chain): only the certificate's pieces,
which just say where to look.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

CHECK_DEPTH = 4
PRECISION = 64  # bits

# The Raven-II DH table (CSLDepend/raven2_sim r2_kinematics): alpha in degrees, a and d in mm.
_ALPHA_DEG = {"left": (0, 75, 128, 0, 90, 90), "right": (180, 75, 52, 0, 90, 90)}
_A_MM = (0, 0, 0, 0, 0, 13)
_D4_MM = -470
_THETA3_DEG = {"left": 90, "right": -90}


@dataclass
class CheckResult:
    ok: bool
    bad_segment: int | None = None  # index of the first bad segment
    reason: str = ""
    pieces: int = 0


def _iv():
    from mpmath import iv

    iv.prec = PRECISION
    return iv


def _exact(iv, value):
    """An exact interval for a float or a fraction string (dyadic or not: rounded outward)."""
    if isinstance(value, str):
        f = Fraction(value)
        return iv.mpf(f.numerator) / iv.mpf(f.denominator)
    return iv.mpf(float(value))


def _link_apply(iv, p, alpha, a, ct, st, d):
    """Rot_x(alpha) Trans_x(a) Rot_z(theta) Trans_z(d) applied to the point p."""
    x, y, z = p[0], p[1], p[2] + d
    x, y = ct * x - st * y, st * x + ct * y
    x = x + a
    ca, sa = alpha
    return (x, ca * y - sa * z, sa * y + ca * z)


def enclose(iv, qbox, arm: str):
    """Interval enclosures of the wrist (frame 5 origin) and tip (frame 6 origin)."""
    alphas = [iv.pi * k / 180 for k in _ALPHA_DEG[arm]]
    alpha = [(iv.cos(al), iv.sin(al)) for al in alphas]
    theta3 = iv.pi * _THETA3_DEG[arm] / 180
    thetas = [qbox[0], qbox[1], theta3, qbox[3], qbox[4], qbox[5]]
    trig = [(iv.cos(t), iv.sin(t)) for t in thetas]
    ds = [iv.mpf(0), iv.mpf(0), qbox[2], iv.mpf(_D4_MM) / 1000, iv.mpf(0), iv.mpf(0)]
    a = [iv.mpf(v) / 1000 for v in _A_MM]
    zero = (iv.mpf(0), iv.mpf(0), iv.mpf(0))

    def frame_origin(last: int):
        p = zero
        for i in range(last, -1, -1):
            p = _link_apply(iv, p, alpha[i], a[i], trig[i][0], trig[i][1], ds[i])
        return p

    return frame_origin(4), frame_origin(5)


def _piece_clear(iv, scene: dict, qa, qb, t0, t1) -> bool:
    t = iv.mpf([t0.a, t1.b]) if hasattr(t0, "a") else iv.mpf([t0, t1])
    qbox = [qa[j] + t * (qb[j] - qa[j]) for j in range(6)]
    for j in range(6):
        lo, hi = _exact(iv, scene["joint_lo"][j]), _exact(iv, scene["joint_hi"][j])
        if not (qbox[j].a >= lo.b and qbox[j].b <= hi.a):
            return False
    wrist, tip = enclose(iv, qbox, scene["arm"])
    margin = _exact(iv, scene["margin"])
    for clause in scene["clauses"]:
        held = False
        for plane in clause:
            n = [_exact(iv, v) for v in plane["normal"]]
            c = _exact(iv, plane["offset"])
            if all((n[0] * p[0] + n[1] * p[1] + n[2] * p[2] - c - margin).a >= 0 for p in (wrist, tip)):
                held = True
                break
        if not held:
            return False
    return True


def _segment_clear(iv, scene, qa, qb, t0, t1, depth: int, counter: list) -> bool:
    counter[0] += 1
    if _piece_clear(iv, scene, qa, qb, t0, t1):
        return True
    if depth == 0:
        return False
    mid = (t0 + t1) / 2
    return (_segment_clear(iv, scene, qa, qb, t0, mid, depth - 1, counter)
            and _segment_clear(iv, scene, qa, qb, mid, t1, depth - 1, counter))


def check_run(run: dict, library_scenes: dict | None = None) -> CheckResult:
    """Check one run's path and certificate. Raises ValueError on a malformed document."""
    iv = _iv()
    cert = run.get("certificate")
    if not isinstance(cert, dict) or "scene" not in cert or "segments" not in cert:
        raise ValueError("the run has no certificate (with 'scene' and 'segments')")
    scene, segments, waypoints = cert["scene"], cert["segments"], run.get("waypoints")
    if not isinstance(waypoints, list) or len(waypoints) < 2 or any(len(w) != 6 for w in waypoints):
        raise ValueError("'waypoints' must be a list of at least two 6-joint configurations")
    if [float(v) for v in waypoints[0]] != [float(v) for v in scene["start"]]:
        return CheckResult(False, 0, "the path does not begin at the scene's start")
    if [float(v) for v in waypoints[-1]] != [float(v) for v in scene["goal"]]:
        return CheckResult(False, len(waypoints) - 2, "the path does not end at the scene's goal")
    if len(segments) != len(waypoints) - 1:
        return CheckResult(False, None, f"{len(segments)} certified segments for a path of "
                                        f"{len(waypoints) - 1}")
    counter = [0]
    for i, seg in enumerate(segments):
        pieces = seg.get("pieces") if isinstance(seg, dict) else None
        if not isinstance(pieces, list) or len(pieces) < 2:
            raise ValueError(f"segment {i}: 'pieces' must list at least two breakpoints, from 0 to 1 "
                             f"(got {pieces!r})")
        points = [Fraction(p) for p in pieces]
        if points[0] != 0 or points[-1] != 1 or any(b <= a for a, b in zip(points, points[1:])):
            return CheckResult(False, i, f"segment {i}: breakpoints must rise from 0 to 1",
                               counter[0])
        qa = [_exact(iv, v) for v in waypoints[i]]
        qb = [_exact(iv, v) for v in waypoints[i + 1]]
        for a, b in zip(seg["pieces"], seg["pieces"][1:]):
            t0, t1 = _exact(iv, a), _exact(iv, b)
            if not _segment_clear(iv, scene, qa, qb, t0, t1, CHECK_DEPTH, counter):
                return CheckResult(False, i, f"segment {i} (waypoint {i} -> {i + 1}): piece [{a}, {b}] "
                                             "is not proved clear", counter[0])
    if library_scenes is not None:
        known = library_scenes.get(scene.get("name"))
        if known is None:
            return CheckResult(False, None, f"unknown scene {scene.get('name')!r}")
        if known.to_json() != scene:
            return CheckResult(False, None, f"the certificate's planes, margin or limits differ from "
                                            f"the library scene {known.name}")
    return CheckResult(True, None, "", counter[0])
