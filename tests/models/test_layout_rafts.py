"""Tests of rfp_twin.models.layout.rafts: triangular rafts of robots tiling a focal plane."""
from __future__ import annotations

import math
import time

import numpy as np
import pytest
from scipy.spatial import cKDTree

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.layout.rafts import (min_side_mm, raft_from_name, raft_layout, raft_rows,
                                          raft_template)

SQRT3 = math.sqrt(3.0)


def _rafts(layout) -> np.ndarray:
    return layout.extra["raft"].astype(int)


def _triangles(layout, side):
    """(n_rafts, 3, 2) vertices of each raft's triangle, rebuilt from its robots: the
    centroid is their mean (the 63-robot raft is symmetric), up/down from the robot
    rows (an up raft has its longest row at the bottom)."""
    raft = _rafts(layout)
    out = []
    for r in range(raft.max() + 1):
        xy = layout.xy[raft == r]
        c = xy.mean(axis=0)
        low = np.isclose(xy[:, 1], xy[:, 1].min())
        high = np.isclose(xy[:, 1], xy[:, 1].max())
        up = low.sum() > high.sum()
        ang = np.radians([90.0, 210.0, 330.0]) + (0.0 if up else math.pi)
        out.append(c + side / SQRT3 * np.column_stack([np.cos(ang), np.sin(ang)]))
    return np.array(out)


def _separated(tri_a, tri_b) -> float:
    """Largest gap between two convex polygons along their edge normals (> 0: apart)."""
    best = -np.inf
    for poly, other in ((tri_a, tri_b), (tri_b, tri_a)):
        for k in range(len(poly)):
            e = poly[(k + 1) % len(poly)] - poly[k]
            n = np.array([e[1], -e[0]]) / np.hypot(*e)
            best = max(best, (other @ n).min() - (poly @ n).max(),
                       (poly @ n).min() - (other @ n).max())
    return best


def test_spec_s5_204_rafts_make_12852_robots():
    lay = raft_layout(n_rafts=204)
    assert lay.n_robots == 12852 == 204 * 63
    assert lay.name == "raft-204x63"
    assert np.bincount(_rafts(lay)).tolist() == [63] * 204
    assert set(lay.extra["raft_side_mm"].tolist()) == {"74.0"}
    assert lay.ids.tolist() == list(range(12852))
    assert layout_by_name("raft:204", 6.2).n_robots == 12852


def test_one_raft_is_11_rows_less_its_corners():
    t = raft_template(63, 6.2)
    assert raft_rows(63) == 11 and len(t) == 63
    np.testing.assert_allclose(t.mean(axis=0), 0.0, atol=1e-12)   # symmetric about centroid
    rows = np.unique(np.round(t[:, 1], 6), return_counts=True)[1]
    assert rows.tolist() == [9, 10, 9, 8, 7, 6, 5, 4, 3, 2]       # corners 11->9, 2->0 trimmed
    # the raft's edge rows are 3.46 mm inside its 74 mm triangle: (74 - 10 * 6.2) / (2 sqrt 3)
    inset = t[:, 1].min() + 74.0 / (2 * SQRT3)
    assert inset == pytest.approx((74.0 - 62.0) / (2 * SQRT3))
    assert [len(raft_template(n, 6.2)) for n in (72, 75)] == [72, 75]


def test_63_robots_split_into_21_units_of_three_adjacent_robots():
    """The "21 trillium units of 3 robots": an exact cover of the raft by triangles of
    mutually adjacent robots exists (depth-first search)."""
    t = raft_template(63, 6.2)
    pairs = cKDTree(t).query_pairs(6.2 * 1.001)
    adj = {i: set() for i in range(len(t))}
    for i, j in pairs:
        adj[i].add(j)
        adj[j].add(i)

    def cover(left: frozenset) -> list | None:
        if not left:
            return []
        i = min(left, key=lambda k: len(adj[k] & left))
        for j in adj[i] & left:
            for k in adj[i] & adj[j] & left:
                rest = cover(left - {i, j, k})
                if rest is not None:
                    return [(i, j, k)] + rest
        return None

    units = cover(frozenset(range(63)))
    assert units is not None and len(units) == 21


def test_base_separation_is_the_pitch_inside_a_raft_and_more_between_rafts():
    lay = raft_layout(n_rafts=24)
    raft = _rafts(lay)
    pairs = cKDTree(lay.xy).query_pairs(20.0, output_type="ndarray")
    d = np.hypot(*(lay.xy[pairs[:, 0]] - lay.xy[pairs[:, 1]]).T)
    same = raft[pairs[:, 0]] == raft[pairs[:, 1]]
    assert d[same].min() == pytest.approx(6.2)
    # across a 2 mm gap: two 3.46 mm insets + the gap
    assert d[~same].min() == pytest.approx(2 * (74.0 - 62.0) / (2 * SQRT3) + 2.0)
    assert d[~same].min() >= 6.2


