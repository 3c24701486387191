"""Tests of the 2D speed bounds and coarse grid (validation/checker2d/speeds.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.trajectory import Trajectory
from tests.validation.conftest import SPEC, swing
from rfp_twin.validation.checker2d import coarse_grid, speed_bounds_mm_s

BUF = 2.5


def test_speed_bound_is_the_peak_slope_times_the_reach():
    # beta 90 -> 39 -> 90 deg in 5 ms; alpha still: V = r_max |b'|
    traj = swing([0.0, 0.1, 0.1025, 0.105, 0.2], [90.0, 90.0, 39.0, 90.0, 90.0], 0.2)
    rate = 51.0 / 0.0025
    v = speed_bounds_mm_s(traj, SPEC, BUF)
    assert v[0] == pytest.approx(SPEC.segment_end(BUF) * math.radians(rate))
    assert v[1] == 0.0
    # the mean slope: 102 deg of travel over the 0.2 s span
    vm = speed_bounds_mm_s(traj, SPEC, BUF, mean=True)
    assert vm[0] == pytest.approx(SPEC.segment_end(BUF) * math.radians(102.0 / 0.2))
    assert vm[1] == 0.0


def test_alpha_motion_moves_the_whole_segment():
    # alpha 0 -> 60 deg in 2 s, beta 0 -> 30 deg in 1 s: l_alpha A + r_max (A + B)
    traj = Trajectory.from_breakpoints([4], [[0.0, 2.0]], [[0.0, 60.0]], [[0.0, 1.0]],
                                       [[0.0, 30.0]])
    a, b = math.radians(30.0), math.radians(30.0)
    r_max = max(abs(SPEC.segment_start_mm), abs(SPEC.segment_end(BUF)))
    v = speed_bounds_mm_s(traj, SPEC, BUF)
    assert v[0] == pytest.approx(SPEC.alpha_length_mm * a + r_max * (a + b))
    vm = speed_bounds_mm_s(traj, SPEC, BUF, mean=True)   # beta's mean: 30 deg over 2 s
    assert vm[0] == pytest.approx(SPEC.alpha_length_mm * a + r_max * (a + b / 2))


def test_coarse_grid_spacing_follows_the_mean_speed():
    traj = swing([0.0, 1.0, 2.0], [90.0, 30.0, 90.0], 2.0)
    grid = coarse_grid(traj, SPEC, BUF, 0, 1)
    vm = speed_bounds_mm_s(traj, SPEC, BUF, mean=True)
    assert grid[0] == 0.0 and grid[-1] == 2.0
    h = np.diff(grid)
    np.testing.assert_allclose(h, h[0])
    assert h[0] <= 2 * BUF / (vm[0] + vm[1]) < 2 * h[0]
    # one robot alone (robot-fiducial pair): its own speed
    assert len(coarse_grid(traj, SPEC, BUF, 0)) == len(grid)
    # a parked robot needs one interval, a single instant none
    assert coarse_grid(traj, SPEC, BUF, 1).tolist() == [0.0, 2.0]
    instant = Trajectory.from_breakpoints([0], [[0.0]], [[0.0]], [[0.0]], [[90.0]])
    assert coarse_grid(instant, SPEC, BUF, 0).tolist() == [0.0]


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), True, "wide"])
def test_bad_buffer_raises(bad):
    with pytest.raises(SpecError, match="buffer_mm"):
        speed_bounds_mm_s(swing([0.0, 1.0], [90.0, 30.0], 1.0), SPEC, bad)
