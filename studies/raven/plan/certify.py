"""Prove a straight joint-space segment clear of a scene, by interval bisection (numpy).

A piece [t0, t1] of the segment q(t) = qa + t (qb - qa) lies in the joint box that the
interval expression qa + [t0, t1] (qb - qa) encloses; the closed-form kinematics evaluated
on that box in outward-rounded interval arithmetic (`intervals.py`) encloses the wrist and
the tip over the whole piece. The piece is **proved** when, for every clause of the scene,
some plane has the lower bound of n·p - c - margin >= 0 for both points. A piece that is
not proved is halved, up to `max_depth` halvings and `max_pieces` evaluations in all (both
deterministic); a piece whose midpoint is a state that fails the float check (or leaves the
joint box) refutes the segment at once. A segment is proved when all its pieces are; the
pieces, as dyadic fractions of the segment, are its certificate.

Nothing here needs to be trusted on its own: `check.py` re-checks the certificate with
another implementation (mpmath intervals over the DH chain).
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from certiloop.studies.raven.plan import intervals as iv
from certiloop.studies.raven.plan import kinematics
from certiloop.studies.raven.plan.scenes import Scene

MAX_DEPTH = 14
MAX_PIECES = 20_000


@dataclass
class SegmentProof:
    proved: bool
    pieces: list  # [(k, depth)] proved pieces [k / 2^depth, (k + 1) / 2^depth], in order
    reason: str = ""
    evaluated: int = 0
    least_margin: float = float("inf")  # smallest proved lower bound of any clause's slack

    def breakpoints(self) -> list[str]:
        """The pieces as the certificate writes them: their boundaries, '0' ... '1'."""
        points = [Fraction(0)] + [Fraction(k + 1, 2 ** d) for k, d in self.pieces]
        return [str(p) for p in points]


_CONSTS: dict = {}


def _interval_consts(arm: str):
    if arm not in _CONSTS:
        from certiloop.studies.raven.arm import ALPHA, THETA3

        a = ALPHA[arm]
        _CONSTS[arm] = (iv.constant_trig(a[0]), iv.constant_trig(a[1]), iv.constant_trig(a[2]),
                        iv.constant_trig(THETA3[arm]))
    return _CONSTS[arm]


def enclose_points(qbox: list[iv.Interval], arm: str = "left"):
    """Interval enclosures (triples) of the wrist and the tip over joint boxes (6 intervals)."""
    trig1 = (iv.cos(qbox[0]), iv.sin(qbox[0]))
    trig2 = (iv.cos(qbox[1]), iv.sin(qbox[1]))
    wrist, tip = kinematics.local_points(qbox[2], iv.cos(qbox[3]), iv.sin(qbox[3]), iv.cos(qbox[4]),
                                         iv.sin(qbox[4]))
    consts = _interval_consts(arm)
    return kinematics.chain(wrist, trig1, trig2, consts), kinematics.chain(tip, trig1, trig2, consts)


def _dot_lower(n, p) -> np.ndarray:
    total = None
    for k in range(3):
        if n[k] == 0.0:
            continue
        term = p[k] * float(n[k])
        total = term if total is None else total + term
    return total.lo


def proved_slack(scene: Scene, qa, qb, t0, t1) -> np.ndarray:
    """Per piece [t0, t1] (arrays): a rigorous lower bound of the least clause slack."""
    qa, qb = np.asarray(qa, float), np.asarray(qb, float)
    t = iv.Interval(t0, t1)
    qbox = [iv.Interval(qa[j]) + t * (iv.Interval(qb[j]) - iv.Interval(qa[j])) for j in range(6)]
    wrist, tip = enclose_points(qbox, scene.arm)
    worst = np.full(np.shape(t0), np.inf)
    margin = iv.Interval(scene.margin)
    for clause in scene.clauses:
        best = np.full(np.shape(t0), -np.inf)
        for n, c in clause:
            # slack = n·p - c - margin, bounded below with outward rounding
            lw = (iv.Interval(_dot_lower(n, wrist)) - c - margin).lo
            lt = (iv.Interval(_dot_lower(n, tip)) - c - margin).lo
            best = np.maximum(best, np.minimum(lw, lt))
        worst = np.minimum(worst, best)
    inside = np.ones(np.shape(t0), dtype=bool)
    for j in range(6):
        inside &= (qbox[j].lo >= scene.lo[j]) & (qbox[j].hi <= scene.hi[j])
    return np.where(inside, worst, -np.inf)


def prove_segment(scene: Scene, qa, qb, max_depth: int = MAX_DEPTH,
                  max_pieces: int = MAX_PIECES) -> SegmentProof:
    qa, qb = np.asarray(qa, float), np.asarray(qb, float)
    pending_k, depth = np.array([0], dtype=np.int64), 0
    proved: list[tuple[int, int]] = []
    evaluated, least = 0, float("inf")
    while len(pending_k):
        if evaluated + len(pending_k) > max_pieces:
            return SegmentProof(False, [], f"piece budget {max_pieces} exhausted", evaluated)
        scale = 2.0 ** -depth
        t0, t1 = pending_k * scale, (pending_k + 1) * scale  # exact: dyadic
        slack = proved_slack(scene, qa, qb, t0, t1)
        evaluated += len(pending_k)
        ok = slack >= 0.0
        if np.any(ok):
            least = min(least, float(slack[ok].min()))
        proved.extend((int(k), depth) for k in pending_k[ok])
        rest = pending_k[~ok]
        if not len(rest):
            break
        mids = qa + (((rest + 0.5) * scale)[:, None]) * (qb - qa)
        if np.any(~scene.valid(mids)):
            return SegmentProof(False, [], "a state on the segment is not clear", evaluated)
        if depth == max_depth:
            return SegmentProof(False, [], f"not proved within {max_depth} halvings", evaluated)
        pending_k = np.concatenate([2 * rest, 2 * rest + 1])
        depth += 1
    proved.sort(key=lambda kd: Fraction(kd[0], 2 ** kd[1]))
    return SegmentProof(True, proved, "", evaluated, least)
