"""Distances and gradients of the navigation field (numba kernels on scalars and arrays).

The repulsion is Makarem et al. 2014, Eq. 2 with its sign corrected. As printed,
``min(0, (s^2 - D^2) / (s^2 - d^2))`` is negative inside the envelope and decreases as
the tips approach, so descending it pulls tips *together* (also in Makarem 2014 Table 2
and Eq. 7, and copied in Macktoobian et al. 2019, Eq. 5). The field used here is::

    rep(s) = (D^2 - s^2) / (s^2 - d^2)   for d < s < D,   0 for s >= D
    d rep / d q_i = -2 (D^2 - d^2) (q_i - q_j) / (s^2 - d^2)^2

zero at ``s = D``, growing to +inf at ``s = d``: it pushes the tips apart; ``s <= d``
counts as a collision. :func:`_barrier_weight` gives the factor of ``(q_i - q_j)``.

A robot's state is its pose row (:func:`_pose`): (cos a, sin a, cos(a+b), sin(a+b),
elbow x, elbow y), shape (n, 6). Distances are between tips (tip model) or beta
collision segments (segment model, Sayres et al. 2021 Eq. 3); in segment mode the force
acts at the closest point ``p`` of the segment, whose Jacobian is the tip's with
``l_beta`` replaced by its distance ``r`` along the arm (:func:`_jt`). Segment distances
come from :mod:`rfp_twin.models.geometry2d`. Lengths in mm, angles in radians.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# the point-segment projection and crossing test of the planner's capsule geometry
from rfp_twin.models.geometry2d import _project_sq, _segments_cross, segment_closest


@njit(cache=True)
def _pose(base, th, la, out):
    """out[i] = (cos a, sin a, cos(a+b), sin(a+b), elbow x, elbow y) for every robot."""
    for i in range(base.shape[0]):
        a = th[i, 0]
        ab = th[i, 0] + th[i, 1]
        ca = math.cos(a)
        sa = math.sin(a)
        out[i, 0] = ca
        out[i, 1] = sa
        out[i, 2] = math.cos(ab)
        out[i, 3] = math.sin(ab)
        out[i, 4] = base[i, 0] + la * ca
        out[i, 5] = base[i, 1] + la * sa


@njit(cache=True)
def _seg_closest(ax, ay, bx, by, cx, cy, dx, dy):
    """Closest points of segments AB and CD: (distance, t on AB, P on AB, Q on CD).

    Crossing segments return distance 0 (P = Q = the crossing point); otherwise
    :func:`rfp_twin.models.geometry2d.segment_closest`.
    """
    if _segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
        d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
        d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
        t = d1 / (d1 - d2)
        x = ax + t * (bx - ax)
        y = ay + t * (by - ay)
        return 0.0, t, x, y, x, y
    return segment_closest(ax, ay, bx, by, cx, cy, dx, dy)


@njit(cache=True)
def _pair(P, i, j, segment, lb, s0, s1):
    """Distance of robots i, j and i's closest point: (s, r_i, px, py, qx, qy).

    Tip mode: the tips (r_i = l_beta). Segment mode: the beta collision segments; r_i is
    the distance of i's closest point from its beta axis.
    """
    if not segment:
        px = P[i, 4] + lb * P[i, 2]
        py = P[i, 5] + lb * P[i, 3]
        qx = P[j, 4] + lb * P[j, 2]
        qy = P[j, 5] + lb * P[j, 3]
        return math.sqrt((px - qx) ** 2 + (py - qy) ** 2), lb, px, py, qx, qy
    s, t, px, py, qx, qy = _seg_closest(
        P[i, 4] + s0 * P[i, 2], P[i, 5] + s0 * P[i, 3], P[i, 4] + s1 * P[i, 2], P[i, 5] + s1 * P[i, 3],
        P[j, 4] + s0 * P[j, 2], P[j, 5] + s0 * P[j, 3], P[j, 4] + s1 * P[j, 2], P[j, 5] + s1 * P[j, 3])
    return s, s0 + t * (s1 - s0), px, py, qx, qy


@njit(cache=True)
def _fid(P, i, fx, fy, segment, lb, s0, s1):
    """Distance of robot i (tip or segment) to point (fx, fy): (s, r_i, px, py)."""
    if not segment:
        px = P[i, 4] + lb * P[i, 2]
        py = P[i, 5] + lb * P[i, 3]
        return math.sqrt((px - fx) ** 2 + (py - fy) ** 2), lb, px, py
    s2, t, px, py = _project_sq(fx, fy, P[i, 4] + s0 * P[i, 2], P[i, 5] + s0 * P[i, 3],
                                P[i, 4] + s1 * P[i, 2], P[i, 5] + s1 * P[i, 3])
    return math.sqrt(s2), s0 + t * (s1 - s0), px, py


@njit(cache=True)
def _jt(P, i, la, r, fx, fy):
    """J^T f for the point at r along robot i's beta arm: (f . dp/dalpha, f . dp/dbeta)."""
    # dp/dalpha = la perp(e_a) + r perp(e_ab); dp/dbeta = r perp(e_ab); perp(c, s) = (-s, c)
    fb = r * (-fx * P[i, 3] + fy * P[i, 2])
    fa = la * (-fx * P[i, 1] + fy * P[i, 0]) + fb
    return fa, fb


@njit(cache=True)
def _barrier_weight(s, d, tiny, l2, dD2):
    """``lambda2 |d rep / d q_i| / |q_i - q_j| = 2 lambda2 (D^2 - d^2) / (s^2 - d^2)^2``.

    ``s^2 - d^2`` is floored at ``tiny`` (a pair at or within ``d`` gets a large finite
    push); dD2 = ``D^2 - d^2``. Units 1/mm^2 times lambda2.
    """
    q = s * s - d * d
    if q < tiny:
        q = tiny
    return 2.0 * l2 * dD2 / (q * q)


@njit(cache=True)
def _start_violation(base, th, la, lb, s0, s1, segment, nbr_ptr, nbr_idx, fid_ptr, fid_idx,
                     fid_xy, d, d_f, movable_only_mask):
    """First (i, j_or_-1-f, s) with s <= threshold at configuration th, or (-1, 0, inf)."""
    n = base.shape[0]
    P = np.empty((n, 6))
    _pose(base, th, la, P)
    for i in range(n):
        for kk in range(nbr_ptr[i], nbr_ptr[i + 1]):
            j = nbr_idx[kk]
            if j <= i or not (movable_only_mask[i] or movable_only_mask[j]):
                continue
            s, _, _, _, _, _ = _pair(P, i, j, segment, lb, s0, s1)
            if s <= d:
                return i, j, s
        if movable_only_mask[i]:
            for kk in range(fid_ptr[i], fid_ptr[i + 1]):
                f = fid_idx[kk]
                s, _, _, _ = _fid(P, i, fid_xy[f, 0], fid_xy[f, 1], segment, lb, s0, s1)
                if s <= d_f:
                    return i, -1 - f, s
    return -1, 0, np.inf

