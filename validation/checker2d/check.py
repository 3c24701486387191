"""The 2D check of a whole trajectory: :func:`check_trajectory` (mm, deg, s).

The collision model is the capsule model of Sayres et al. 2021 (Eq. 3) with each
robot's own geometry. Robot ``i`` with base ``b_i``, alpha ``a`` and beta ``b``
(degrees) has its beta collision body on the segment

    P_i(r, t) = b_i + l_i (cos a, sin a) + r (cos(a + b), sin(a + b)),   r in [s0_i, s1_i]

with its alpha arm length ``l_i``, segment ``[s0_i, s1_i]`` and buffer ``buffer_i``
from the layout's per-robot columns
(:func:`rfp_twin.models.layout.columns.robot_collision_arrays`: the spec's values at
``buffer_mm`` where blank; ``buffer_i = buffer_mm + buffer_add_mm``). Robots ``i, j``
collide when the segment distance ``D_ij(t) <= buffer_i + buffer_j``. An obstacle
``f`` (a non-robot row of the layout: a fiducial is a point, a ``gfa`` row with
``x2_mm, y2_mm`` a segment; :func:`rfp_twin.models.layout.columns.obstacle_arrays`) is
thickened by its own ``obstacle_buffer_mm`` (default ``spec.fiducial_buffer_mm``);
robot ``i`` collides with it when the distance of its segment to the obstacle's is
``<= buffer_i + obstacle_buffer_f``. Only pairs whose bases are within ``reach_i +
reach_j`` (robot pairs, ``reach_i = l_i + r_max,i + buffer_i``, ``r_max,i = max(|s0_i|,
|s1_i|)``) or whose base is within ``reach_i + obstacle_buffer_f`` of the obstacle can
touch; the candidate pairs are found here (k-d tree, or all robot-obstacle distances
when obstacles differ), not with the planner's neighbour lists.

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
from rfp_twin.models.layout.columns import obstacle_arrays
from rfp_twin.models.robot import RobotSpec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.checker2d.kernel import check_pairs
from rfp_twin.validation.checker2d.report import CheckReport, Collision
from rfp_twin.validation.checker2d.speeds import checked_buffer, robot_arms, robot_speeds
from rfp_twin.validation.numerics import (REACH_TOL_MM, axis_csr, checked_float, pairs_within,
                                 robot_bases, segment_distance_np, time_span)


def _fiducials_within(robot_xy: np.ndarray, fid_xy: np.ndarray, reach: float) -> np.ndarray:
    """(robot index, fiducial index) pairs at most ``reach`` (+ tolerance) apart, (q, 2)."""
    if len(robot_xy) == 0 or len(fid_xy) == 0:
        return np.empty((0, 2), dtype=np.int64)
    lists = cKDTree(fid_xy).query_ball_point(robot_xy, r=reach + REACH_TOL_MM)
    rows = [(i, k) for i, ks in enumerate(lists) for k in sorted(ks)]
    return np.array(rows, dtype=np.int64).reshape(-1, 2)


def _robot_pairs(base: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Robot index pairs ``(i < j)`` whose bases (n, 2) are at most ``reach_i + reach_j``
    (+ tolerance) apart, (p, 2) int64, sorted; ``reach`` (n,) mm."""
    top = float(reach.max()) if len(reach) else 0.0
    pairs = pairs_within(base, 2.0 * top)
    if len(pairs) and np.any(reach != top):
        d = np.hypot(*(base[pairs[:, 0]] - base[pairs[:, 1]]).T)
        pairs = pairs[d <= reach[pairs[:, 0]] + reach[pairs[:, 1]] + REACH_TOL_MM]
    return pairs


def _obstacle_pairs(base: np.ndarray, reach: np.ndarray, a: np.ndarray, b: np.ndarray,
                    obuf: np.ndarray) -> np.ndarray:
    """(robot index, obstacle index) pairs, (q, 2) int64 sorted, whose base (n, 2) is at
    most ``reach_i + obuf_f`` (+ tolerance) from the obstacle segment ``a_f``-``b_f``
    ((m, 2) mm; a point when ``a_f == b_f``); ``reach`` (n,), ``obuf`` (m,) mm."""
    if len(base) == 0 or len(a) == 0:
        return np.empty((0, 2), dtype=np.int64)
    if np.all(a == b) and np.all(reach == reach[0]) and np.all(obuf == obuf[0]):
        return _fiducials_within(base, a, float(reach[0]) + float(obuf[0]))
    d = segment_distance_np(base[:, None], base[:, None], a[None], b[None])       # (n, m)
    near = d <= reach[:, None] + obuf[None, :] + REACH_TOL_MM
    return np.argwhere(near).astype(np.int64).reshape(-1, 2)


