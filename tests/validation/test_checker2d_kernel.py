"""Tests of the dense 2D check's kernel (validation/checker2d/kernel.py): refinement,
interval bound, resolution and collision runs, through :func:`check_trajectory`.

Robot 0 swings its beta arm past robot 1's parked arm (tests/validation/conftest.py):
their segment distance is ``7.6 sin b`` (SDSS-V, buffer 2.5 mm, threshold 5 mm).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rfp_twin.models.trajectory import Trajectory
from tests.validation.conftest import SPEC, brute_distances, pair_layout, swing
from rfp_twin.validation.checker2d import check_trajectory, coarse_grid
from rfp_twin.validation.checker2d.kernel import MAX_COARSE, n_intervals

BUF = 2.5
THR = 2 * BUF
RES = 1e-5


# -- a brief overlap ----------------------------------------------------------------
def test_brief_swing_through_is_caught_by_refinement():
    # beta 90 -> 39 -> 90 deg in 5 ms; collision while 7.6 sin b <= 5
    traj = swing([0.0, 0.1, 0.1025, 0.105, 0.2], [90.0, 90.0, 39.0, 90.0, 90.0], 0.2)
    rate = 51.0 / 0.0025
    b_crit = math.degrees(math.asin(THR / 7.6))
    t_in, t_out = 0.1 + (90 - b_crit) / rate, 0.105 - (90 - b_crit) / rate
    overlap = t_out - t_in
    assert 1e-4 < overlap < 3e-4

    report = check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES)
    assert not report.ok
    assert len(report.collisions) == 1
    c = report.collisions[0]
    assert (c.kind, c.robot_a, c.other) == ("robot", 0, 1)
    assert not c.conservative
    assert c.threshold_mm == pytest.approx(THR)
    assert abs(c.t_start - t_in) <= 2 * RES and abs(c.t_end - t_out) <= 2 * RES
    assert t_in <= c.t_min <= t_out
    assert c.min_distance_mm <= THR
    assert report.min_clearance_mm < 0

    # the coarse grid alone would miss it: its spacing exceeds the overlap and none of
    # its samples is in collision; the bisection is what catches it
    grid = coarse_grid(traj, SPEC, BUF, 0, 1, resolution_s=RES)
    assert grid[0] == 0.0 and grid[-1] == pytest.approx(0.2)
    assert np.diff(grid).min() > overlap
    assert np.all(brute_distances(traj, pair_layout(), grid, 0, 1, buffer_mm=BUF) > THR)


def test_two_brief_overlaps_in_one_coarse_interval_stay_separate():
    t = [0.0, 0.1, 0.1025, 0.105, 0.1075, 0.11, 0.2]
    traj = swing(t, [90.0, 90.0, 39.0, 90.0, 39.0, 90.0, 90.0], 0.2)
    grid = coarse_grid(traj, SPEC, BUF, 0, 1, resolution_s=RES)
    assert np.diff(grid).min() > 0.0075          # both swings inside one coarse interval
    report = check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES)
    assert len(report.collisions) == 2
    for c, peak in zip(report.collisions, (0.1025, 0.1075)):
        assert c.t_start < peak < c.t_end and c.t_end - c.t_start < 3e-4
        assert abs(c.t_min - peak) < 1.5e-4


# -- a near miss --------------------------------------------------------------------
def near_miss_traj() -> Trajectory:
    b_min = math.degrees(math.asin((THR + 0.01) / 7.6))
    return swing([0.0, 1.0, 2.0], [90.0, b_min, 90.0], 2.0)


def test_near_miss_is_ok_and_minimum_matches_brute_force():
    traj = near_miss_traj()
    report = check_trajectory(traj, SPEC, pair_layout(), BUF, resolution_s=RES)
    assert report.ok, report.table()
    assert report.n_pairs == 1 and report.n_fiducial_pairs == 0
    times = np.arange(0.0, 2.0 + RES / 2, RES)
    brute = brute_distances(traj, pair_layout(), times, 0, 1, buffer_mm=BUF).min()
    assert abs(report.pair_min_distance_mm[0] - brute) <= 0.01
    assert report.pair_min_distance_mm[0] == pytest.approx(THR + 0.01, abs=0.006)
    assert report.min_clearance_mm == pytest.approx(0.01, abs=0.006)
    assert report.min_clearance_mm > 0
    assert report.duration_s == pytest.approx(2.0)


def test_near_miss_below_resolution_is_reported_conservatively():
    # with a 20 ms resolution the bound cannot clear the 0.01 mm near miss
    report = check_trajectory(near_miss_traj(), SPEC, pair_layout(), BUF, resolution_s=0.02)
    assert not report.ok
    assert len(report.collisions) == 1
    c = report.collisions[0]
    assert c.conservative
    assert c.t_start <= 1.0 <= c.t_end and c.t_end - c.t_start <= 0.05
    assert c.min_distance_mm < THR


# -- coarse grid ------------------------------------------------------------------------
def test_coarse_interval_count():
    assert n_intervals(0.0, 10.0, 5.0, 1e-5) == 0            # a single instant
    assert n_intervals(2.0, 0.0, 5.0, 1e-5) == 1             # nothing moves
    assert n_intervals(2.0, 10.0, 5.0, 1e-5) == 4            # spacing slack / speed
    assert n_intervals(2.0, 10.1, 5.0, 1e-5) == 5            # rounded up
    assert n_intervals(2.0, 1e9, 5.0, 0.1) == 20             # capped by the resolution
    assert n_intervals(1e6, 1e9, 5.0, 1e-9) == MAX_COARSE    # and by the memory guard
