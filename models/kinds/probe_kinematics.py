"""Kinematics of the MIRADAS probe arm (Sabater et al. 2018 Eqs. 1-4), numba kernels.

Motor angles in degrees at the boundary (radians inside), lengths in mm, positions in
the arm frame: J1 at the origin, J2 at ``(d12, 0)``; theta1 turns the crank J1-J3
counter-clockwise, theta2 the rocker J2-J4 clockwise (Fig. 3b), so that

    J3 = d13 (cos t1, sin t1),   J4 = (d12 - d24 cos t2, d24 sin t2),
    tip = J3 + d3tip (1, u) / sqrt(1 + u^2)                     (Eqs. 1-2)
    u = (-d13 sin t1 + d24 sin t2) / (d12 - d13 cos t1 - d24 cos t2)   (Eq. 3)
    d34 = |J4 - J3|                                             (Eq. 4)

``links`` is ``ProbeArmSpec.links()``: (d12, d13, d24, d3tip, ds1, ds2) mm; ``limits``
the (2, 2) joint ranges in degrees. A pose is forbidden outside the ranges or in the
zone of avoidance (ZoA), ``d34`` outside ``(ds1, ds2)``.

The inverse is geometric (Sect. 3.1): J3 lies on the circle of radius d13 about J1 and
on the circle of radius d3tip about the tip; J4 lies on the line J3 -> tip at distance
d24 from J2. Of the (up to four) poses that put the tip on a point, the allowed one
reached soonest from a reference pose (Eq. 5) is returned.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

DEG = math.pi / 180.0


@njit(cache=True, inline="always")
def pose_points(t1, t2, links):
    """J3, J4 and tip of motor angles t1, t2 (radians): ``(j3x, j3y, j4x, j4y, tipx, tipy,
    ux, uy, d34)``, the unit vector u along the long tube from J3 towards the tip."""
    d12, d13, d24, d3t = links[0], links[1], links[2], links[3]
    j3x = d13 * math.cos(t1)
    j3y = d13 * math.sin(t1)
    j4x = d12 - d24 * math.cos(t2)
    j4y = d24 * math.sin(t2)
    dx = j4x - j3x
    dy = j4y - j3y
    d34 = math.sqrt(dx * dx + dy * dy)
    u = dy / dx                        # Eq. 3 (dx > 0: d12 > d13 + d24)
    c = 1.0 / math.sqrt(1.0 + u * u)
    return j3x, j3y, j4x, j4y, j3x + d3t * c, j3y + d3t * u * c, c, u * c, d34


@njit(cache=True)
def forward_tip(q_deg, links):
    """(m, 2) tip of each pose of ``q_deg`` (m, 2) deg (Eqs. 1-3), mm, arm frame."""
    m = q_deg.shape[0]
    out = np.empty((m, 2))
    for k in range(m):
        p = pose_points(q_deg[k, 0] * DEG, q_deg[k, 1] * DEG, links)
        out[k, 0] = p[4]
        out[k, 1] = p[5]
    return out


@njit(cache=True)
def d34_of(q_deg, links):
    """(m,) J3-J4 distance of each pose (Eq. 4), mm."""
    m = q_deg.shape[0]
    out = np.empty(m)
    for k in range(m):
        out[k] = pose_points(q_deg[k, 0] * DEG, q_deg[k, 1] * DEG, links)[8]
    return out


@njit(cache=True, inline="always")
def pose_forbidden(t1_deg, t2_deg, links, limits):
    """Outside the joint ranges or in the ZoA (``d34`` not in ``(ds1, ds2)``)?"""
    if not (limits[0, 0] <= t1_deg <= limits[0, 1]) or not (limits[1, 0] <= t2_deg <= limits[1, 1]):
        return True
    d = pose_points(t1_deg * DEG, t2_deg * DEG, links)[8]
    return not (links[4] < d < links[5])


@njit(cache=True)
def forbidden_poses(q_deg, links, limits):
    """(m,) bool: :func:`pose_forbidden` of each row of ``q_deg`` (m, 2) deg."""
    m = q_deg.shape[0]
    out = np.empty(m, dtype=np.bool_)
    for k in range(m):
        out[k] = pose_forbidden(q_deg[k, 0], q_deg[k, 1], links, limits)
    return out


@njit(cache=True)
def edges_forbidden(q0s, q1s, step, links, limits):
    """Any forbidden pose along each straight edge ``q0s[e] -> q1s[e]`` (E, 2) deg,
    sampled at most ``step`` (2,) deg apart per joint, ends included.

    Returns (hit (E,) bool, points checked (E,) int64)."""
    n_e = q0s.shape[0]
    hit = np.zeros(n_e, dtype=np.bool_)
    counts = np.zeros(n_e, dtype=np.int64)
    for e in range(n_e):
        n = 1
        for c in range(2):
            k = int(math.ceil(abs(q1s[e, c] - q0s[e, c]) / step[c] - 1e-9))
            n = max(n, k)
        for j in range(n + 1):
            f = j / n
            counts[e] += 1
            if pose_forbidden(q0s[e, 0] + f * (q1s[e, 0] - q0s[e, 0]),
                              q0s[e, 1] + f * (q1s[e, 1] - q0s[e, 1]), links, limits):
                hit[e] = True
                break
    return hit, counts


@njit(cache=True, inline="always")
def _in_range(a, lo, hi):
    """``a`` (deg) moved onto ``lo`` or ``hi`` when within 1e-7 deg of it (rounding of
    atan2 at a range end, e.g. the park pose), else unchanged."""
    if lo - 1e-7 <= a < lo:
        return lo
    if hi < a <= hi + 1e-7:
        return hi
    return a


@njit(cache=True)
def inverse_tip(tip_xy, links, limits, ref_deg, vmax):
    """(m, 2) deg: the allowed pose putting the tip on each row of ``tip_xy`` (m, 2) mm
    that is reached soonest from ``ref_deg`` (2,) at speeds ``vmax`` (2,) (Eq. 5); NaN
    rows where none is allowed (out of reach, or only ZoA / out-of-range poses)."""
    d12, d13, d24, d3t, ds1, ds2 = links[0], links[1], links[2], links[3], links[4], links[5]
    m = tip_xy.shape[0]
    out = np.full((m, 2), np.nan)
    for k in range(m):
        px, py = tip_xy[k, 0], tip_xy[k, 1]
        dd = math.sqrt(px * px + py * py)
        if dd < 1e-12:
            continue
        a = (d13 * d13 - d3t * d3t + dd * dd) / (2.0 * dd)
        h2 = d13 * d13 - a * a
        if h2 < 0.0:
            continue
        h = math.sqrt(h2)
        ex, ey = px / dd, py / dd
        best = np.inf
        for s3 in (-1.0, 1.0):
            j3x = a * ex - s3 * h * ey
            j3y = a * ey + s3 * h * ex
            if px - j3x <= 0.0:
                continue                      # the tube points from J3 away from J1's side
            ux, uy = (px - j3x) / d3t, (py - j3y) / d3t
            t1 = _in_range(math.atan2(j3y, j3x) / DEG, limits[0, 0], limits[0, 1])
            # J4 = J3 + s u with |J4 - J2| = d24
            wx, wy = j3x - d12, j3y
            b = ux * wx + uy * wy
            c = wx * wx + wy * wy - d24 * d24
            disc = b * b - c
            if disc < 0.0:
                continue
            root = math.sqrt(disc)
            for s4 in (-1.0, 1.0):
                s = -b + s4 * root
                if not (ds1 < s < ds2):
                    continue
                j4x, j4y = j3x + s * ux, j3y + s * uy
                t2a = math.atan2(j4y, d12 - j4x) / DEG
                for turn in (-360.0, 0.0, 360.0):
                    t2 = _in_range(t2a + turn, limits[1, 0], limits[1, 1])
                    if pose_forbidden(t1, t2, links, limits):
                        continue
                    cost = max(abs(t1 - ref_deg[0]) / vmax[0], abs(t2 - ref_deg[1]) / vmax[1])
                    if cost < best:
                        best = cost
                        out[k, 0] = t1
                        out[k, 1] = t2
    return out


@njit(cache=True, inline="always")
def pose_capsules(t1_deg, t2_deg, links, sizes, out):
    """Fill ``out`` (5, 5) with the collision capsules ``(x0, y0, x1, y1, radius)`` of
    one pose, arm frame, mm.

    ``sizes`` = ``ProbeArmSpec.body_sizes()``: link, cabinet, tube, head radius, tube
    rear, head length (mm). Bodies: crank J1-J3, rocker J2-J4, collimator cabinet (tube
    rear to s1), long tube (J3 to the head), pick-off head (ending at the tip).
    """
    j3x, j3y, j4x, j4y, tx, ty, ux, uy, _ = pose_points(t1_deg * DEG, t2_deg * DEG, links)
    d12, ds1 = links[0], links[4]
    rear, head = sizes[4], sizes[5]
    hx, hy = tx - head * ux, ty - head * uy
    rows = ((0.0, 0.0, j3x, j3y, sizes[0]), (d12, 0.0, j4x, j4y, sizes[0]),
            (j3x - rear * ux, j3y - rear * uy, j3x + ds1 * ux, j3y + ds1 * uy, sizes[1]),
            (j3x, j3y, hx, hy, sizes[2]), (hx, hy, tx, ty, sizes[3]))
    for b in range(5):
        for c in range(5):
            out[b, c] = rows[b][c]


@njit(cache=True)
def arm_capsules(q_deg, links, sizes):
    """(m, 5, 5) collision capsules of each pose of ``q_deg`` (m, 2) deg, arm frame
    (:func:`pose_capsules`)."""
    m = q_deg.shape[0]
    out = np.empty((m, 5, 5))
    for k in range(m):
        pose_capsules(q_deg[k, 0], q_deg[k, 1], links, sizes, out[k])
    return out