def check_trajectory(traj: Trajectory, spec: RobotSpec, layout: Layout, buffer_mm: float, *,
                     resolution_s: float = 1e-5, distance_tol_mm: float = 0.005,
                     distance_rel_tol: float = 0.05,
                     focus_ids: np.ndarray | None = None) -> CheckReport:
    """Check a trajectory densely against the 2D capsule model.

    Parameters
    ----------
    traj : Trajectory
        Robots are matched to the layout by id.
    spec : RobotSpec
        Arm geometry (``alpha_length_mm``, ``segment_start_mm``, ``segment_end``,
        ``fiducial_buffer_mm``) of every robot and obstacle the layout does not
        override.
    layout : Layout
        Robot bases and obstacles, and the optional per-robot / per-obstacle columns
        (:mod:`rfp_twin.models.layout.columns`). Layout robots absent from ``traj`` are
        not checked.
    buffer_mm : float
        Collision buffer of every robot, mm (plus its ``buffer_add_mm``; threshold
        ``buffer_i + buffer_j`` for robot pairs).
    resolution_s : float
        Shortest interval the bisection splits; an interval this short that the bound
        cannot clear is reported as a (conservative) collision. Also the precision of
        collision start/end times.
    distance_tol_mm, distance_rel_tol : float
        Per-pair minima are refined until within ``distance_tol_mm + distance_rel_tol
        * clearance`` of the true minimum (``clearance``: sampled minimum minus the
        threshold, if positive): close pairs to 0.005 mm, far pairs to 5 % of their
        clearance (as the 3D check; at 1 % the first check of a 12,871-robot fold takes
        3.8 s instead of 2.2 s, half of it spent refining minima of pairs mm apart).
        Collisions do not depend on these: an interval is bisected while its bound is
        at or below the threshold, whatever the tolerance.
    focus_ids : (k,) robot ids, optional
        Check only the pairs with at least one of these robots (and their obstacles):
        a re-check after some robots' trajectories changed, the other pairs being known.
        Default: every pair.

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
    LayoutError
        A per-robot / per-obstacle column out of range, or a robot buffer outside
        ``(0, pitch / 2)``.
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
    la, s0, s1, rmax, buf = robot_arms(spec, layout, ids, buffer_mm)
    fid_xy, fid_end, obuf = obstacle_arrays(spec, layout)
    fid_ids = np.asarray(layout.fiducial_ids, dtype=np.int64)
    n = len(ids)

    reach = la + rmax + buf
    rpairs = _robot_pairs(base, reach)
    fpairs = _obstacle_pairs(base, reach, fid_xy, fid_end, obuf)
    if focus_ids is not None:
        focus = np.isin(ids, np.asarray(focus_ids, dtype=np.int64).reshape(-1))
        rpairs = rpairs[focus[rpairs[:, 0]] | focus[rpairs[:, 1]]]
        fpairs = fpairs[focus[fpairs[:, 0]]]
    n_r, n_f = len(rpairs), len(fpairs)

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
        ends = [np.concatenate([np.zeros(n_r), xy[fpairs[:, 1], k]])
                for xy in (fid_xy, fid_end) for k in (0, 1)]
        thr = np.concatenate([buf[rpairs[:, 0]] + buf[rpairs[:, 1]],
                              buf[fpairs[:, 0]] + obuf[fpairs[:, 1]]])
        pmin, _, n_samples, coll = check_pairs(
            pi, pj, *ends, thr,
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
        seconds=time.perf_counter() - clock,
        pair_threshold_mm=np.asarray(thr_all[:n_r], dtype=np.float64),
        fiducial_threshold_mm=np.asarray(thr_all[n_r:], dtype=np.float64))
