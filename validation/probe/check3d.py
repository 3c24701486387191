"""3D check of a probe-arm plan with FCL (MIRADAS, Sabater et al. 2018).

Each arm's five bodies (crank, rocker, collimator cabinet, long tube, pick-off head) are
FCL capsules of the spec's radii and lengths, posed in 3D from the validation package's
own kinematics (:mod:`~rfp_twin.validation.probe.geometry`) in the arms' plane (z = 0; the
MuJoCo bench, :mod:`rfp_twin.models.mjcf.probe_bench`, holds the same capsules in one
plane). The plan is sampled every ``dt_s``; for every two arms, the body pairs whose
bounding boxes come within ``margin_mm`` (plus both buffers) are measured by
``fcl.distance`` (the same pose pair once: arms at rest repeat it), the others are
farther than ``margin_mm`` apart. Reports the smallest 3D distance and every contact.
Units: mm, deg, s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import fcl
import numpy as np

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.validation.probe.geometry import (BODY_NAMES, arm_frames, capsule_ends,
                                                sample_poses)
from rfp_twin.validation.probe.sampling import ProbeSampling, plan_arrays, sample_count, time_chunks

#: Samples handled at once (bounds memory).
CHUNK = 1024


@dataclass
class ProbeCheck3DReport(ProbeSampling):
    """Verdict of :func:`check_probe_plan_3d`.

    Attributes
    ----------
    ok : bool, no two arms within ``2 * buffer_mm`` of each other at any sample
    min_distance_mm : float, smallest FCL distance between bodies of two arms minus both
        buffers; capped at ``margin_mm`` (pairs not measured are at least that far apart)
    worst : (t s, arm a, arm b, body a, body b) of that distance (bodies by name)
    contacts : list of (t s, arm a, arm b, body a, body b) at or below 0 (first 20)
    n_queries : int, fcl.distance calls (distinct pose pairs within the margin)
    margin_mm : float, the distance beyond which body pairs are not measured, mm
    buffer_mm, dt_s, n_samples, duration_s : what was checked (:class:`ProbeSampling`)
    """

    ok: bool
    min_distance_mm: float
    worst: tuple
    contacts: list = field(default_factory=list)
    n_queries: int = 0
    margin_mm: float = 0.0


class _Capsules:
    """One FCL capsule object per body and arm slot (a, b), re-posed per query."""

    def __init__(self, spec, radii: np.ndarray) -> None:
        lengths = np.array([spec.d13_mm, spec.d24_mm, spec.tube_rear_mm + spec.ds1_mm,
                            spec.d3tip_mm - spec.head_length_mm, spec.head_length_mm])
        self.objs = [[fcl.CollisionObject(fcl.Capsule(float(r), float(h))) for r, h in
                      zip(radii, lengths)] for _ in range(2)]
        self.req = fcl.DistanceRequest()
        self.creq = fcl.CollisionRequest()

    @staticmethod
    def _pose(obj, p0: np.ndarray, p1: np.ndarray) -> None:
        """Put the capsule's axis (FCL: z, centred) on the segment p0 -> p1 (z = 0)."""
        phi = math.atan2(p1[1] - p0[1], p1[0] - p0[0])
        c, s = math.cos(phi), math.sin(phi)
        # Rz(phi) @ Ry(pi / 2): the capsule's z axis onto (cos phi, sin phi, 0)
        rot = np.array([[0.0, -s, c], [0.0, c, s], [-1.0, 0.0, 0.0]])
        obj.setTransform(fcl.Transform(rot, np.array([0.5 * (p0[0] + p1[0]),
                                                      0.5 * (p0[1] + p1[1]), 0.0])))

    def distance(self, i: int, seg_a: np.ndarray, j: int, seg_b: np.ndarray) -> float:
        """3D distance of body i at segment ``seg_a`` (2, 2) and body j at ``seg_b``;
        0 when they touch."""
        oa, ob = self.objs[0][i], self.objs[1][j]
        self._pose(oa, seg_a[0], seg_a[1])
        self._pose(ob, seg_b[0], seg_b[1])
        d = float(fcl.distance(oa, ob, self.req, fcl.DistanceResult()))
        if d <= 0.0 or fcl.collide(oa, ob, self.creq, fcl.CollisionResult()) > 0:
            return min(d, 0.0)
        return d


