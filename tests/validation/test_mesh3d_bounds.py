"""Tests of the 3D lower bounds (validation/mesh3d/bounds.py)."""
from __future__ import annotations

import math

import numpy as np

from rfp_twin.models.geometry import LINKS
from tests.validation.conftest import sdss_geometry, sdss_models, whole_link_distance
from rfp_twin.validation.mesh3d import link_pose
from rfp_twin.validation.mesh3d.bounds import link_bound, poly_lower_bound, store_pose_bounds
from rfp_twin.validation.numerics import segment_distance_np


def _polygon_distance(p, q) -> float:
    """Brute force: 0 if the convex CCW polygons overlap, else the least vertex-edge distance."""
    def inside(pts, poly):
        for x in pts:
            e = np.roll(poly, -1, axis=0) - poly
            w = x - poly
            if np.all(e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0] >= 0):
                return True
        return False

    def cross(a, b, c, d):
        def o(p_, q_, r_):
            return np.sign((q_[0] - p_[0]) * (r_[1] - p_[1]) - (q_[1] - p_[1]) * (r_[0] - p_[0]))

        return o(a, b, c) != o(a, b, d) and o(c, d, a) != o(c, d, b)

    if inside(p, q) or inside(q, p):
        return 0.0
    for i in range(len(p)):
        for j in range(len(q)):
            if cross(p[i], p[(i + 1) % len(p)], q[j], q[(j + 1) % len(q)]):
                return 0.0
    best = np.inf
    for a, b in ((p, q), (q, p)):
        for i in range(len(b)):
            s0, s1 = b[i], b[(i + 1) % len(b)]
            best = min(best, segment_distance_np(a, a, s0, s1).min())
    return float(best)


def test_hull_prism_bound_is_the_polygon_distance_and_never_above_it():
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(7)
    gaps = []
    for _ in range(300):
        a = rng.normal(size=(rng.integers(3, 15), 2)) * rng.uniform(0.3, 3)
        b = rng.normal(size=(rng.integers(3, 15), 2)) * rng.uniform(0.3, 3)
        a, b = a[ConvexHull(a).vertices], b[ConvexHull(b).vertices]
        pxy = np.vstack([a, b])
        pptr = np.array([0, len(a), len(a) + len(b)])
        t1, t2 = rng.uniform(0, 2 * np.pi, 2)
        ox, oy = rng.normal(size=2) * 4
        lb = poly_lower_bound(0, 1, math.cos(t1), math.sin(t1), 0.0, 0.0, math.cos(t2),
                              math.sin(t2), ox, oy, pptr, pxy)

        def rot(t):
            return np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])

        ref = _polygon_distance(a @ rot(t1).T, b @ rot(t2).T + [ox, oy])
        gaps.append(ref - lb)
    gaps = np.array(gaps)
    assert gaps.min() > -1e-9          # a lower bound
    assert gaps.max() < 1e-9           # and exact (GJK converges on polygons)


def test_link_bounds_stay_below_the_mesh_distance_and_hulls_tighten_capsules():
    geom, m = sdss_geometry(), sdss_models()
    rng = np.random.default_rng(8)
    kinds = [("alpha", "beta"), ("beta", "beta"), ("beta", "alpha"), ("alpha", "alpha"),
             ("body", "beta")]
    poses = np.empty((1, 6))
    rows = np.empty((1, m.max_piece_pairs))
    gaps = []
    for ang in rng.uniform(0, 360, (40, 4)):
        base_b = (rng.uniform(12, 26), rng.uniform(-6, 6))
        for la, lb in kinds:
            ka, kb = LINKS.index(la), LINKS.index(lb)
            pa = link_pose(m, ka, (0.0, 0.0), *ang[:2])[:3]
            pb = link_pose(m, kb, base_b, *ang[2:])[:3]
            geo = (m.kind_ptr, m.cap, m.zlim, m.poly_ptr, m.poly_xy)
            capsules = link_bound(ka, kb, *pa, *pb, *geo, -np.inf)
            tight = link_bound(ka, kb, *pa, *pb, *geo, np.inf)
            d = whole_link_distance(geom, (0, 0), ang[:2], la, base_b, ang[2:], lb)
            assert capsules <= tight + 1e-12
            assert max(tight, 0.0) <= d + 1e-9                 # a lower bound
            rows[:] = np.inf
            store_pose_bounds(poses, rows, 0, ka, kb, *pa, *pb, *geo)
            np.testing.assert_array_equal(poses[0], [*pa, *pb])
            npp = m.n_pieces(ka) * m.n_pieces(kb)
            assert rows[0, :npp].min() == tight and np.all(np.isinf(rows[0, npp:]))
            if d > 0:
                gaps.append(d - tight)
    # on the procedural prisms the hull-prism bound is the distance itself
    assert len(gaps) > 100 and max(gaps) < 1e-7
