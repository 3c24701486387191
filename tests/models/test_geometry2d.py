"""Tests of rfp_twin.models.geometry2d: the 2D capsule model of Sayres 2021 Sect. 3.3 (Eqs. 1-3).

The brute-force references below are independent numpy code: the distance between two
segments is the minimum over dense sample points (spacing <= 2 um) on each segment of the
exact distance to the other one, so the reference is never below the true distance and
at most 1 um above it.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.geometry2d import (beta_segment, fiducial_distances, pair_distances,
                               point_segment_distance, segment_closest, segment_closest_sq,
                               segment_distance, segments_within)
from rfp_twin.models.kinematics import forward

LA, LB, PITCH = 7.4, 15.0, 22.4
H = 2e-3            # brute-force sample spacing, mm
TOL = 1e-3          # = H / 2: brute-force resolution, mm
C10, S10 = math.cos(math.radians(10.0)), math.sin(math.radians(10.0))


# -- independent references ------------------------------------------------------------
def _samples(p, q):
    n = max(2, int(math.ceil(math.hypot(q[0] - p[0], q[1] - p[1]) / H)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(p, float) + t * (np.asarray(q, float) - np.asarray(p, float))


def _points_to_segment(pts, a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    u = b - a
    den = float(u @ u)
    t = np.zeros(len(pts)) if den == 0.0 else np.clip((pts - a) @ u / den, 0.0, 1.0)
    return np.hypot(*(a + t[:, None] * u - pts).T)


def brute_segment_distance(a, b, c, d) -> float:
    return float(min(_points_to_segment(_samples(a, b), c, d).min(),
                     _points_to_segment(_samples(c, d), a, b).min()))


def brute_point_segment_distance(p, a, b) -> float:
    return float(np.hypot(*(_samples(a, b) - np.asarray(p, float)).T).min())


def _unit(rng):
    t = rng.uniform(0, 2 * math.pi)
    return np.array([math.cos(t), math.sin(t)])


def random_segment_pairs(n: int, seed: int = 0):
    """(kind, a, b, c, d) with a mix of general, crossing, parallel, collinear, degenerate."""
    rng = np.random.default_rng(seed)
    kinds = ["general", "crossing", "parallel", "collinear", "degenerate", "touching"]
    out = []
    for k in range(n):
        kind = kinds[k % len(kinds)]
        if kind == "general":
            a, b, c, d = rng.uniform(-6, 6, size=(4, 2))
        elif kind == "crossing":       # both segments pass strictly through x
            x = rng.uniform(-3, 3, 2)
            u, v = _unit(rng), _unit(rng)
            a, b = x - rng.uniform(0.5, 5) * u, x + rng.uniform(0.5, 5) * u
            c, d = x - rng.uniform(0.5, 5) * v, x + rng.uniform(0.5, 5) * v
        elif kind == "parallel":       # c-d = a-b shifted sideways and along
            a = rng.uniform(-3, 3, 2)
            u = _unit(rng)
            b = a + rng.uniform(0.5, 8) * u
            off = rng.uniform(-4, 4) * np.array([-u[1], u[0]]) + rng.uniform(-10, 10) * u
            c, d = a + off, b + off
            if rng.random() < 0.5:
                c, d = d, c
        elif kind == "collinear":      # same line, overlapping or not
            o = rng.uniform(-3, 3, 2)
            u = _unit(rng)
            a, b, c, d = [o + t * u for t in rng.uniform(-6, 6, 4)]
        elif kind == "degenerate":     # one or both zero-length
            a, c, d = rng.uniform(-6, 6, size=(3, 2))
            b = a.copy()
            if rng.random() < 0.3:
                d = c.copy()
            if rng.random() < 0.5:
                a, b, c, d = c, d, a, b
        else:                          # an endpoint of CD lies on AB (T junction)
            a, b = rng.uniform(-6, 6, size=(2, 2))
            c = a + rng.uniform(0.1, 0.9) * (b - a)
            d = c + rng.uniform(0.5, 5) * _unit(rng)
        out.append((kind, *(np.asarray(p, float) for p in (a, b, c, d))))
    return out


def sd(a, b, c, d) -> float:
    return float(segment_distance(a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]))


# -- segment_distance ------------------------------------------------------------------
def test_segment_distance_matches_brute_force():
    worst = 0.0
    for kind, a, b, c, d in random_segment_pairs(2000):
        got = sd(a, b, c, d)
        ref = brute_segment_distance(a, b, c, d)
        assert got <= ref + 1e-9, (kind, a, b, c, d, got, ref)
        assert ref - got <= TOL, (kind, a, b, c, d, got, ref)
        # symmetric in the two segments and in the direction of each
        assert sd(c, d, a, b) == pytest.approx(got, abs=1e-12)
        assert sd(b, a, d, c) == pytest.approx(got, abs=1e-12)
        if kind in ("crossing", "touching"):
            assert got <= 1e-12, (kind, got)
        worst = max(worst, ref - got)
    assert worst > 0.0  # the reference is genuinely approximate, not the same code


@pytest.mark.parametrize("a, b, c, d, expected", [
    ((0, 0), (10, 0), (0, 3), (10, 3), 3.0),                 # parallel, facing
    ((0, 0), (10, 0), (12, 3), (20, 3), math.hypot(2, 3)),   # parallel, offset along
    ((0, 0), (10, 0), (5, -1), (5, 1), 0.0),                 # X crossing
    ((0, 0), (10, 0), (5, 0), (15, 0), 0.0),                 # collinear overlapping
    ((0, 0), (10, 0), (12, 0), (15, 0), 2.0),                # collinear disjoint
    ((0, 0), (10, 0), (10, 0), (10, 5), 0.0),                # shared endpoint
    ((0, 0), (10, 0), (4, 2), (6, 5), 2.0),                  # endpoint above interior
    ((1, 1), (1, 1), (4, 5), (4, 5), 5.0),                   # both degenerate
    ((3, 4), (3, 4), (0, 0), (10, 0), 4.0),                  # one degenerate
    ((0, 0), (4, 4), (0, 4), (2.0, 2.0), 0.0),               # T: endpoint on the other
    ((0, 0), (4, 4), (0, 4), (1.0, 3.0), math.sqrt(2.0)),    # stops short of the other
])
def test_segment_distance_exact_cases(a, b, c, d, expected):
    a, b, c, d = (np.asarray(p, float) for p in (a, b, c, d))
    assert sd(a, b, c, d) == pytest.approx(expected, abs=1e-12)
    assert sd(d, c, b, a) == pytest.approx(expected, abs=1e-12)


# -- point_segment_distance ------------------------------------------------------------
def test_point_segment_distance_matches_brute_force():
    rng = np.random.default_rng(11)
    for k in range(1000):
        p, a, b = rng.uniform(-6, 6, size=(3, 2))
        if k % 10 == 0:
            b = a.copy()                              # degenerate segment
        elif k % 10 == 1:
            p = a + rng.uniform(0, 1) * (b - a)       # point on the segment
        got = float(point_segment_distance(p[0], p[1], a[0], a[1], b[0], b[1]))
        ref = brute_point_segment_distance(p, a, b)
        assert got <= ref + 1e-9 and ref - got <= TOL, (p, a, b, got, ref)
        if k % 10 == 0:
            assert got == pytest.approx(math.hypot(*(p - a)), abs=1e-12)
        if k % 10 == 1:
            assert got <= 1e-9


@pytest.mark.parametrize("p, expected", [((5, 3), 3.0), ((-3, 4), 5.0), ((13, -4), 5.0),
                                         ((7, 0), 0.0), ((0, 0), 0.0)])
def test_point_segment_distance_exact(p, expected):
    assert point_segment_distance(p[0], p[1], 0.0, 0.0, 10.0, 0.0) == pytest.approx(expected)


# -- beta_segment (Eqs. 1-2) -----------------------------------------------------------
def test_beta_segment_follows_eqs_1_2():
    rng = np.random.default_rng(3)
    base = rng.uniform(-100, 100, size=(50, 2))
    ang = np.column_stack([rng.uniform(0, 360, 50), rng.uniform(0, 360, 50)])
    fiber, elbow = forward(base, ang, LA, LB)
    for k in range(50):
        x0, y0, x1, y1 = beta_segment(base[k, 0], base[k, 1], ang[k, 0], ang[k, 1], LA, 0.0, LB)
        np.testing.assert_allclose([x0, y0], elbow[k], atol=1e-12)
        np.testing.assert_allclose([x1, y1], fiber[k], atol=1e-12)
        # a sub-segment lies on the beta arm at the given distances from the beta axis
        s0, s1 = 2.0, 14.73
        x0, y0, x1, y1 = beta_segment(base[k, 0], base[k, 1], ang[k, 0], ang[k, 1], LA, s0, s1)
        u = (fiber[k] - elbow[k]) / LB
        np.testing.assert_allclose([x0, y0], elbow[k] + s0 * u, atol=1e-12)
        np.testing.assert_allclose([x1, y1], elbow[k] + s1 * u, atol=1e-12)


def test_beta_segment_explicit():
    # alpha 90: elbow at (0, 7.4); beta 90: arm towards -x
    x0, y0, x1, y1 = beta_segment(1.0, 2.0, 90.0, 90.0, LA, 0.0, LB)
    np.testing.assert_allclose([x0, y0, x1, y1], [1.0, 9.4, -14.0, 9.4], atol=1e-12)


# -- pair_distances / fiducial_distances -----------------------------------------------
def _pairs(*ij):
    return np.array(ij, dtype=np.int64).reshape(-1, 2)


def test_pair_distances_folded_neighbours():
    """Two folded (10, 170) SDSS-V robots: both beta segments point along -x at the same
    height, so along a row the gap is pitch - segment end (7.4 mm for the 15 mm segment);
    for the 60 deg neighbour the x-ranges overlap and the gap is pitch * sqrt(3) / 2."""
    base = np.array([[0.0, 0.0], [PITCH, 0.0], [PITCH / 2, PITCH * math.sqrt(3) / 2]])
    ang = np.tile([10.0, 170.0], (3, 1))
    seg = np.full(3, LB)
    d = pair_distances(base, ang, _pairs((0, 1), (0, 2), (1, 2)), LA, 0.0, seg)
    np.testing.assert_allclose(d, [PITCH - LB, PITCH * math.sqrt(3) / 2,
                                   PITCH * math.sqrt(3) / 2], atol=1e-9)
    # production segment end at cb = 2: 14.7276 mm
    seg2 = np.full(3, 16.2 - (math.hypot(2.0, 0.3) - 0.55))
    d2 = pair_distances(base, ang, _pairs((0, 1)), LA, 0.0, seg2)
    assert d2[0] == pytest.approx(PITCH - seg2[0], abs=1e-9)
    assert d2[0] == pytest.approx(7.67, abs=0.005)


def test_pair_distances_perpendicular_and_per_robot_segment_end():
    """Robot 0 at (0, 90): segment x = 7.4, y in [0, 15]. Robot 1 folded at (22.4, 0):
    segment tip at (22.4 + 7.4 cos10 - s1, 7.4 sin10). Its distance to the vertical
    segment is the x gap 7.4 cos10 + 15 - s1."""
    base = np.array([[0.0, 0.0], [PITCH, 0.0]])
    ang = np.array([[0.0, 90.0], [10.0, 170.0]])
    for s1 in (15.0, 12.0):
        d = pair_distances(base, ang, _pairs((0, 1), (1, 0)), LA, 0.0, np.array([15.0, s1]))
        expected = LA * C10 + PITCH - LA - s1
        np.testing.assert_allclose(d, [expected, expected], atol=1e-9)
    # a segment start beyond the elbow shortens robot 0 from below: y in [5, 15]
    d = pair_distances(base, ang, _pairs((0, 1)), LA, 5.0, np.array([15.0, 15.0]))
    assert d[0] == pytest.approx(math.hypot(LA * C10, 5.0 - LA * S10), abs=1e-9)


def test_pair_distances_facing_robots_overlap():
    base = np.array([[0.0, 0.0], [PITCH, 0.0]])
    ang = np.array([[0.0, 0.0], [180.0, 0.0]])  # both fully extended towards each other
    assert pair_distances(base, ang, _pairs((0, 1)), LA, 0.0, np.full(2, LB))[0] < 1e-12


def test_pair_distances_empty():
    out = pair_distances(np.zeros((2, 2)), np.zeros((2, 2)), np.empty((0, 2), np.int64),
                         LA, 0.0, np.full(2, LB))
    assert out.shape == (0,)


def test_fiducial_distances():
    base = np.array([[0.0, 0.0], [PITCH, 0.0]])
    ang = np.array([[10.0, 170.0], [0.0, 90.0]])
    fid = np.array([[-PITCH, 0.0], [PITCH + LA, 20.0]])
    d = fiducial_distances(base, ang, _pairs((0, 0), (1, 1), (1, 0)), fid, LA, 0.0,
                           np.full(2, LB))
    # robot 0 folded: its nearest point to (-22.4, 0) is the segment tip
    assert d[0] == pytest.approx(math.hypot(PITCH + LA * C10 - LB, LA * S10), abs=1e-9)
    # robot 1 beta arm vertical from (29.8, 0) to (29.8, 15): fiducial 5 mm above its tip
    assert d[1] == pytest.approx(5.0, abs=1e-9)
    # robot 1's elbow (29.8, 0) is its nearest point to (-22.4, 0)
    assert d[2] == pytest.approx(2 * PITCH + LA, abs=1e-9)


def test_closest_points_realise_the_distance():
    """segment_closest: the closest points that the Markov energy gradient relies on."""
    rng = np.random.default_rng(5)
    for _ in range(500):
        a, b, c, d = rng.uniform(-10, 10, size=(4, 2))
        dist, s, px, py, qx, qy = segment_closest(*a, *b, *c, *d)
        ref = segment_distance(*a, *b, *c, *d)
        if ref == 0.0:
            continue  # crossing: not used by the planner
        assert abs(dist - ref) < 1e-9
        np.testing.assert_allclose([px, py], a + s * (b - a), atol=1e-9)
        assert 0.0 <= s <= 1.0
        assert abs(np.hypot(px - qx, py - qy) - dist) < 1e-9
        d2, s2, *pq2 = segment_closest_sq(*a, *b, *c, *d)
        assert math.sqrt(d2) == dist
        assert (s2, *pq2) == (s, px, py, qx, qy)


def test_segments_within_agrees_with_the_distance():
    rng = np.random.default_rng(8)
    for _ in range(2000):
        a, b, c, d = rng.uniform(-10, 10, size=(4, 2))
        r = rng.uniform(0.0, 6.0)
        dist = segment_distance(*a, *b, *c, *d)
        if abs(dist - r) > 1e-9:
            assert segments_within(*a, *b, *c, *d, r) == (dist <= r)
    assert segments_within(0.0, 0.0, 10.0, 0.0, 5.0, -1.0, 5.0, 1.0, 0.0)   # crossing
