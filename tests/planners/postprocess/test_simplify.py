"""Ramer-Douglas-Peucker on (time, angle) axes (planners/postprocess/simplify.py)."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.planners.postprocess.simplify import (max_deviation, rdp_mask, simplify_axis, simplify_columns,
                               simplify_plan)
from rfp_twin.planners.postprocess.timing import pl_kinematics
from tests.planners.conftest import make_geom, plan_random
from tests.planners.path_builders import make_plan


def test_straight_line_keeps_its_two_ends():
    t = np.linspace(0, 2, 201)
    tt, yy, used = simplify_axis(t, 3.0 + 12.5 * t, 1e-6)
    assert tt.tolist() == [0.0, 2.0] and yy.tolist() == [3.0, 28.0] and used == 1e-6


def test_deviation_is_vertical_not_perpendicular():
    # a steep ramp with one bump: the bump is 0.5 deg high at the same time, although
    # its perpendicular distance to the chord is tiny (slope 1000 deg/s)
    t = np.array([0.0, 0.5, 1.0])
    y = np.array([0.0, 500.5, 1000.0])
    keep = np.empty(3, dtype=np.bool_)
    assert rdp_mask(t, y, 0.4, keep) == 3
    assert rdp_mask(t, y, 0.6, keep) == 2


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kept_points_are_samples_within_tolerance(seed):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.001, 0.02, 3000))
    Y = np.cumsum(rng.normal(size=(3000, 3)), axis=0) * 0.05
    tol = np.array([0.01, 0.1, 0.5])
    keep, used = simplify_columns(t, Y, tol, 3000)
    np.testing.assert_array_equal(used, tol)
    for c in range(3):
        m = keep[:, c]
        assert m[0] and m[-1]
        assert max_deviation(t, Y[:, c], t[m], Y[m, c]) <= tol[c] + 1e-12
    counts = keep.sum(axis=0)
    assert counts[0] > counts[1] > counts[2] >= 2


def test_point_budget_raises_the_tolerance_and_says_so():
    t = np.linspace(0, 10, 5001)
    y = 20 * np.sin(3 * t)
    keep, used = simplify_columns(t, y[:, None], 1e-4, max_points=16)
    assert keep.sum() <= 16
    assert used[0] > 1e-4
    assert max_deviation(t, y, t[keep[:, 0]], y[keep[:, 0]]) <= used[0] + 1e-12


def test_any_subset_of_exact_samples_stays_within_limits():
    """Slopes and three-point accelerations of kept samples of a trajectory within
    (v, a) stay within (v, a): the reason RDP cannot break the limits."""
    v, a = 30.0, 45.0
    ta = v / a                                        # trapezoid: accelerate, cruise, brake
    T = 4.0
    t = np.linspace(0, T, 4001)
    q = np.where(t < ta, 0.5 * a * t**2,
                 np.where(t < T - ta, 0.5 * a * ta**2 + v * (t - ta),
                          v * (T - ta) - 0.5 * a * (T - t) ** 2))
    for tol in (1e-3, 0.01, 0.1, 1.0):
        tt, yy, _ = simplify_axis(t, q, tol)
        vm, am = pl_kinematics(tt, yy)
        assert vm <= v * (1 + 1e-9) and am <= a * (1 + 1e-6)
    assert simplify_axis(t, q, 0.1)[0].size < 30


def test_bad_arguments():
    t = np.linspace(0, 1, 5)
    with pytest.raises(SpecError, match="tolerance_deg"):
        simplify_columns(t, np.zeros((5, 1)), 0.0)
    with pytest.raises(SpecError, match="max_points"):
        simplify_columns(t, np.zeros((5, 1)), 0.1, max_points=1)
    with pytest.raises(ValueError):
        simplify_columns(t, np.zeros((4, 1)), 0.1)


@pytest.mark.parametrize("tol", [0.05, 0.2])
def test_simplified_markov_plan_stays_within_tolerance_at_every_step(tol):
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 3, step_deg=0.1, algorithm="markov")
    small = simplify_plan(plan, tol)
    # one-step wiggles (0.1 deg) collapse once the tolerance exceeds a step
    assert small.path_step.size < (0.5 if tol > plan.step_deg else 1.0) * plan.path_step.size
    assert small.n_steps == plan.n_steps
    np.testing.assert_array_equal(small.start(), plan.start())
    np.testing.assert_array_equal(small.end(), plan.end())
    steps = np.arange(plan.n_steps + 1.0)
    dev = np.abs(small.angles_at(steps) - plan.angles_at(steps)).max()
    assert dev <= tol + 1e-12
    # kept breakpoints are the plan's own, per robot
    for i in range(plan.n_robots):
        s0, a0 = plan.path(i)
        s1, a1 = small.path(i)
        idx = np.searchsorted(s0, s1)
        np.testing.assert_array_equal(s0[idx], s1)
        np.testing.assert_array_equal(a0[idx], a1)
    # per-robot tolerances; 0 keeps the plan as it is
    same = simplify_plan(plan, np.zeros(plan.n_robots))
    np.testing.assert_array_equal(same.path_step, plan.path_step)
    with pytest.raises(SpecError, match="presimplify_deg"):
        simplify_plan(plan, -1.0)


def rdp_reference(t, y, tol, axis_form):
    """Textbook recursive RDP (vertical deviation, largest over the columns of y, first
    sample at a tie), its chord rounded as rdp_mask (axis_form) or simplify_plan does."""
    keep = np.zeros(t.size, dtype=bool)
    keep[[0, -1]] = True

    def split(i, j):
        dt = t[j] - t[i]
        best, idx = -1.0, -1
        for k in range(i + 1, j):
            d = 0.0
            for c in range(y.shape[1]):
                dy = y[j, c] - y[i, c]
                if axis_form:
                    yk = y[i, c] + dy * (t[k] - t[i]) / dt if dt > 0 else y[i, c]
                else:
                    yk = y[i, c] + ((t[k] - t[i]) / dt if dt > 0 else 0.0) * dy
                d = max(d, abs(y[k, c] - yk))
            if d > best:
                best, idx = d, k
        if best > tol:
            keep[idx] = True
            split(i, idx)
            split(idx, j)

    split(0, t.size - 1)
    return keep


def test_each_chord_rounding_is_kept_at_exact_ties():
    """On a coarse grid of times and angles deviations tie exactly, and the two ways of
    rounding the chord keep different samples; rdp_mask and simplify_plan each keep
    their own (results published with each depend on it)."""
    rng = np.random.default_rng(0)
    differ = 0
    for _ in range(400):
        n = int(rng.integers(3, 30))
        t = np.sort(rng.choice(np.arange(1, 100), n - 1, replace=False)).astype(float)
        t = np.concatenate([[0.0], t])
        y = rng.integers(-5, 6, (n, 2)) * 0.1
        keep = np.empty(n, dtype=np.bool_)
        count = rdp_mask(t, y[:, 0].copy(), 0.05, keep)
        axis = rdp_reference(t, y[:, :1], 0.05, True)
        np.testing.assert_array_equal(keep, axis)
        assert count == axis.sum()
        small = simplify_plan(make_plan([(t, y)]), 0.05)
        np.testing.assert_array_equal(small.path_step, t[rdp_reference(t, y, 0.05, False)])
        differ += not np.array_equal(axis, rdp_reference(t, y[:, :1], 0.05, False))
    assert differ > 0


def test_direction_reversals_count_turns_per_robot_and_axis():
    from rfp_twin.planners.postprocess.simplify import direction_reversals

    # robot 0: alpha up, wait, down (1 turn), beta steady; robot 1: beta zig-zag (3 turns);
    # robot 2: a single breakpoint; robot 3: alpha up then, after robot boundaries, nothing
    a0 = [[0, 0], [1, 1], [1, 2], [0, 3]]
    a1 = [[5, 0], [5, 1], [5, 0], [5, 1], [5, 0]]
    a2 = [[3, 3]]
    a3 = [[0, 0], [2, 0]]
    angles = np.array(a0 + a1 + a2 + a3, dtype=float)
    ptr = np.cumsum([0, len(a0), len(a1), len(a2), len(a3)])
    assert direction_reversals(ptr, angles).tolist() == [1, 3, 0, 0]
    # a turn across two robots' paths is not counted
    angles2 = np.array([[0, 0], [1, 0], [0, 0], [-1, 0]], dtype=float)
    assert direction_reversals(np.array([0, 2, 4]), angles2).tolist() == [0, 0]