def check_probe_plan_3d(spec, breakpoints: dict, *, dt_s: float = 0.1, buffer_mm: float = 0.0,
                        margin_mm: float = 10.0) -> ProbeCheck3DReport:
    """Check a plan of ``spec.n_arms`` probe arms in 3D with FCL (see the module docstring).

    Parameters
    ----------
    spec : ProbeArmSpec (dimensions, bench)
    breakpoints : {arm: (times (k,) s increasing, configs (k, 2) deg)}, every arm
    dt_s : sample spacing, s
    buffer_mm : safety buffer of each arm (0: the bodies themselves)
    margin_mm : body pairs farther apart than this (beyond both buffers) are not measured
    """
    n = spec.n_arms
    bp = plan_arrays(breakpoints, n)
    if not (math.isfinite(dt_s) and dt_s > 0):
        raise TrajectoryError(f"dt_s = {dt_s}; allowed: a finite number > 0 s")
    t_end, n_t = sample_count(bp, dt_s)
    frames = arm_frames(spec)
    pad = 2.0 * buffer_mm
    reach = margin_mm + pad
    best, worst, contacts, n_queries = math.inf, (0.0, -1, -1, "", ""), [], 0
    caps = None
    for t in time_chunks(n_t, dt_s, CHUNK):
        ends, radii = capsule_ends(spec, sample_poses(bp, n, t), frames)   # (T, n, 5, 2, 2)
        if caps is None:
            caps = _Capsules(spec, radii)
        box_lo = ends.min(axis=-2) - radii[None, None, :, None]           # (T, n, 5, 2)
        box_hi = ends.max(axis=-2) + radii[None, None, :, None]
        for a in range(n):
            for b in range(a + 1, n):
                near = np.all((box_lo[:, a, :, None] <= box_hi[:, b, None, :] + reach) &
                              (box_lo[:, b, None, :] <= box_hi[:, a, :, None] + reach), axis=-1)
                hits = np.argwhere(near)                                 # (k, 3): t, i, j
                if hits.size == 0:
                    continue
                rows = np.concatenate([ends[hits[:, 0], a, hits[:, 1]].reshape(-1, 4),
                                       ends[hits[:, 0], b, hits[:, 2]].reshape(-1, 4),
                                       hits[:, 1:]], axis=1)
                uniq, first, inverse = np.unique(np.round(rows, 9), axis=0, return_index=True,
                                                 return_inverse=True)
                dist = np.empty(len(uniq))
                for u, k in enumerate(first):
                    ti, i, j = hits[k]
                    dist[u] = caps.distance(int(i), ends[ti, a, i], int(j), ends[ti, b, j]) - pad
                n_queries += len(uniq)
                per_hit = dist[inverse.reshape(-1)]
                k = int(np.argmin(per_hit))
                if per_hit[k] < best:
                    best = float(per_hit[k])
                    ti, i, j = hits[k]
                    worst = (float(t[ti]), a, b, BODY_NAMES[i], BODY_NAMES[j])
                for k in np.flatnonzero(per_hit <= 0.0)[:max(0, 20 - len(contacts))]:
                    ti, i, j = hits[k]
                    contacts.append((float(t[ti]), a, b, BODY_NAMES[i], BODY_NAMES[j]))
    best = min(best, float(margin_mm))    # unmeasured pairs are at least the margin apart
    return ProbeCheck3DReport(best > 0.0, best, worst, contacts, n_queries, margin_mm,
                              buffer_mm=buffer_mm, dt_s=dt_s, n_samples=n_t, duration_s=t_end)
