"""2D capsule geometry of Sayres 2021 Sect. 3.3: beta arms as buffered segments.

All functions are numba ``@njit(cache=True)`` kernels on scalars or numpy arrays.
Lengths in mm, angles in degrees at the public boundary (radians inside).

A robot's collision body is the segment from ``start`` to ``end`` mm along its beta
arm (measured from the beta axis), thickened by a buffer; two robots collide when the
segment distance is ``<= buffer_i + buffer_j`` (Eq. 3). Every robot may have its own
alpha arm length and segment (per-robot arrays, :mod:`rfp_twin.models.layout.columns`).
An obstacle is a disk (a fiducial) or a buffered segment (a guide-camera edge).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import overload

DEG = math.pi / 180.0


@njit(cache=True, inline="always")
def segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
    """True when segments AB and CD properly cross (each separates the other's ends)."""
    d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
    d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
    d3 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    d4 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
    return ((d1 > 0.0 and d2 < 0.0) or (d1 < 0.0 and d2 > 0.0)) and \
        ((d3 > 0.0 and d4 < 0.0) or (d3 < 0.0 and d4 > 0.0))


@njit(cache=True, inline="always")
def segment_distance(ax, ay, bx, by, cx, cy, dx, dy):
    """Minimum distance between segments AB and CD in the plane, mm.

    Exact for all cases (crossing, parallel, degenerate). Scalars in, scalar out.
    Crossing segments are 0 apart; otherwise the minimum is reached at an endpoint of
    one of the segments.
    """
    if segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
        return 0.0
    return math.sqrt(min(_point_segment_sq(ax, ay, cx, cy, dx, dy),
                         _point_segment_sq(bx, by, cx, cy, dx, dy),
                         _point_segment_sq(cx, cy, ax, ay, bx, by),
                         _point_segment_sq(dx, dy, ax, ay, bx, by)))


@njit(cache=True, inline="always")
def project_sq(px, py, ax, ay, bx, by):
    """Nearest point F of segment AB to point P: ``(|PF|^2 mm^2, t, fx, fy)`` with
    ``F = A + t (B - A)``, ``t`` in [0, 1] (``t = 0`` for a degenerate segment)."""
    ux = bx - ax
    uy = by - ay
    den = ux * ux + uy * uy
    t = 0.0
    if den > 0.0:
        t = min(1.0, max(0.0, ((px - ax) * ux + (py - ay) * uy) / den))
    fx = ax + t * ux
    fy = ay + t * uy
    ex = fx - px
    ey = fy - py
    return ex * ex + ey * ey, t, fx, fy


@njit(cache=True, inline="always")
def _point_segment_sq(px, py, ax, ay, bx, by):
    """Squared distance from point P to segment AB, mm^2."""
    return project_sq(px, py, ax, ay, bx, by)[0]


@njit(cache=True, inline="always")
def segments_within(ax, ay, bx, by, cx, cy, dx, dy, r):
    """True when segments AB and CD are at most r apart (no square roots)."""
    if segments_cross(ax, ay, bx, by, cx, cy, dx, dy):
        return True
    r2 = r * r
    return (_point_segment_sq(ax, ay, cx, cy, dx, dy) <= r2
            or _point_segment_sq(bx, by, cx, cy, dx, dy) <= r2
            or _point_segment_sq(cx, cy, ax, ay, bx, by) <= r2
            or _point_segment_sq(dx, dy, ax, ay, bx, by) <= r2)


@njit(cache=True, inline="always")
def segment_closest(ax, ay, bx, by, cx, cy, dx, dy):
    """Closest points of non-crossing segments AB and CD.

    Returns (distance, s, px, py, qx, qy): P = A + s (B - A) on AB and Q on CD, mm.
    For crossing segments the distance is 0 and P = Q is an endpoint-nearest point.
    """
    d2, s_best, px, py, qx, qy = segment_closest_sq(ax, ay, bx, by, cx, cy, dx, dy)
    return math.sqrt(d2), s_best, px, py, qx, qy


@njit(cache=True, inline="always")
def segment_closest_sq(ax, ay, bx, by, cx, cy, dx, dy):
    """As :func:`segment_closest` but returns the squared distance (mm^2): no roots.

    Returns (distance^2, s, px, py, qx, qy).
    """
    best, _, qx, qy = project_sq(ax, ay, cx, cy, dx, dy)
    s_best, px, py = 0.0, ax, ay
    d, _, fx, fy = project_sq(bx, by, cx, cy, dx, dy)
    if d < best:
        best, s_best, px, py, qx, qy = d, 1.0, bx, by, fx, fy
    d, t, fx, fy = project_sq(cx, cy, ax, ay, bx, by)
    if d < best:
        best, s_best, px, py, qx, qy = d, t, fx, fy, cx, cy
    d, t, fx, fy = project_sq(dx, dy, ax, ay, bx, by)
    if d < best:
        best, s_best, px, py, qx, qy = d, t, fx, fy, dx, dy
    return best, s_best, px, py, qx, qy


@njit(cache=True, inline="always")
def point_segment_distance(px, py, ax, ay, bx, by):
    """Distance from point P to segment AB, mm."""
    return math.sqrt(_point_segment_sq(px, py, ax, ay, bx, by))


@njit(cache=True, inline="always")
def beta_segment(bx, by, alpha_deg, beta_deg, l_alpha, s0, s1):
    """Endpoints (x0, y0, x1, y1) of the beta collision segment, mm (Eqs. 1-2)."""
    a = alpha_deg * DEG
    ab = (alpha_deg + beta_deg) * DEG
    ex = bx + l_alpha * math.cos(a)
    ey = by + l_alpha * math.sin(a)
    c = math.cos(ab)
    s = math.sin(ab)
    return ex + s0 * c, ey + s0 * s, ex + s1 * c, ey + s1 * s


def _per_robot(values, i):
    """``values[i]`` for a per-robot array, ``values`` itself for a scalar (the same
    value for every robot). Usable in numba kernels (see the overload below)."""
    return values if np.ndim(values) == 0 else values[i]


@overload(_per_robot, inline="always")
def _per_robot_nb(values, i):
    if isinstance(values, types.Array):
        return lambda values, i: values[i]
    return lambda values, i: values


@njit(cache=True, inline="always")
def _robot_segment(base_xy, angles, i, alpha_len, seg_start, seg_end):
    """:func:`beta_segment` of robot index ``i``: row ``i`` of ``base_xy`` (n, 2) mm and
    ``angles`` (n, 2) deg, element ``i`` of ``alpha_len``, ``seg_start``, ``seg_end`` ((n,)
    mm; a scalar stands for the same value for every robot)."""
    return beta_segment(base_xy[i, 0], base_xy[i, 1], angles[i, 0], angles[i, 1],
                        _per_robot(alpha_len, i), _per_robot(seg_start, i), _per_robot(seg_end, i))


@njit(cache=True)
def pair_distances(base_xy, angles, pairs, alpha_len, seg_start, seg_end):
    """Segment distance of each robot pair, mm.

    Parameters
    ----------
    base_xy : (n, 2) float64, mm
    angles : (n, 2) float64, (alpha, beta) deg
    pairs : (p, 2) int64, robot indices
    alpha_len, seg_start, seg_end : (n,) float64, mm
        Each robot's alpha arm length and beta collision segment (start, end along its
        beta arm); a scalar stands for the same value for every robot.

    Returns
    -------
    (p,) float64
    """
    out = np.empty(pairs.shape[0])
    for k in range(pairs.shape[0]):
        a0x, a0y, a1x, a1y = _robot_segment(base_xy, angles, pairs[k, 0], alpha_len, seg_start,
                                            seg_end)
        b0x, b0y, b1x, b1y = _robot_segment(base_xy, angles, pairs[k, 1], alpha_len, seg_start,
                                            seg_end)
        out[k] = segment_distance(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y)
    return out


@njit(cache=True)
def fiducial_distances(base_xy, angles, robot_fid, fid_xy, alpha_len, seg_start, seg_end,
                       fid_end_xy=None):
    """Distance from each (robot, obstacle) pair's beta segment to the obstacle, mm.

    Parameters
    ----------
    base_xy, angles, alpha_len, seg_start, seg_end : as :func:`pair_distances`
    robot_fid : (p, 2) int64 of (robot index, obstacle index)
    fid_xy : (m, 2) float64, mm: obstacle centres (a fiducial) or first ends (a segment)
    fid_end_xy : (m, 2) float64, mm, optional
        Second end of each obstacle segment (== ``fid_xy`` for a point obstacle); None:
        every obstacle is the point ``fid_xy``.

    Returns
    -------
    (p,) float64
    """
    out = np.empty(robot_fid.shape[0])
    for k in range(robot_fid.shape[0]):
        f = robot_fid[k, 1]
        a0x, a0y, a1x, a1y = _robot_segment(base_xy, angles, robot_fid[k, 0], alpha_len,
                                            seg_start, seg_end)
        fx = fid_xy[f, 0]
        fy = fid_xy[f, 1]
        if fid_end_xy is None:
            out[k] = point_segment_distance(fx, fy, a0x, a0y, a1x, a1y)
        elif fid_end_xy[f, 0] == fx and fid_end_xy[f, 1] == fy:
            out[k] = point_segment_distance(fx, fy, a0x, a0y, a1x, a1y)
        else:
            out[k] = segment_distance(a0x, a0y, a1x, a1y, fx, fy, fid_end_xy[f, 0],
                                      fid_end_xy[f, 1])
    return out
