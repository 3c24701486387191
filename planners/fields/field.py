"""Distances and gradients of the navigation field (numba kernels on scalars and arrays).

The repulsion is Makarem et al. 2014, Eq. 2 with its sign corrected. As printed,
``min(0, (s^2 - D^2) / (s^2 - d^2))`` is negative inside the envelope and decreases as
the tips approach, so descending it pulls tips *together* (also in Makarem 2014 Table 2
and Eq. 7, and copied in Macktoobian et al. 2019, Eq. 5). The field used here is::

    rep(s) = (D^2 - s^2) / (s^2 - d^2)   for d < s < D,   0 for s >= D
    d rep / d q_i = -2 (D^2 - d^2) (q_i - q_j) / (s^2 - d^2)^2

zero at ``s = D``, growing to +inf at ``s = d``: it pushes the tips apart; ``s <= d``
counts as a collision. :func:`barrier_weight` gives the factor of ``(q_i - q_j)``.

A robot's state is its pose row (:func:`arm_poses`): (cos a, sin a, cos(a+b), sin(a+b),
elbow x, elbow y), shape (n, 6). Distances are between tips (tip model) or beta
collision segments (segment model, Sayres et al. 2021 Eq. 3); in segment mode the force
acts at the closest point ``p`` of the segment, whose Jacobian is the tip's with
``l_beta`` replaced by its distance ``r`` along the arm (:func:`jacobian_transpose`). Segment distances
come from :mod:`rfp_twin.models.geometry2d`. Lengths in mm, angles in radians.

Geometry is per robot (:class:`rfp_twin.models.array.ArrayGeometry`): robot i's elbow
is ``alpha_len[i]`` from its base, its beta segment runs from ``seg_start[i]`` to
``seg_end[i]``; obstacles are segments ``fid_xy[f]``-``fid_end_xy[f]`` (a point where
both ends are equal: the point formulas are then used unchanged). Per-body buffers
enter the thresholds (``d + ex_i + ex_j``), not the distances.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# the point-segment projection and crossing test of the planner's capsule geometry
from rfp_twin.models.geometry2d import project_sq, segments_cross, segment_closest


@njit(cache=True)
def arm_poses(base, th, la, out):
    """out[i] = (cos a, sin a, cos(a+b), sin(a+b), elbow x, elbow y) for every robot.

    base : (n, 2) mm; th : (n, 2) rad; la : (n,) each robot's alpha arm length, mm;
    out : (n, 6) filled in place.
    """
    for i in range(base.shape[0]):
        a = th[i, 0]
        ab = th[i, 0] + th[i, 1]
        ca = math.cos(a)
        sa = math.sin(a)
        out[i, 0] = ca
        out[i, 1] = sa
        out[i, 2] = math.cos(ab)
        out[i, 3] = math.sin(ab)
        out[i, 4] = base[i, 0] + la[i] * ca
        out[i, 5] = base[i, 1] + la[i] * sa


@njit(cache=True)
def _seg_closest(ax, ay, bx, by, cx, cy, dx, dy):
    """Closest points of segments AB and CD: (distance, t on AB, P on AB, Q on CD).

    Crossing segments return distance 0 (P = Q = the crossing point); otherwise
    :func:`rfp_twin.models.geometry2d.segment_closest`.
    """
    if segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
        d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
        d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
        t = d1 / (d1 - d2)
        x = ax + t * (bx - ax)
        y = ay + t * (by - ay)
        return 0.0, t, x, y, x, y
    return segment_closest(ax, ay, bx, by, cx, cy, dx, dy)


@njit(cache=True)
def pair_distance(P, i, j, segment, lb, s0, s1):
    """Distance of robots i, j and i's closest point: (s, r_i, px, py, qx, qy), mm.

    Tip mode: the tips (r_i = l_beta). Segment mode: the beta collision segments, robot
    k's from ``s0[k]`` to ``s1[k]`` (both (n,), mm) along its beta arm; r_i is the
    distance of i's closest point from its beta axis.
    """
    if not segment:
        px = P[i, 4] + lb * P[i, 2]
        py = P[i, 5] + lb * P[i, 3]
        qx = P[j, 4] + lb * P[j, 2]
        qy = P[j, 5] + lb * P[j, 3]
        return math.sqrt((px - qx) ** 2 + (py - qy) ** 2), lb, px, py, qx, qy
    a0 = s0[i]
    a1 = s1[i]
    b0 = s0[j]
    b1 = s1[j]
    s, t, px, py, qx, qy = _seg_closest(
        P[i, 4] + a0 * P[i, 2], P[i, 5] + a0 * P[i, 3], P[i, 4] + a1 * P[i, 2], P[i, 5] + a1 * P[i, 3],
        P[j, 4] + b0 * P[j, 2], P[j, 5] + b0 * P[j, 3], P[j, 4] + b1 * P[j, 2], P[j, 5] + b1 * P[j, 3])
    return s, a0 + t * (a1 - a0), px, py, qx, qy


@njit(cache=True)
def obstacle_distance(P, i, fa, fb, f, segment, lb, s0, s1):
    """Distance of robot i (tip or beta segment) to obstacle f: (s, r_i, px, py, qx, qy).

    The obstacle is the segment ``fa[f]``-``fb[f]`` ((m, 2) ends, mm; a point where the
    ends are equal, e.g. a fiducial). ``p`` is i's closest point (``r_i`` mm along its
    beta arm; ``l_beta`` in tip mode), ``q`` the obstacle's. s0, s1 : (n,) mm as in
    :func:`pair_distance`.
    """
    ax = fa[f, 0]
    ay = fa[f, 1]
    bx = fb[f, 0]
    by = fb[f, 1]
    point = ax == bx and ay == by
    if not segment:
        px = P[i, 4] + lb * P[i, 2]
        py = P[i, 5] + lb * P[i, 3]
        if point:
            return math.sqrt((px - ax) ** 2 + (py - ay) ** 2), lb, px, py, ax, ay
        s2, _, qx, qy = project_sq(px, py, ax, ay, bx, by)
        return math.sqrt(s2), lb, px, py, qx, qy
    r0 = s0[i]
    r1 = s1[i]
    if point:
        s2, t, px, py = project_sq(ax, ay, P[i, 4] + r0 * P[i, 2], P[i, 5] + r0 * P[i, 3],
                                    P[i, 4] + r1 * P[i, 2], P[i, 5] + r1 * P[i, 3])
        return math.sqrt(s2), r0 + t * (r1 - r0), px, py, ax, ay
    s, t, px, py, qx, qy = _seg_closest(
        P[i, 4] + r0 * P[i, 2], P[i, 5] + r0 * P[i, 3], P[i, 4] + r1 * P[i, 2], P[i, 5] + r1 * P[i, 3],
        ax, ay, bx, by)
    return s, r0 + t * (r1 - r0), px, py, qx, qy


@njit(cache=True)
def jacobian_transpose(P, i, la, r, fx, fy):
    """J^T f for the point at r along robot i's beta arm: (f . dp/dalpha, f . dp/dbeta).

    la : robot i's alpha arm length (scalar), mm; f = (fx, fy) a force in the plane.
    """
    # dp/dalpha = la perp(e_a) + r perp(e_ab); dp/dbeta = r perp(e_ab); perp(c, s) = (-s, c)
    fb = r * (-fx * P[i, 3] + fy * P[i, 2])
    fa = la * (-fx * P[i, 1] + fy * P[i, 0]) + fb
    return fa, fb


@njit(cache=True)
def barrier_weight(s, d, tiny, l2, dD2):
    """``lambda2 |d rep / d q_i| / |q_i - q_j| = 2 lambda2 (D^2 - d^2) / (s^2 - d^2)^2``.

    ``s^2 - d^2`` is floored at ``tiny`` (a pair at or within ``d`` gets a large finite
    push); dD2 = ``D^2 - d^2``. Units 1/mm^2 times lambda2.
    """
    q = s * s - d * d
    if q < tiny:
        q = tiny
    return 2.0 * l2 * dD2 / (q * q)


@njit(cache=True, inline="always")
def barrier_push(P, i, la, r, s, d, D, l2, px, py, qx, qy, bx, by, ax, ay):
    """Joint velocities (alpha, beta) of robot i's repulsion from one body (Eq. 2).

    (px, py) is robot i's closest point (at r along its beta arm), (qx, qy) the body's, s
    their distance, mm; the barrier runs from ``d`` (contact) to ``D`` (no force) and is
    scaled by ``l2`` (:func:`barrier_weight`). The push is along q -> p; at contact (s ~ 0)
    it points from (ax, ay) to robot i's base (bx, by) instead, with length ``d``.
    """
    w = barrier_weight(s, d, 1e-6 * d * d, l2, D * D - d * d)
    vx = px - qx
    vy = py - qy
    if s < 1e-12:
        vx = bx - ax
        vy = by - ay
        nv = max(math.sqrt(vx * vx + vy * vy), 1e-12)
        vx *= d / nv
        vy *= d / nv
    return jacobian_transpose(P, i, la, r, w * vx, w * vy)


@njit(cache=True)
def start_violation(base, th, la, lb, s0, s1, segment, nbr_ptr, nbr_idx, fid_ptr, fid_idx,
                     fid_a, fid_b, ex, fex, d, d_f, movable_only_mask):
    """First (i, j_or_-1-f, s) with s <= threshold at configuration th, or (-1, 0, inf).

    Thresholds: ``d + ex[i] + ex[j]`` for a pair, ``d_f + ex[i] + fex[f]`` for an
    obstacle (ex (n,), fex (m,): each body's buffer beyond the nominal one, mm).
    """
    n = base.shape[0]
    P = np.empty((n, 6))
    arm_poses(base, th, la, P)
    for i in range(n):
        for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
            j = nbr_idx[kk]
            if j <= i or not (movable_only_mask[i] or movable_only_mask[j]):
                continue
            s, _, _, _, _, _ = pair_distance(P, i, j, segment, lb, s0, s1)
            if s <= d + (ex[i] + ex[j]):
                return i, j, s
        if movable_only_mask[i]:
            for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[kk]
                s, _, _, _, _, _ = obstacle_distance(P, i, fid_a, fid_b, f, segment, lb, s0, s1)
                if s <= d_f + (ex[i] + fex[f]):
                    return i, -1 - f, s
    return -1, 0, np.inf