def test_gap_is_honoured_and_rafts_do_not_overlap():
    for gap in (0.0, 2.0, 5.0):
        lay = raft_layout(n_rafts=13, gap_mm=gap)
        tri = _triangles(lay, 74.0)
        gaps = [_separated(tri[a], tri[b]) for a in range(len(tri)) for b in range(a)]
        assert min(gaps) == pytest.approx(gap, abs=1e-9)       # neighbours exactly gap apart
        raft = _rafts(lay)
        for r, t in enumerate(tri):                             # robots inside their triangle
            xy = lay.xy[raft == r]
            for k in range(3):
                e = t[(k + 1) % 3] - t[k]
                inward = np.array([-e[1], e[0]]) / np.hypot(*e)
                assert ((xy - t[k]) @ inward).min() >= 3.0 - 1e-9  # body radius inside


def test_every_robot_inside_the_radius():
    lay = raft_layout(radius_mm=300.0)
    r = np.hypot(*lay.robot_xy.T)
    assert r.max() <= 300.0
    assert lay.n_robots % 63 == 0 and lay.n_robots > 63 * 40
    tri = _triangles(lay, 74.0)
    assert np.hypot(*tri.reshape(-1, 2).T).max() <= 300.0 + 1e-9   # whole triangles inside
    more = raft_layout(radius_mm=400.0)
    assert more.n_robots > lay.n_robots
    both = raft_layout(n_rafts=10, radius_mm=300.0)
    np.testing.assert_array_equal(both.xy, raft_layout(n_rafts=10).xy)


def test_nearest_rafts_first_and_names():
    small, big = raft_layout(n_rafts=6), raft_layout(n_rafts=12)
    np.testing.assert_array_equal(big.xy[:small.n_robots], small.xy)
    assert raft_from_name("raft:R=300", 6.2).n_robots == raft_layout(radius_mm=300.0).n_robots
    lay = layout_by_name("raft:3,robots=75,side=82,gap=1.5", 6.2)
    assert lay.n_robots == 225 and lay.extra["raft_side_mm"][0] == "82.0"
    assert layout_by_name("raft", 6.2).n_robots == 12852


def test_thirty_thousand_robots_build_fast():
    raft_layout(n_rafts=4)
    t0 = time.perf_counter()
    lay = layout_by_name("raft:476", 6.2)
    seconds = time.perf_counter() - t0
    assert lay.n_robots == 476 * 63 == 29988
    assert seconds < 1.0, seconds


@pytest.mark.parametrize("kwargs, words", [
    ({"gap_mm": -1.0}, ["'gap_mm'", ">= 0", "overlap"]),
    ({"pitch_mm": 5.0}, ["'pitch_mm'", "robot body", ">= 6 mm"]),
    ({"robots_per_raft": 75}, ["'robots_per_raft'", "75", "1..66", "side_mm >= 78.5"]),
    ({"side_mm": 60.0}, ["'robots_per_raft'", "1..45"]),
    ({"side_mm": 10.0, "robots_per_raft": 1}, ["'robots_per_raft'", "allowed: side_mm >= 10.392"]),
    ({"side_mm": 0.0}, ["'side_mm'", "> 0"]),
    ({"pitch_mm": -6.2}, ["'pitch_mm'", "> 0"]),
    ({"robots_per_raft": 0}, ["'robots_per_raft'", ">= 1"]),
    ({"n_rafts": 0}, ["'n_rafts'", ">= 1"]),
    ({"n_rafts": 2.5}, ["'n_rafts'", "integer"]),
    ({"radius_mm": 50.0}, ["'radius_mm'", "holds no raft", ">= 75.7"]),
    ({"radius_mm": -3.0}, ["'radius_mm'", "> 0"]),
    ({"radius_mm": 100.0, "n_rafts": 50}, ["'n_rafts'", "allowed: 1..6"]),
    ({"gap_mm": float("nan")}, ["'gap_mm'"]),
])
def test_bad_input_names_the_field(kwargs, words):
    with pytest.raises(LayoutError) as info:
        raft_layout(**kwargs)
    msg = str(info.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


@pytest.mark.parametrize("name, words", [
    ("raft:x", ["'raft:x'", "item 'x'", "key=value"]),
    ("raft:size=3", ["item 'size=3'", "n, R, robots"]),
    ("raft:2.5", ["item '2.5'"]),
    ("raft:R=0", ["'radius_mm'"]),
])
def test_bad_names_raise_one_line(name, words):
    with pytest.raises(LayoutError) as info:
        layout_by_name(name, 6.2)
    msg = str(info.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_min_side_matches_the_fit_rule():
    assert min_side_mm(63, 6.2) == pytest.approx(62.0 + SQRT3 * 6.0)
    raft_layout(n_rafts=1, side_mm=min_side_mm(63, 6.2))            # exactly fits
