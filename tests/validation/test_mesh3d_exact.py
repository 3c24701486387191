"""Tests of the exact FCL distance (validation/mesh3d/exact.py)."""
from __future__ import annotations

import fcl
import numpy as np
import pytest

from rfp_twin.models.geometry import LINKS
from tests.validation.conftest import PITCH, sdss_geometry, sdss_models, whole_link_distance
from rfp_twin.validation.mesh3d import link_pose
from rfp_twin.validation.mesh3d.exact import ExactDistance
from rfp_twin.validation.mesh3d.pair import pair_piece_bounds

MODELS = sdss_models()


def test_a_piece_inside_another_counts_as_touching():
    # robot B's ferrule placed inside robot A's beta bar: the surfaces do not meet, so
    # FCL's BVH distance is positive; the solid distance is 0
    ex = ExactDistance(MODELS)
    k = LINKS.index("beta")
    za = MODELS.offset_z[k]
    pose_a = (0.0, 0.0, 0.0)
    pose_b = (0.0, 0.0, 0.0)
    zb = za + 1.8                      # ferrule (z -1..0 in its frame) -> bar height 0.8..1.8
    ferrule = MODELS.kind_ptr[k] + 2
    bar = MODELS.kind_ptr[k]
    o1 = fcl.CollisionObject(MODELS.bvh[bar], fcl.Transform(np.eye(3), np.array([0, 0, za])))
    o2 = fcl.CollisionObject(MODELS.bvh[ferrule], fcl.Transform(np.eye(3), np.array([0, 0, zb])))
    assert fcl.distance(o1, o2) > 0.1
    bounds = np.full(9, -1.0)
    assert ex.distance(k, pose_a, za, k, pose_b, zb, bounds) == 0.0
    assert ex.collides(k, pose_a, za, k, pose_b, zb, bounds)


def _posed(kind: str, base, alpha: float, beta: float):
    k = LINKS.index(kind)
    p = link_pose(MODELS, k, base, alpha, beta)
    return k, p[:3], p[3]


def test_exact_distance_is_the_whole_mesh_distance_and_pruning_keeps_it():
    geom = sdss_geometry()
    ex = ExactDistance(MODELS)
    rng = np.random.default_rng(12)
    # random configurations, and beta bars overlapping (b = 20 deg) or 0.15 mm apart
    configs = np.vstack([rng.uniform(0, 360, (58, 4)), [[0, 20, 180, 180], [0, 24.5, 180, 180]]])
    checked = hits = 0
    for ang in configs:
        for la, lb in (("beta", "beta"), ("alpha", "beta"), ("beta", "alpha")):
            ka, pa, za = _posed(la, (0.0, 0.0), *ang[:2])
            kb, pb, zb = _posed(lb, (PITCH, 0.0), *ang[2:])
            ref = whole_link_distance(geom, (0, 0), ang[:2], la, (PITCH, 0), ang[2:], lb)
            unpruned = ex.distance(ka, pa, za, kb, pb, zb, np.full(MODELS.max_piece_pairs,
                                                                   -np.inf))
            # the capsule bounds of every piece pair, as the check passes them
            _, bounds = pair_piece_bounds(np.deg2rad(ang)[None], PITCH, 0.0, ka, kb,
                                           MODELS.l_alpha, MODELS.kind_ptr, MODELS.cap,
                                           MODELS.zlim, MODELS.poly_ptr, MODELS.poly_xy,
                                           MODELS.max_piece_pairs)
            calls = ex.n_calls
            pruned = ex.distance(ka, pa, za, kb, pb, zb, bounds[0])
            assert ex.n_calls - calls <= MODELS.n_pieces(ka) * MODELS.n_pieces(kb)
            assert pruned == unpruned
            hits += unpruned == 0.0
            if ref > 1e-6:                       # surfaces apart: solid = surface distance
                assert unpruned == pytest.approx(ref, abs=1e-9)
                checked += 1
            assert ex.collides(ka, pa, za, kb, pb, zb, bounds[0]) == (unpruned <= 0.0)
            assert ex.collides(ka, pa, za, kb, pb, zb, bounds[0], 0.5) == (unpruned <= 0.5)
    assert checked > 100 and hits >= 1
    assert ex.n_evals == 60 * 3 * 4                     # distance twice, collides twice


def test_gjk_upper_bounds_are_never_below_the_exact_distance():
    # the pieces as convex solids (GJK): an upper bound of the exact distance, equal to
    # it on nearly every pose; at or below ``upper_above`` the exact value is returned
    ex = ExactDistance(MODELS)
    rng = np.random.default_rng(5)
    configs = np.vstack([rng.uniform(0, 360, (80, 4)), [[0, 20, 180, 180]]])
    equal = clear = overlaps = 0
    for ang in configs:
        for la, lb in (("beta", "beta"), ("alpha", "beta")):
            ka, pa, za = _posed(la, (0.0, 0.0), *ang[:2])
            kb, pb, zb = _posed(lb, (PITCH, 0.0), *ang[2:])
            bounds = np.full(MODELS.max_piece_pairs, -np.inf)
            exact = ex.distance(ka, pa, za, kb, pb, zb, bounds)
            calls, hull_calls = ex.n_calls, ex.n_hull_calls
            upper = ex.distance(ka, pa, za, kb, pb, zb, bounds, upper_above=0.0)
            assert ex.n_hull_calls > hull_calls
            assert upper >= exact - 1e-9
            if exact > 0.0:
                clear += 1
                equal += upper <= exact + 1e-6
                assert ex.n_calls == calls          # no BVH call for a clear pose
            else:                                   # overlap: GJK says 0, BVH confirms
                overlaps += 1
                assert upper == 0.0 and ex.n_calls > calls
    assert overlaps >= 1 and clear > 100 and equal >= 0.95 * clear
