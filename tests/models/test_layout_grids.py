"""Tests of rfp_twin.models.layout.grids and the generated grids: centred hex lattices (Sayres 2021 Sect. 3.2)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout import Layout, hex_axial, hex_count, hex_rings, hex_xy, nearest_hex_counts

PITCH = 22.4
ROW_DY = PITCH * math.sqrt(3.0) / 2.0


# -- lattice arithmetic ----------------------------------------------------------------
def test_hex_count_and_rings_are_inverse():
    counts = [hex_count(r) for r in range(40)]
    assert counts[:6] == [1, 7, 19, 37, 61, 91] and hex_count(13) == 547
    assert [hex_rings(n) for n in counts] == list(range(40))
    assert [hex_rings(n) for n in (0, -5, 2, 8, 36, 38, 546)] == [None] * 7


@pytest.mark.parametrize("n, expected", [(100, [91, 127]), (37, [37, 61]), (8, [7, 19]),
                                         (0, [1]), ("many", [1, 7])])
def test_nearest_hex_counts(n, expected):
    assert nearest_hex_counts(n) == expected


def test_axial_coordinates_fill_the_hexagon_sorted_by_row():
    qr = hex_axial(2)
    assert qr.dtype == np.int64 and qr.shape == (19, 2)
    assert np.max(np.abs(np.column_stack([qr, qr.sum(axis=1)]))) == 2
    assert len({tuple(p) for p in qr.tolist()}) == 19
    assert np.all(np.diff(qr[:, 1]) >= 0)                          # rows ascending
    same_row = np.diff(qr[:, 1]) == 0
    assert np.all(np.diff(qr[:, 0])[same_row] > 0)                 # q ascending in a row


def test_axial_to_xy_uses_the_60_degree_lattice():
    xy = hex_xy(np.array([[1, 0], [0, 1], [-1, 1]]), 10.0)
    np.testing.assert_allclose(xy, [[10.0, 0.0], [5.0, 5.0 * math.sqrt(3.0)],
                                    [-5.0, 5.0 * math.sqrt(3.0)]], atol=1e-12)
    assert np.allclose(np.hypot(*xy.T), 10.0)


# -- Layout.hex_grid / hex_grid_positions --------------------------------------------
@pytest.mark.parametrize("rings, count", [(3, 37), (5, 91), (7, 169), (13, 547), (31, 2977)])
def test_hex_grid_counts_and_pitch(rings, count):
    grid = Layout.hex_grid(rings, PITCH)
    assert len(grid.ids) == grid.n_robots == count
    assert grid.n_fiducials == 0
    assert grid.ids.tolist() == list(range(count))
    dist, _ = cKDTree(grid.xy).query(grid.xy, k=2)
    np.testing.assert_allclose(dist[:, 1], PITCH, rtol=1e-12)
    assert Layout.hex_grid_positions(count, PITCH).xy.shape == (count, 2)


def test_hex_grid_geometry():
    grid = Layout.hex_grid(3, 10.0)
    assert grid.xy.dtype == np.float64 and grid.ids.dtype == np.int64
    np.testing.assert_allclose(grid.xy.mean(axis=0), 0.0, atol=1e-12)
    assert np.any(np.all(grid.xy == 0.0, axis=1))                   # a position at the centre
    order = np.lexsort((grid.xy[:, 0], grid.xy[:, 1]))
    assert order.tolist() == list(range(37))                         # ids sorted by y then x
    centre_row = grid.xy[np.abs(grid.xy[:, 1]) < 1e-9, 0]
    np.testing.assert_allclose(np.diff(centre_row), 10.0)            # rows run along +x
    assert len(centre_row) == 7


def test_hex_grid_positions_rejects_non_hex_count():
    with pytest.raises(LayoutError, match=r"n_positions.*100.*91, 127"):
        Layout.hex_grid_positions(100, PITCH)


@pytest.mark.parametrize("rings, pitch", [(-1, PITCH), (2.5, PITCH), (3, 0.0), (3, math.nan)])
def test_hex_grid_rejects_bad_arguments(rings, pitch):
    with pytest.raises(LayoutError):
        Layout.hex_grid(rings, pitch)
