"""Tests of rfp_twin.models.layout.neighbours: neighbour lists within a reach (Sayres 2021 Eq. 4)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import LayoutError
from rfp_twin.models.layout import Layout

PITCH = 22.4


def hex_distance(xy: np.ndarray, pitch: float) -> np.ndarray:
    """Lattice ring number of each position of a centred hex grid, (n,) int."""
    r = np.rint(xy[:, 1] / (pitch * math.sqrt(3.0) / 2.0))
    q = np.rint(xy[:, 0] / pitch - r / 2.0)
    return np.max(np.abs(np.stack([q, r, q + r])), axis=0).astype(int)



@pytest.mark.parametrize("reach, expected, depth", [(1.01 * PITCH, 6, 1), (48.8, 18, 2)])
def test_interior_robots_have_full_neighbourhoods(reach, expected, depth):
    rings = 7
    grid = Layout.hex_grid(rings, PITCH)
    ptr, idx = grid.neighbour_csr(reach)
    counts = np.diff(ptr)
    interior = hex_distance(grid.robot_xy, PITCH) <= rings - depth
    assert interior.sum() > 0
    assert (counts[interior] == expected).all()
    assert (counts[~interior] < expected).all()


def test_neighbour_pairs_and_csr_agree():
    grid = Layout.hex_grid(5, PITCH)
    pairs = grid.neighbour_pairs(48.8)
    assert pairs.dtype == np.int64 and pairs.shape[1] == 2
    assert (pairs[:, 0] < pairs[:, 1]).all()
    d = np.linalg.norm(grid.robot_xy[pairs[:, 0]] - grid.robot_xy[pairs[:, 1]], axis=1)
    assert (d <= 48.8).all()
    ptr, idx = grid.neighbour_csr(48.8)
    assert ptr.shape == (grid.n_robots + 1,) and ptr.dtype == idx.dtype == np.int64
    assert len(idx) == 2 * len(pairs)
    edges = {(i, int(j)) for i in range(grid.n_robots) for j in idx[ptr[i]:ptr[i + 1]]}
    expected = {(int(i), int(j)) for i, j in pairs} | {(int(j), int(i)) for i, j in pairs}
    assert edges == expected


def test_robot_fiducial_csr_uses_fiducial_indices():
    grid = Layout.sdss_v_grid(fiducial_ids=[273])                   # the centre position
    assert grid.n_robots == 546 and grid.n_fiducials == 1
    np.testing.assert_allclose(grid.fiducial_xy, [[0.0, 0.0]], atol=1e-12)
    ptr, idx = grid.robot_fiducial_csr(48.8)
    assert ptr.shape == (547,)
    assert np.diff(ptr).sum() == 18 and set(idx.tolist()) == {0}


def test_distance_equal_to_the_reach_counts():
    grid = Layout.hex_grid(1, 10.0)
    assert len(grid.neighbour_pairs(10.0)) == 12                   # 6 spokes + 6 rim edges
    assert len(grid.neighbour_pairs(9.999)) == 0


def test_small_layouts_have_empty_lists():
    one = Layout.hex_grid(0, PITCH)
    assert one.neighbour_pairs(50.0).shape == (0, 2)
    ptr, idx = one.neighbour_csr(50.0)
    assert ptr.tolist() == [0, 0] and idx.size == 0
    ptr, idx = one.robot_fiducial_csr(50.0)                        # no fiducials
    assert ptr.tolist() == [0, 0] and idx.size == 0


@pytest.mark.parametrize("reach", [-1.0, math.nan, math.inf, "far"])
def test_bad_reach_is_rejected(reach):
    grid = Layout.hex_grid(1, PITCH)
    with pytest.raises(LayoutError, match="reach_mm"):
        grid.neighbour_pairs(reach)
    with pytest.raises(LayoutError, match="reach_mm"):
        grid.robot_fiducial_csr(reach)
