"""Lower bounds of the 3D distance of two posed links (numba kernels; mm, rad).

Every convex collision piece is enclosed three times, in the frame of its link
(:class:`rfp_twin.validation.mesh3d.links.LinkModels`):

* a *3D capsule* (sphere-swept segment, fitted to the piece's vertices): tight for
  pieces that lean, such as the P1 prototype's rising tube, where the prisms below
  span the whole height of the lean;
* a vertical *capsule prism*: a 2D capsule (segment + radius, fitted to the piece's
  vertices so that every vertex is inside; a capsule is convex, so the whole piece is)
  times the piece's z interval;
* a vertical *hull prism*: the convex hull of the piece's vertices projected on the
  xy plane, times the same z interval. It contains the piece; for the procedural
  pieces (prisms and cylinders) it *is* the piece.

The distance of two product sets ``P x [z]`` and ``Q x [z']`` is exactly
``sqrt(d_xy^2 + d_z^2)`` (``d_xy`` the 2D distance, ``d_z`` the gap of the z
intervals). For capsules ``d_xy = max(0, seg_dist - r_u - r_v)`` (~0.05 us in numba;
when ``d_z = 0`` the signed value is kept); for hulls ``d_xy`` comes from a 2D GJK on
the two polygons, of which every iterate gives a valid lower bound ``v . w / |v|``
(~1 us). The hull value is computed only where the capsule value is below a given
``tight_below``. ``C``, the minimum over the piece pairs of two links, is a lower bound
of their true distance ``D`` (on the procedural SDSS-V meshes equal to it to 1e-12 mm),
against ~100-300 us for one FCL BVH distance: FCL is called only where ``C`` cannot
decide.

A link pose is ``(theta, x, y)``: world point ``= (x, y) + Rz(theta) p`` in the xy plane
for ``p`` in the link frame (the z offset of a link kind is constant).

Per-robot geometry (:mod:`rfp_twin.validation.mesh3d.scene`): the kernels' alpha-arm
argument ``place`` is either a float (every robot's alpha arm; objects at height 0, exact
poses: the nominal case) or a tuple ``(obj_la (n_obj,), obj_z0 (n_obj,), lp_slack (n_lp,
2), obj_g (n_obj, 2))``. The links are posed upright in a frame where their true (tilted)
points lie within ``s_xy`` (mm) horizontally of the posed ones, and vertically at
``z0 + g . (x, y)`` (a plane over the frame's xy: the object's height and its tilt relative
to the frame; ``(x, y)`` the posed point) from the posed height, within ``s_z`` (mm).
:func:`piece_bound_at` lowers the xy distance by ``s_xy`` and takes each piece's z interval
over its capsule's range of that plane, widened by ``s_z``: a lower bound still. It moves
with the link, so a bound with a tilt ``g`` is Lipschitz with each link's speed times ``1
+ |g|`` (the scene scales the speeds). With zero planes and slacks every value is
bit-identical to the float case.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.core import types
from numba.extending import overload

from rfp_twin.models.geometry import LINKS
from rfp_twin.validation.numerics import clamp01, closest_parameters, segment_distance

#: Piece pairs whose capsule bounds are within this of the smallest of their two links
#: also get the hull bound in :func:`store_pose_bounds_at`, mm.
HULL_WITHIN_MM = 1.0

#: The 3D capsule bound (cheap) is taken where the prism bound is below ``tight_below`` plus
#: this, mm; the hull bound (a 2D GJK, ~20x dearer) only below ``tight_below``.
CAPSULE3_WITHIN_MM = 1.0

#: Link kind codes used inside the kernels (index into :data:`rfp_twin.models.geometry.LINKS`).
BODY, ALPHA, BETA, FIDUCIAL = (LINKS.index(n) for n in ("body", "alpha", "beta", "fiducial"))


def obj_alpha(place, o):
    """Alpha arm of object ``o``, mm: ``place`` (a float) or ``place[0][o]``."""
    return place if isinstance(place, float) else place[0][o]


def obj_plane(place, o):
    """Height plane ``(z0, gx, gy)`` of object ``o`` (mm, 1, 1): zeros (``place`` a float)
    or ``(place[1][o], place[3][o, 0], place[3][o, 1])``."""
    if isinstance(place, float):
        return 0.0, 0.0, 0.0
    return place[1][o], place[3][o, 0], place[3][o, 1]


def pair_slack(place, p):
    """Slack ``(s_xy, s_z)`` of link pair ``p``, mm: zeros (``place`` a float) or
    ``place[2][p]``."""
    return (0.0, 0.0) if isinstance(place, float) else (place[2][p, 0], place[2][p, 1])


@overload(obj_alpha)
def _obj_alpha(place, o):
    if isinstance(place, types.Float):
        return lambda place, o: place
    return lambda place, o: place[0][o]


@overload(obj_plane)
def _obj_plane(place, o):
    if isinstance(place, types.Float):
        return lambda place, o: (0.0, 0.0, 0.0)
    return lambda place, o: (place[1][o], place[3][o, 0], place[3][o, 1])


@njit(cache=True)
def plane_range(plane, x0, y0, x1, y1, r):
    """Range ``(lo, hi)`` of ``z0 + g . (x, y)`` (``plane = (z0, gx, gy)``) over the capsule
    of segment (x0, y0)-(x1, y1) and radius r, mm; ``(z0, z0)`` for a flat plane."""
    z0, gx, gy = plane
    if gx == 0.0 and gy == 0.0:
        return z0, z0
    e0 = gx * x0 + gy * y0
    e1 = gx * x1 + gy * y1
    er = r * math.sqrt(gx * gx + gy * gy)
    return z0 + min(e0, e1) - er, z0 + max(e0, e1) + er


@overload(pair_slack)
def _pair_slack(place, p):
    if isinstance(place, types.Float):
        return lambda place, p: (0.0, 0.0)
    return lambda place, p: (place[2][p, 0], place[2][p, 1])


@njit(cache=True)
def pose(kind, a, b, la):
    """(theta, ox, oy): link frame rotation and xy offset from the base (rad, mm)."""
    if kind == ALPHA:
        return a, 0.0, 0.0
    if kind == BETA:
        return a + b, la * math.cos(a), la * math.sin(a)
    return 0.0, 0.0, 0.0


@njit(cache=True)
def _support(pxy, k0, k1, c, s, ox, oy, dx, dy):
    """Vertex of polygon pxy[k0:k1] (posed: rotation (c, s), offset (ox, oy)) furthest
    along world direction (dx, dy); returns its world coordinates."""
    lx = c * dx + s * dy            # direction in the link frame
    ly = -s * dx + c * dy
    best = -np.inf
    kb = k0
    for k in range(k0, k1):
        d = pxy[k, 0] * lx + pxy[k, 1] * ly
        if d > best:
            best = d
            kb = k
    return ox + c * pxy[kb, 0] - s * pxy[kb, 1], oy + s * pxy[kb, 0] + c * pxy[kb, 1]


@njit(cache=True)
def poly_lower_bound(u, v, ca, sa, xa, ya, cb, sb, xb, yb, pptr, pxy):
    """Lower bound of the distance of two posed convex polygons (2D GJK).

    Iterates GJK on the Minkowski difference ``A - B``; at every iteration ``v . w /
    |v|`` (``v`` the current closest point, ``w`` the support point in direction
    ``-v``) bounds the distance from below, whatever the convergence, so the result
    is always a valid lower bound (exact when GJK converges). 0 when they overlap.
    """
    a0, a1, b0, b1 = pptr[u], pptr[u + 1], pptr[v], pptr[v + 1]
    ax, ay = _support(pxy, a0, a1, ca, sa, xa, ya, 1.0, 0.0)
    bx, by = _support(pxy, b0, b1, cb, sb, xb, yb, -1.0, 0.0)
    s0x = ax - bx
    s0y = ay - by
    s1x = 0.0
    s1y = 0.0
    ns = 1
    vx = s0x
    vy = s0y
    lb = 0.0
    for _ in range(64):
        vv = vx * vx + vy * vy
        if vv <= 1e-24:
            return 0.0
        ax, ay = _support(pxy, a0, a1, ca, sa, xa, ya, -vx, -vy)
        bx, by = _support(pxy, b0, b1, cb, sb, xb, yb, vx, vy)
        wx = ax - bx
        wy = ay - by
        vw = vx * wx + vy * wy
        nv = math.sqrt(vv)
        if vw / nv > lb:
            lb = vw / nv
        if vv - vw <= 1e-12 * vv + 1e-18:
            break
        if ns == 1:
            # segment [s0, w]
            ex = wx - s0x
            ey = wy - s0y
            ee = ex * ex + ey * ey
            t = clamp01(-(s0x * ex + s0y * ey) / ee) if ee > 0.0 else 0.0
            if t <= 0.0:
                vx, vy = s0x, s0y
            elif t >= 1.0:
                s0x, s0y = wx, wy
                vx, vy = wx, wy
            else:
                s1x, s1y = wx, wy
                ns = 2
                vx = s0x + t * ex
                vy = s0y + t * ey
        else:
            # triangle (s0, s1, w): origin inside -> overlap
            c1 = (s1x - s0x) * (wy - s0y) - (s1y - s0y) * (wx - s0x)
            d0 = (s1x - s0x) * (-s0y) - (s1y - s0y) * (-s0x)
            d1 = (wx - s1x) * (-s1y) - (wy - s1y) * (-s1x)
            d2 = (s0x - wx) * (-wy) - (s0y - wy) * (-wx)
            if c1 != 0.0 and d0 * c1 >= 0.0 and d1 * c1 >= 0.0 and d2 * c1 >= 0.0:
                return 0.0
            # keep the closest of the edges (s0, w) and (s1, w) (w is new, so in the edge)
            best = np.inf
            keep_x = 0.0
            keep_y = 0.0
            for e in range(2):
                px = s0x if e == 0 else s1x
                py = s0y if e == 0 else s1y
                ex = wx - px
                ey = wy - py
                ee = ex * ex + ey * ey
                t = clamp01(-(px * ex + py * ey) / ee) if ee > 0.0 else 0.0
                cx = px + t * ex
                cy = py + t * ey
                dd = cx * cx + cy * cy
                if dd < best:
                    best = dd
                    keep_x, keep_y = px, py
                    vx, vy = cx, cy
            s0x, s0y = keep_x, keep_y
            s1x, s1y = wx, wy
    return max(lb, 0.0)


@njit(cache=True)
def segment_distance3(p0x, p0y, p0z, p1x, p1y, p1z, q0x, q0y, q0z, q1x, q1y, q1z):
    """Distance of the 3D segments p0-p1 and q0-q1, mm (closest points of the two
    segments, clamped; either may be a point)."""
    d1x, d1y, d1z = p1x - p0x, p1y - p0y, p1z - p0z
    d2x, d2y, d2z = q1x - q0x, q1y - q0y, q1z - q0z
    rx, ry, rz = p0x - q0x, p0y - q0y, p0z - q0z
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    c = d1x * rx + d1y * ry + d1z * rz
    b = d1x * d2x + d1y * d2y + d1z * d2z
    den = a * e - b * b
    s = clamp01((b * f - c * e) / den) if den > 1e-18 * a * e else 0.0
    s, t = closest_parameters(a, b, c, e, f, s, 1e-18)
    dx = p0x + d1x * s - q0x - d2x * t
    dy = p0y + d1y * s - q0y - d2y * t
    dz = p0z + d1z * s - q0z - d2z * t
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@njit(cache=True, inline="always")
def posed(c, s, x, y, px, py):
    """Point (px, py) of a link frame rotated by (cos, sin) = (c, s) and moved by (x, y), mm."""
    return x + c * px - s * py, y + s * px + c * py


@njit(cache=True)
def capsule3_bound(u, v, ca, sa, xa, ya, plane_a, cb, sb, xb, yb, plane_b, s_xy, s_z, cap):
    """Lower bound from the 3D capsules of pieces u and v (``cap`` columns 5-11), mm.

    Each capsule is posed (rotation ``(c, s)``, offset ``(x, y)``) and its axis lifted by
    its height plane ``z0 + g . (x, y)`` (an affine shear: the segment stays a segment;
    a ball of radius r becomes a set within ``r (1 + |g|)`` of its sheared centre); the
    slacks are subtracted. Negative when the capsules overlap.
    """
    z0a, gxa, gya = plane_a
    z0b, gxb, gyb = plane_b
    a0x, a0y = posed(ca, sa, xa, ya, cap[u, 5], cap[u, 6])
    a1x, a1y = posed(ca, sa, xa, ya, cap[u, 8], cap[u, 9])
    b0x, b0y = posed(cb, sb, xb, yb, cap[v, 5], cap[v, 6])
    b1x, b1y = posed(cb, sb, xb, yb, cap[v, 8], cap[v, 9])
    d = segment_distance3(a0x, a0y, cap[u, 7] + z0a + gxa * a0x + gya * a0y,
                          a1x, a1y, cap[u, 10] + z0a + gxa * a1x + gya * a1y,
                          b0x, b0y, cap[v, 7] + z0b + gxb * b0x + gyb * b0y,
                          b1x, b1y, cap[v, 10] + z0b + gxb * b1x + gyb * b1y)
    grow_a = 1.0 + math.sqrt(gxa * gxa + gya * gya)
    grow_b = 1.0 + math.sqrt(gxb * gxb + gyb * gyb)
    return d - cap[u, 11] * grow_a - cap[v, 11] * grow_b - s_xy - s_z


@njit(cache=True)
def piece_bound(u, v, tha, xa, ya, thb, xb, yb, cap, zlim, pptr, pxy, tight_below):
    """Lower bound of the distance of pieces u (pose a) and v (pose b), mm (links at
    height 0, exact poses: :func:`piece_bound_at` with zero planes and slacks)."""
    return piece_bound_at(u, v, tha, xa, ya, (0.0, 0.0, 0.0), thb, xb, yb, (0.0, 0.0, 0.0),
                          0.0, 0.0, cap, zlim, pptr, pxy, tight_below)


@njit(cache=True)
def piece_bound_at(u, v, tha, xa, ya, plane_a, thb, xb, yb, plane_b, s_xy, s_z, cap, zlim, pptr,
                   pxy, tight_below):
    """Lower bound of the distance of pieces u (pose a, height plane ``plane_a``) and v
    (pose b, ``plane_b``), mm, with slacks ``s_xy``, ``s_z`` (mm, see the module docstring).

    Capsule prisms first; where that is below ``tight_below`` the 3D capsules
    (:func:`capsule3_bound`), then where still below it the vertical prisms of the
    pieces' xy hulls (GJK lower bound), keeping the largest. Each is a lower bound of the
    true distance (the interval bounds of :mod:`rfp_twin.validation.mesh3d.broadphase`
    need no more: they rest on the true distance being Lipschitz).
    """
    return piece_bound_cs(u, v, math.cos(tha), math.sin(tha), xa, ya, plane_a, math.cos(thb),
                          math.sin(thb), xb, yb, plane_b, s_xy, s_z, cap, zlim, pptr, pxy,
                          tight_below)


@njit(cache=True)
def piece_bound_cs(u, v, ca, sa, xa, ya, plane_a, cb, sb, xb, yb, plane_b, s_xy, s_z, cap, zlim,
                   pptr, pxy, tight_below):
    """:func:`piece_bound_at` with the link rotations given as cosine and sine (computed once
    per link, not once per piece pair)."""
    a0x, a0y = posed(ca, sa, xa, ya, cap[u, 0], cap[u, 1])
    a1x, a1y = posed(ca, sa, xa, ya, cap[u, 2], cap[u, 3])
    b0x, b0y = posed(cb, sb, xb, yb, cap[v, 0], cap[v, 1])
    b1x, b1y = posed(cb, sb, xb, yb, cap[v, 2], cap[v, 3])
    dxy = segment_distance(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y) - cap[u, 4] - cap[v, 4] - s_xy
    za0, za1 = plane_range(plane_a, a0x, a0y, a1x, a1y, cap[u, 4])
    zb0, zb1 = plane_range(plane_b, b0x, b0y, b1x, b1y, cap[v, 4])
    dz = max(0.0, (zlim[u, 0] + za0) - (zlim[v, 1] + zb1),
             (zlim[v, 0] + zb0) - (zlim[u, 1] + za1)) - s_z
    if dz > 0.0:
        x = max(dxy, 0.0)
        out = math.sqrt(x * x + dz * dz)
    else:
        out = dxy
    if out < tight_below + CAPSULE3_WITHIN_MM:
        c3 = capsule3_bound(u, v, ca, sa, xa, ya, plane_a, cb, sb, xb, yb, plane_b, s_xy, s_z,
                            cap)
        if c3 > out:
            out = c3
    if out < tight_below:
        lp = max(poly_lower_bound(u, v, ca, sa, xa, ya, cb, sb, xb, yb, pptr, pxy) - s_xy, 0.0)
        f = math.sqrt(lp * lp + dz * dz) if dz > 0.0 else lp
        if f > out:
            out = f
    return out


@njit(cache=True)
def link_bound(ka, kb, tha, xa, ya, thb, xb, yb, kptr, cap, zlim, pptr, pxy, tight_below):
    """Lower bound C of the distance of link kind ka (pose a) and kb (pose b), mm: the
    minimum of :func:`piece_bound` over their piece pairs."""
    return link_bound_at(ka, kb, tha, xa, ya, (0.0, 0.0, 0.0), thb, xb, yb, (0.0, 0.0, 0.0),
                         0.0, 0.0, kptr, cap, zlim, pptr, pxy, tight_below)


@njit(cache=True)
def link_bound_at(ka, kb, tha, xa, ya, plane_a, thb, xb, yb, plane_b, s_xy, s_z, kptr, cap, zlim,
                  pptr, pxy, tight_below):
    """:func:`link_bound` of links with height planes and slacks (mm)."""
    best = np.inf
    ca, sa, cb, sb = math.cos(tha), math.sin(tha), math.cos(thb), math.sin(thb)
    for u in range(kptr[ka], kptr[ka + 1]):
        for v in range(kptr[kb], kptr[kb + 1]):
            d = piece_bound_cs(u, v, ca, sa, xa, ya, plane_a, cb, sb, xb, yb, plane_b, s_xy, s_z,
                               cap, zlim, pptr, pxy, tight_below)
            if d < best:
                best = d
    return best


@njit(cache=True)
def store_pose_bounds(poses, bounds, k, ka, kb, tha, xa, ya, thb, xb, yb,
                      kptr, cap, zlim, pptr, pxy):
    """Row ``k`` of ``poses`` (both link poses) and of ``bounds`` (the capsule bound of
    every piece pair, row-major over (u, v)) for links ka (pose a) and kb (pose b)."""
    store_pose_bounds_at(poses, bounds, k, ka, kb, tha, xa, ya, (0.0, 0.0, 0.0), thb, xb, yb,
                         (0.0, 0.0, 0.0), 0.0, 0.0, kptr, cap, zlim, pptr, pxy)


@njit(cache=True)
def store_pose_bounds_at(poses, bounds, k, ka, kb, tha, xa, ya, plane_a, thb, xb, yb, plane_b,
                         s_xy, s_z, kptr, cap, zlim, pptr, pxy):
    """:func:`store_pose_bounds` of links with height planes and slacks (mm).

    The capsule prisms and 3D capsules of every piece pair first; the (costlier) hull
    bound only for the piece pairs within :data:`HULL_WITHIN_MM` of the smallest of those,
    the ones FCL may visit (a far piece pair keeps its capsule value: a lower bound still).
    """
    poses[k] = (tha, xa, ya, thb, xb, yb)
    ca, sa, cb, sb = math.cos(tha), math.sin(tha), math.cos(thb), math.sin(thb)
    lowest = np.inf
    j = 0
    for u in range(kptr[ka], kptr[ka + 1]):
        for v in range(kptr[kb], kptr[kb + 1]):
            f = max(piece_bound_cs(u, v, ca, sa, xa, ya, plane_a, cb, sb, xb, yb, plane_b, s_xy,
                                   s_z, cap, zlim, pptr, pxy, -np.inf),
                    capsule3_bound(u, v, ca, sa, xa, ya, plane_a, cb, sb, xb, yb, plane_b, s_xy,
                                   s_z, cap))
            bounds[k, j] = f
            if f < lowest:
                lowest = f
            j += 1
    # tightening raises values (and so the smallest): repeat until every piece pair within
    # HULL_WITHIN_MM of the smallest is tight, so the row's minimum is the tight link bound
    nb = kptr[kb + 1] - kptr[kb]
    done = np.zeros(j, dtype=np.bool_)
    changed = True
    while changed:
        changed = False
        for jj in range(j):
            if not done[jj] and bounds[k, jj] < lowest + HULL_WITHIN_MM:
                u = kptr[ka] + jj // nb
                v = kptr[kb] + jj % nb
                bounds[k, jj] = piece_bound_cs(u, v, ca, sa, xa, ya, plane_a, cb, sb, xb, yb,
                                               plane_b, s_xy, s_z, cap, zlim, pptr, pxy, np.inf)
                done[jj] = True
                changed = True
        if changed:
            lowest = np.inf
            for jj in range(j):
                if bounds[k, jj] < lowest:
                    lowest = bounds[k, jj]
