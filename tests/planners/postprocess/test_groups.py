"""Per-group work (planners/postprocess/groups.py): timed, sampled, simplified, assembled."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.planners.postprocess.groups import assemble, group_offsets, time_and_simplify
from rfp_twin.planners.postprocess.simplify import max_deviation
from rfp_twin.planners.postprocess.smoothing import smooth_plan
from rfp_twin.planners.postprocess.timing import pl_kinematics
from tests.planners.path_builders import A, CORNER, V, make_plan


def timed(plan, robots, tol=0.1, max_points=1024):
    sp = smooth_plan(plan, window_steps=40.0)
    return time_and_simplify(sp, np.asarray(robots), np.array([V, V]), np.array([A, A]),
                             np.full(plan.n_robots, tol), grid_steps=4.0, backend="numba",
                             sample_s=0.01, max_points=max_points, moving_range=sp.moving_range())


def test_a_group_is_sampled_simplified_and_within_the_limits():
    g = timed(CORNER, [0])
    assert g.t[0] == 0.0 and g.t[-1] == g.law.duration and g.scale >= 1.0
    assert np.all(np.diff(g.t) <= 0.01 + 1e-12)
    assert g.duration == pytest.approx(g.scale * g.law.duration)
    for c in range(2):
        m = g.keep[:, c]
        assert m[0] and m[-1] and m.sum() < g.t.size
        assert max_deviation(g.t, g.Y[:, c], g.t[m], g.Y[m, c]) <= g.tol_used[c] + 1e-12
        vm, am = pl_kinematics(g.scale * g.t[m], g.Y[m, c])
        assert vm <= V * (1 + 1e-6) and am <= A * (1 + 1e-6)
    # a point budget raises the tolerance of the axes that need it
    small = timed(CORNER, [0], max_points=4)
    assert small.keep.sum(axis=0).max() <= 4 and small.tol_used.max() > 0.1


def test_groups_are_aligned_and_assembled_with_exact_ends():
    plan = make_plan([([0, 400], [[10, 170], [50, 130]]),       # long move
                      ([0, 100], [[0, 180], [10, 180]]),         # short move
                      ([0, 10], [[5, 5], [5, 5]])])              # never moves
    groups = {0: timed(plan, [0]), 1: timed(plan, [1]), 2: timed(plan, [2])}
    assert groups[2].duration == 0.0 and groups[1].duration < groups[0].duration
    off = group_offsets(groups, "end")
    assert off[0] == 0.0 and off[1] == pytest.approx(groups[0].duration - groups[1].duration)
    assert group_offsets(groups, "start") == {0: 0.0, 1: 0.0, 2: 0.0}
    traj = assemble(plan, groups, "end", plan.start(), plan.end())
    np.testing.assert_array_equal(traj.start(), plan.start())
    np.testing.assert_array_equal(traj.end(), plan.end())
    assert traj.duration == pytest.approx(groups[0].duration)
    assert traj.times[0][1][0] == pytest.approx(off[1])          # the short move waits
    assert traj.point_counts()[2].tolist() == [1, 1]             # still: one point


def test_group_members_are_the_robots_of_each_label_in_order():
    from rfp_twin.planners.postprocess.groups import group_members

    rng = np.random.default_rng(4)
    labels = rng.integers(0, 40, 500) * 3          # gaps in the labels
    got = group_members(labels)
    assert sorted(got) == sorted(set(labels.tolist()))
    for g, robots in got.items():
        assert robots.dtype == np.int64
        assert np.array_equal(robots, np.flatnonzero(labels == g))
    assert group_members(np.zeros(0, dtype=np.int64)) == {}
