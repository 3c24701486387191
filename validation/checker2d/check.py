"""The 2D check of a whole trajectory: :func:`check_trajectory` (mm, deg, s).

The collision model is the capsule model of Sayres et al. 2021 (Eq. 3). Robot ``i``
with base ``b_i``, alpha ``a`` and beta ``b`` (degrees) has its beta collision body on
the segment

    P_i(r, t) = b_i + l_alpha (cos a, sin a) + r (cos(a + b), sin(a + b)),
    r in [segment_start_mm, spec.segment_end(buffer)]

Robots ``i, j`` collide when the segment distance ``D_ij(t) <= buffer_i + buffer_j``.
A fiducial is a disk of radius ``spec.fiducial_buffer_mm``; robot ``i`` collides with
it when the point-segment distance ``<= buffer_i + fiducial_buffer_mm``. Only pairs
whose bases are within ``2 (l_alpha + r_max + buffer)`` (robot pairs) or
``l_alpha + r_max + buffer + fiducial_buffer`` (robot-fiducial) can touch,
``r_max = max(segment_start, segment_end)``; the candidate pairs are found here with
a k-d tree, not with the planner's neighbour lists.

The checked span is ``[T0, T1]``, ``T0 = min(0, first breakpoint)``, ``T1`` the last
breakpoint (:func:`rfp_twin.validation.numerics.time_span`). Robots of the layout that the
trajectory does not list are not checked. The dense check itself (why no collision can
slip between samples) is :mod:`rfp_twin.validation.checker2d.kernel`.
"""
from __future__ import annotations

import time

import numpy as np
from scipy.spatial import cKDTree

from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import RobotSpec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.checker2d.kernel import check_pairs
from rfp_twin.validation.checker2d.report import CheckReport, Collision
from rfp_twin.validation.checker2d.speeds import arm_geometry, checked_buffer, robot_speeds
from rfp_twin.validation.numerics import (REACH_TOL_MM, axis_csr, checked_float, pairs_within,
                                 robot_bases, time_span)


def _fiducials_within(robot_xy: np.ndarray, fid_xy: np.ndarray, reach: float) -> np.ndarray:
    """(robot index, fiducial index) pairs at most ``reach`` (+ tolerance) apart, (q, 2)."""
    if len(robot_xy) == 0 or len(fid_xy) == 0:
        return np.empty((0, 2), dtype=np.int64)
    lists = cKDTree(fid_xy).query_ball_point(robot_xy, r=reach + REACH_TOL_MM)
    rows = [(i, k) for i, ks in enumerate(lists) for k in sorted(ks)]
    return np.array(rows, dtype=np.int64).reshape(-1, 2)


