"""Tests of rfp_twin.models.array.ArrayGeometry on a 19-robot hex grid and the real SDSS-V layout.

Sayres 2021 Eq. 3 (clearance D_ij - 2 sigma_cb) and Eq. 4 (neighbours within
2 (la + lb + sigma_cb)).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec

PITCH = 22.4
SPEC = load_spec("sdss-v")
PROD = load_spec("sdss-v-production")


@pytest.fixture(scope="module")
def grid() -> Layout:
    return Layout.hex_grid(2, PITCH)


@pytest.fixture(scope="module")
def geom(grid) -> ArrayGeometry:
    return ArrayGeometry(SPEC, grid, 2.5)


def folded(n: int, spec=SPEC) -> np.ndarray:
    return np.tile(np.asarray(spec.fold_deg, dtype=np.float64), (n, 1))


def index_at(g: ArrayGeometry, x: float, y: float) -> int:
    k = np.flatnonzero(np.hypot(g.base_xy[:, 0] - x, g.base_xy[:, 1] - y) < 1e-9)
    assert len(k) == 1
    return int(k[0])


def test_basic_arrays(geom, grid):
    assert geom.n_robots == 19
    np.testing.assert_array_equal(geom.base_xy, grid.robot_xy)
    np.testing.assert_array_equal(geom.robot_ids, np.arange(19))
    np.testing.assert_array_equal(geom.buffer, np.full(19, 2.5))
    np.testing.assert_array_equal(geom.seg_end, np.full(19, 15.0))
    assert geom.fid_xy.shape == (0, 2) and geom.robot_fid_pairs.shape == (0, 2)
    assert geom.fiducial_clearance(folded(19)).shape == (0,)


@pytest.mark.parametrize("buffer", [1.5, 2.5, 3.5])
def test_pairs_unique_and_match_eq4(grid, buffer):
    g = ArrayGeometry(SPEC, grid, buffer)
    reach = 2 * (7.4 + 15.0 + buffer)
    xy = grid.robot_xy
    dist = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    expected = {(i, j) for i in range(19) for j in range(i + 1, 19) if dist[i, j] <= reach}
    got = [tuple(map(int, p)) for p in g.pairs]
    assert g.pairs.dtype == np.int64 and g.pairs.shape[1] == 2
    assert all(i < j for i, j in got)
    assert len(got) == len(set(got))
    assert set(got) == expected
    # with sigma <= 2.5 the shells at 1, sqrt(3) and 2 pitches (22.4, 38.8, 44.8 mm) are in,
    # sqrt(7) pitches (59.3 mm) is out
    d = dist[g.pairs[:, 0], g.pairs[:, 1]]
    assert d.max() == pytest.approx(2 * PITCH)
    assert d.max() <= reach < math.sqrt(7) * PITCH


def test_csr_symmetric_and_nbr_dist(geom):
    ptr, idx = geom.nbr_ptr, geom.nbr_idx
    assert ptr[0] == 0 and ptr[-1] == len(idx) == 2 * len(geom.pairs) == len(geom.nbr_dist)
    adj = {i: set(idx[ptr[i]:ptr[i + 1]].tolist()) for i in range(19)}
    for i in range(19):
        assert i not in adj[i]
        for j in adj[i]:
            assert i in adj[j]
        for k in range(ptr[i], ptr[i + 1]):
            j = idx[k]
            assert geom.nbr_dist[k] == pytest.approx(
                math.hypot(*(geom.base_xy[i] - geom.base_xy[j])), abs=1e-12)
    # centre robot: 6 + 6 + 6 neighbours in the three shells
    c = index_at(geom, 0.0, 0.0)
    assert len(adj[c]) == 18
    assert sorted(np.round(geom.nbr_dist[ptr[c]:ptr[c + 1]], 6).tolist()) == \
        [22.4] * 6 + [round(PITCH * math.sqrt(3), 6)] * 6 + [44.8] * 6


def test_production_spec_uses_buffer_dependent_segment(grid):
    g = ArrayGeometry(PROD, grid, 3.0)
    np.testing.assert_allclose(g.seg_end, 16.2 - (math.hypot(3.0, 0.3) - 0.55))


@pytest.mark.parametrize("buffer", [0.0, -1.0, PITCH / 2, 20.0, math.nan, math.inf])
def test_bad_buffer(grid, buffer):
    with pytest.raises(SpecError) as exc:
        ArrayGeometry(SPEC, grid, buffer)
    assert "buffer_mm" in str(exc.value) and "allowed" in str(exc.value)


def test_buffer_just_inside_bounds(grid):
    assert ArrayGeometry(SPEC, grid, 0.01).n_robots == 19
    assert ArrayGeometry(SPEC, grid, PITCH / 2 - 0.01).n_robots == 19


def test_folded_clearance_positive(geom):
    cl = geom.pair_clearance(folded(19))
    assert cl.shape == (len(geom.pairs),)
    assert np.all(cl > 0)
    # along a row the folded segments are 22.4 - 15 = 7.4 mm apart: clearance 7.4 - 5
    assert cl.min() == pytest.approx(PITCH - 15.0 - 5.0, abs=1e-9)


def test_facing_robots_collide_only_with_each_other(geom):
    c = index_at(geom, 0.0, 0.0)
    r = index_at(geom, PITCH, 0.0)
    ang = folded(19)
    ang[c] = (0.0, 0.0)      # fully extended towards +x
    ang[r] = (180.0, 0.0)    # fully extended towards -x
    cl = geom.pair_clearance(ang)
    k = [n for n, (i, j) in enumerate(geom.pairs) if {int(i), int(j)} == {c, r}]
    assert len(k) == 1
    assert cl[k[0]] == pytest.approx(-5.0, abs=1e-9)   # segments overlap: D = 0
    others = np.delete(cl, k[0])
    assert np.all(others > 0), geom.pairs[np.flatnonzero(cl <= 0)]


def test_pair_clearance_is_eq3(geom):
    """Clearance = segment distance - 2 sigma for random configurations (vs own numpy)."""
    rng = np.random.default_rng(9)
    ang = np.column_stack([rng.uniform(0, 360, 19), rng.uniform(0, 180, 19)])
    cl = geom.pair_clearance(ang)
    a, ab = np.deg2rad(ang[:, 0]), np.deg2rad(ang[:, 0] + ang[:, 1])
    e = geom.base_xy + 7.4 * np.column_stack([np.cos(a), np.sin(a)])
    f = e + 15.0 * np.column_stack([np.cos(ab), np.sin(ab)])
    t = np.linspace(0, 1, 1501)[:, None]
    for n, (i, j) in enumerate(geom.pairs):
        pi = e[i] + t * (f[i] - e[i])
        pj = e[j] + t * (f[j] - e[j])
        # dense point-to-point minimum (spacings 0.01 and 0.05 mm): >= the true distance
        # and at most (0.01 + 0.05) / 2 mm above it
        d = np.hypot(pi[:, None, 0] - pj[None, ::5, 0], pi[:, None, 1] - pj[None, ::5, 1])
        ref = d.min() - 5.0
        assert cl[n] <= ref + 1e-9
        assert ref - cl[n] < 0.05


def test_fiducials_clear_of_folded_robots():
    lay = Layout.sdss_v_fps()
    for spec in (SPEC, PROD):
        g = ArrayGeometry(spec, lay, spec.buffer_mm)
        assert g.n_robots == 500 and len(g.fid_xy) == lay.n_fiducials
        assert len(g.robot_fid_pairs) > 0
        fc = g.fiducial_clearance(folded(500, spec))
        assert fc.shape == (len(g.robot_fid_pairs),)
        assert np.all(fc > 0), fc.min()
        assert np.all(g.pair_clearance(folded(500, spec)) > 0)


def test_fiducial_pairs_cover_reach():
    """Every fiducial a robot could touch is listed: base distance <= reach + fid buffer."""
    lay = Layout.sdss_v_fps()
    g = ArrayGeometry(SPEC, lay, 2.5)
    reach = 7.4 + 15.0 + 2.5 + SPEC.fiducial_buffer_mm
    d = np.hypot(lay.robot_xy[:, None, 0] - lay.fiducial_xy[None, :, 0],
                 lay.robot_xy[:, None, 1] - lay.fiducial_xy[None, :, 1])
    expected = {(int(i), int(f)) for i, f in zip(*np.nonzero(d <= reach))}
    assert {tuple(map(int, p)) for p in g.robot_fid_pairs} == expected


def test_fiducial_clearance_negative_when_arm_points_at_fiducial():
    lay = Layout([0, 1], [[0.0, 0.0], [PITCH, 0.0]], ["robot", "fiducial"], name="one-fid")
    g = ArrayGeometry(SPEC, lay, 2.5)
    cl = g.fiducial_clearance(np.array([[0.0, 0.0]]))     # fiber sits on the fiducial
    assert cl.shape == (1,) and cl[0] == pytest.approx(-(2.5 + 1.5), abs=1e-9)
    cl = g.fiducial_clearance(np.array([[180.0, 0.0]]))   # pointing away: elbow nearest
    assert cl[0] == pytest.approx(PITCH + 7.4 - 2.5 - 1.5, abs=1e-9)
    cl = g.fiducial_clearance(np.array([[0.0, 90.0]]))    # arm vertical at x = 7.4
    assert cl[0] == pytest.approx(PITCH - 7.4 - 2.5 - 1.5, abs=1e-9)
