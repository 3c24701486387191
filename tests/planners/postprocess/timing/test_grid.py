"""Group grids (planners/postprocess/timing/grid.py): every knot, fine where curved, coarse on cruises."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.postprocess.smoothing import smooth_plan
from rfp_twin.planners.postprocess.timing import STRAIGHT_STEPS, group_grid, time_group
from tests.planners.path_builders import A, CORNER, V, make_plan, real_groups


def test_grid_is_coarse_only_on_straight_cruises():
    """Every knot is a gridpoint, curved intervals are cut at grid_steps, and the coarse
    straight intervals cost (almost) nothing against 4 steps everywhere."""
    sp, groups = real_groups()
    mrange = sp.moving_range()
    n_fine = n_coarse = 0
    for robots in groups:
        k = robots.size
        lim = (np.full(2 * k, V), np.full(2 * k, A), 1e5)
        fine = group_grid(sp, robots, 4.0, mrange)
        coarse = group_grid(sp, robots, 4.0, mrange, limits=lim)
        if fine.size < 2:
            continue
        assert np.all(np.diff(coarse) > 0) and coarse[0] == fine[0] and coarse[-1] == fine[-1]
        knots = np.unique(np.concatenate([sp.robot_knots(int(i)) for i in robots]))
        inside = knots[(knots > fine[0]) & (knots < fine[-1])]
        assert np.all(np.isin(inside, coarse))
        mid = 0.5 * (coarse[1:] + coarse[:-1])
        curved = np.any(sp.evaluate(mid, robots, 2).reshape(mid.size, -1) != 0, axis=1)
        assert np.all(np.diff(coarse)[curved] <= 4.0 + 1e-9)
        assert np.diff(coarse).max() <= STRAIGHT_STEPS + 1e-9
        n_fine += fine.size
        n_coarse += coarse.size
        d_fine = time_group(sp, robots, (V, V), (A, A), straight_steps=4.0, moving_range=mrange)
        d_coarse = time_group(sp, robots, (V, V), (A, A), moving_range=mrange)
        assert d_fine.duration * (1 - 1e-6) <= d_coarse.duration <= d_fine.duration * 1.001
    assert n_coarse < 0.6 * n_fine


def test_ramp_zones_of_a_long_cruise():
    """One straight move of 2000 steps at 0.1 deg/step: from rest the law reaches its
    cruise (300 steps/s) within D = X / (2 U) = 300^2 / (2 * 450) = 100 steps; the grid
    is fine (D / 16) there and at the other end, coarse in between."""
    plan = make_plan([([0, 2000], [[0.0, 0.0], [200.0, 0.0]])])
    sp = smooth_plan(plan, window_steps=0.0)
    grid = group_grid(sp, np.array([0]), 4.0, limits=(np.full(2, V), np.full(2, A), 1e5))
    assert grid[0] == 0.0 and grid[-1] == 2000.0
    # the zones end at D from either end (D = 100 up to rounding)
    d = grid[np.argmin(np.abs(grid - 100.0))]
    assert d == pytest.approx(100.0, rel=1e-9)
    assert np.min(np.abs(grid - (2000.0 - d))) < 1e-9
    h = np.diff(grid)
    ramps = np.concatenate([h[grid[1:] <= d], h[grid[:-1] >= 2000.0 - d]])
    assert ramps.size >= 32 and np.all(ramps <= d / 16 + 1e-9)
    cruise = h[(grid[:-1] >= d) & (grid[1:] <= 2000.0 - d)]
    assert cruise.max() <= STRAIGHT_STEPS and cruise.size == int(np.ceil(1800 / STRAIGHT_STEPS))
    # a robot that never moves has a one-point grid
    still = smooth_plan(make_plan([([0, 10], [[5.0, 5.0], [5.0, 5.0]])]), window_steps=4.0)
    assert group_grid(still, np.array([0]), 4.0).tolist() == [0.0]
    # without limits every interval is cut at grid_steps
    assert np.diff(group_grid(smooth_plan(CORNER, window_steps=0.0), np.array([0]), 4.0)).max() <= 4.0