def check_trajectory(traj: Trajectory, spec: RobotSpec, layout: Layout, buffer_mm: float, *,
                     resolution_s: float = 1e-5, distance_tol_mm: float = 0.005,
                     distance_rel_tol: float = 0.01) -> CheckReport:
    """Check a trajectory densely against the 2D capsule model.

    Parameters
    ----------
    traj : Trajectory
        Robots are matched to the layout by id.
    spec : RobotSpec
        Arm geometry (``alpha_length_mm``, ``segment_start_mm``, ``segment_end``,
        ``fiducial_buffer_mm``).
    layout : Layout
        Robot bases and fiducials. Layout robots absent from ``traj`` are not checked.
    buffer_mm : float
        Collision buffer of every robot, mm (threshold ``2 buffer`` for robot pairs).
    resolution_s : float
        Shortest interval the bisection splits; an interval this short that the bound
        cannot clear is reported as a (conservative) collision. Also the precision of
        collision start/end times.
    distance_tol_mm, distance_rel_tol : float
        Per-pair minima are refined until within ``distance_tol_mm + distance_rel_tol
        * clearance`` of the true minimum (``clearance``: sampled minimum minus the
        threshold, if positive): close pairs to 0.005 mm, far pairs more loosely.

    Returns
    -------
    CheckReport

    Raises
    ------
    UnknownRobotError
        A trajectory robot id that is not a robot of the layout.
    TrajectoryError
        Duplicate robot ids, or an axis that jumps (no finite speed bound).
    SpecError
        ``buffer_mm``, ``resolution_s``, ``distance_tol_mm`` or ``distance_rel_tol``
        out of range.
    """
    clock = time.perf_counter()
    buffer_mm = checked_buffer(buffer_mm)
    res = checked_float(resolution_s, "resolution_s", "a finite number >= 1e-12 s",
                        "check_trajectory", 1e-12, strict=False, allow_bool=True)
    tol = checked_float(distance_tol_mm, "distance_tol_mm", "a finite number >= 0 mm",
                        "check_trajectory", strict=False, allow_bool=True)
    rel = checked_float(distance_rel_tol, "distance_rel_tol", "a finite number >= 0",
                        "check_trajectory", strict=False, allow_bool=True)

    ids, base = robot_bases(traj, layout)
    la, s0, s1, rmax = arm_geometry(spec, buffer_mm)
    fbuf = float(spec.fiducial_buffer_mm)
    n = len(ids)

    rpairs = pairs_within(base, 2.0 * (la + rmax + buffer_mm))
    fpairs = _fiducials_within(base, np.asarray(layout.fiducial_xy, dtype=np.float64),
                               la + rmax + buffer_mm + fbuf)
    n_r, n_f = len(rpairs), len(fpairs)
    fid_xy = np.asarray(layout.fiducial_xy, dtype=np.float64)
    fid_ids = np.asarray(layout.fiducial_ids, dtype=np.int64)

    t_lo, t_hi = time_span(traj)

    pmin = np.empty(0)
    n_samples = 0
    coll = np.empty((0, 6))
    if n_r + n_f:
        pa, ta, aa, ra = axis_csr(traj, 0)
        pb, tb, ab, rb = axis_csr(traj, 1)
        vglob, vmean = robot_speeds(la, rmax, (pa, ta, ra), (pb, tb, rb), t_hi - t_lo)
        pi = np.concatenate([rpairs[:, 0], fpairs[:, 0]]).astype(np.int64)
        pj = np.concatenate([rpairs[:, 1], np.full(n_f, -1, dtype=np.int64)]).astype(np.int64)
        pfx = np.concatenate([np.zeros(n_r), fid_xy[fpairs[:, 1], 0] if n_f else np.empty(0)])
        pfy = np.concatenate([np.zeros(n_r), fid_xy[fpairs[:, 1], 1] if n_f else np.empty(0)])
        thr = np.concatenate([np.full(n_r, 2.0 * buffer_mm), np.full(n_f, buffer_mm + fbuf)])
        pmin, _, n_samples, coll = check_pairs(
            pi, pj, pfx, pfy, thr,
            np.ascontiguousarray(base[:, 0]), np.ascontiguousarray(base[:, 1]),
            la, s0, s1, rmax, pa, ta, aa, ra, pb, tb, ab, rb, vglob, vmean,
            t_lo, t_hi, 2.0 * buffer_mm, res, tol, rel)
        thr_all = thr
    else:
        thr_all = np.empty(0)

    collisions: list[Collision] = []
    for row in coll:
        p = int(row[0])
        if p < n_r:
            kind, a_id, other = "robot", int(ids[rpairs[p, 0]]), int(ids[rpairs[p, 1]])
        else:
            q = p - n_r
            kind, a_id, other = "fiducial", int(ids[fpairs[q, 0]]), int(fid_ids[fpairs[q, 1]])
        collisions.append(Collision(kind, a_id, other, float(row[1]), float(row[2]),
                                    float(row[3]), float(row[4]), float(thr_all[p]),
                                    bool(row[5] != 0.0)))
    collisions.sort(key=lambda c: (c.t_start, c.kind, c.robot_a, c.other))

    clearance = np.inf
    if n_r + n_f:
        clearance = float(np.min(pmin - thr_all))
    for c in collisions:
        clearance = min(clearance, c.min_distance_mm - c.threshold_mm)

    pair_ids = ids[rpairs] if n_r else np.empty((0, 2), dtype=np.int64)
    fpair_ids = (np.stack([ids[fpairs[:, 0]], fid_ids[fpairs[:, 1]]], axis=1) if n_f
                 else np.empty((0, 2), dtype=np.int64))
    return CheckReport(
        buffer_mm=buffer_mm, n_robots=n, n_pairs=n_r, n_fiducial_pairs=n_f,
        duration_s=t_hi - t_lo, n_samples=int(n_samples),
        pair_ids=pair_ids.astype(np.int64), pair_min_distance_mm=np.asarray(pmin[:n_r]),
        fiducial_pair_ids=fpair_ids.astype(np.int64),
        fiducial_min_distance_mm=np.asarray(pmin[n_r:]),
        min_clearance_mm=clearance, collisions=collisions,
        seconds=time.perf_counter() - clock)
