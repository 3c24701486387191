"""Two robots of one design, many configurations: bounds, exact distances, collisions.

What the buffer calibration (:mod:`rfp_twin.validation.buffer`) compares the 2D model with: robot
A's base at the origin, robot B's at ``offset_xy`` (mm); configurations are ``(n, 4)``
arrays of degrees ``(alpha_A, beta_A, alpha_B, beta_B)``. Lower bounds come from the
numba kernels of :mod:`rfp_twin.validation.mesh3d.bounds`; FCL is called only where they cannot
decide (:mod:`rfp_twin.validation.mesh3d.exact`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.geometry import LINKS
from rfp_twin.validation.mesh3d.bounds import link_bound, pose, store_pose_bounds
from rfp_twin.validation.mesh3d.exact import ExactDistance
from rfp_twin.validation.mesh3d.links import ROBOT_KINDS, LinkModels


@njit(cache=True)
def _pair_bounds(ang, ox, oy, lp_ka, lp_kb, la, kptr, cap, zlim, pptr, pxy, tight_below):
    """Lower bounds (n, n_lp) of every link pair of robot A (base at the origin) and
    robot B (base at (ox, oy)) for configurations ``ang`` (n, 4) rad: (aA, bA, aB, bB)."""
    n = ang.shape[0]
    out = np.empty((n, len(lp_ka)))
    for k in range(n):
        for p in range(len(lp_ka)):
            ka = lp_ka[p]
            kb = lp_kb[p]
            tha, xa, ya = pose(ka, ang[k, 0], ang[k, 1], la)
            thb, xb, yb = pose(kb, ang[k, 2], ang[k, 3], la)
            out[k, p] = link_bound(ka, kb, tha, xa, ya, thb, xb + ox, yb + oy, kptr, cap, zlim,
                                   pptr, pxy, tight_below)
    return out


@njit(cache=True)
def pair_piece_bounds(ang, ox, oy, ka, kb, la, kptr, cap, zlim, pptr, pxy, max_pp):
    """Poses (n, 6) and piece-pair bounds (n, max_pp) of one link pair (ka of A, kb of B)."""
    n = ang.shape[0]
    poses = np.empty((n, 6))
    bounds = np.full((n, max_pp), np.inf)
    for k in range(n):
        tha, xa, ya = pose(ka, ang[k, 0], ang[k, 1], la)
        thb, xb, yb = pose(kb, ang[k, 2], ang[k, 3], la)
        store_pose_bounds(poses, bounds, k, ka, kb, tha, xa, ya, thb, xb + ox, yb + oy,
                          kptr, cap, zlim, pptr, pxy)
    return poses, bounds


class RobotPair:
    """Two robots of one design, robot B's base at ``offset_xy`` from robot A's.

    Batches of configurations ``angles`` are ``(n, 4)`` arrays of degrees
    ``(alpha_A, beta_A, alpha_B, beta_B)``. The link pairs compared are those that can
    touch at this base distance (:meth:`LinkModels.can_touch`).

    Methods
    -------
    bounds(angles) : (n,) lower bounds of the 3D distance (hull prisms, numba), mm
    distances(angles) : (n,) exact 3D (solid) distances with FCL, mm
    collides(angles, min_gap_mm) : (n,) bool, exact (bounds first, FCL where undecided)
    """

    def __init__(self, models: LinkModels, offset_xy, min_gap_mm: float = 0.0):
        self.models = models
        self.offset = np.asarray(offset_xy, dtype=np.float64).reshape(2)
        rows = models.link_pairs(ROBOT_KINDS, ROBOT_KINDS, float(np.hypot(*self.offset)),
                                 min_gap_mm)
        arr = np.asarray(rows, dtype=np.int64).reshape(-1, 2)
        self.lp_ka = np.ascontiguousarray(arr[:, 0])
        self.lp_kb = np.ascontiguousarray(arr[:, 1])
        self.link_names = [(LINKS[a], LINKS[b]) for a, b in rows]
        self._exact = ExactDistance(models)

    @property
    def n_fcl_calls(self) -> int:
        """FCL calls made so far."""
        return self._exact.n_calls

    def _rad(self, angles) -> np.ndarray:
        a = np.ascontiguousarray(np.deg2rad(np.asarray(angles, dtype=np.float64).reshape(-1, 4)))
        if not np.all(np.isfinite(a)):
            raise field_error(SpecError, "angles", "NaN/inf", "finite angles in degrees",
                              "RobotPair")
        return a

    def link_bounds(self, angles) -> np.ndarray:
        """(n, n_link_pairs) lower bounds per link pair, mm."""
        m = self.models
        if len(self.lp_ka) == 0:
            return np.full((len(np.asarray(angles).reshape(-1, 4)), 0), np.inf)
        return _pair_bounds(self._rad(angles), float(self.offset[0]), float(self.offset[1]),
                            self.lp_ka, self.lp_kb, m.l_alpha, m.kind_ptr, m.cap, m.zlim,
                            m.poly_ptr, m.poly_xy, np.inf)

    def bounds(self, angles) -> np.ndarray:
        """(n,) lower bound of the 3D distance of the two robots, mm."""
        lb = self.link_bounds(angles)
        return lb.min(axis=1) if lb.shape[1] else np.full(lb.shape[0], np.inf)

    def _per_link(self, angles, fn):
        ang = self._rad(angles)
        lb = self.link_bounds(angles)
        m = self.models
        n = len(ang)
        out = [None] * n
        for p in range(len(self.lp_ka)):
            ka, kb = int(self.lp_ka[p]), int(self.lp_kb[p])
            poses, pb = pair_piece_bounds(ang, float(self.offset[0]), float(self.offset[1]),
                                           ka, kb, m.l_alpha, m.kind_ptr, m.cap, m.zlim,
                                           m.poly_ptr, m.poly_xy, m.max_piece_pairs)
            for k in range(n):
                out[k] = fn(out[k], k, p, ka, kb, poses[k], pb[k], lb[k])
        return out

    def distances(self, angles, with_links: bool = False):
        """Exact 3D distances (FCL, solid), mm, (n,); with ``with_links`` also the
        closest link pair ``(link_a, link_b)`` of each configuration."""
        m = self.models

        def fn(state, k, p, ka, kb, pose, pb, lb_row):
            best, arg = state if state is not None else (math.inf, -1)
            if lb_row[p] >= best:
                return best, arg
            d = self._exact.distance(ka, pose[:3], m.offset_z[ka], kb, pose[3:],
                                     m.offset_z[kb], pb)
            return (d, p) if d < best else (best, arg)

        res = self._per_link(angles, fn)
        d = np.array([r[0] if r is not None else math.inf for r in res])
        if with_links:
            return d, [self.link_names[r[1]] if r is not None and r[1] >= 0 else ("", "")
                       for r in res]
        return d

    def collides(self, angles, min_gap_mm: float = 0.0) -> np.ndarray:
        """(n,) bool: the robots are within ``min_gap_mm`` (solid) at each configuration."""
        m = self.models
        gap = float(min_gap_mm)

        def fn(state, k, p, ka, kb, pose, pb, lb_row):
            if state or lb_row[p] > gap:
                return bool(state)
            return self._exact.collides(ka, pose[:3], m.offset_z[ka], kb, pose[3:],
                                        m.offset_z[kb], pb, gap)

        return np.array([bool(r) for r in self._per_link(angles, fn)], dtype=bool)
