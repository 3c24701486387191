"""One-robot groups in one compiled call (planners/postprocess/singles.py): the values of
the per-group path, bit for bit."""
from __future__ import annotations

import numpy as np
import pytest

import rfp_twin.planners.postprocess.pipeline as pipeline
from rfp_twin.planners.postprocess import postprocess
from rfp_twin.planners.postprocess.groups import time_and_simplify
from rfp_twin.planners.postprocess.singles import time_singles
from rfp_twin.planners.postprocess.smoothing import smooth_plan
from rfp_twin.validation.checker2d import check_trajectory
from tests.planners.conftest import make_geom, plan_random

V, A = np.array([30.0, 30.0]), np.array([45.0, 45.0])


def assert_same_group(a, b) -> None:
    np.testing.assert_array_equal(a.robots, b.robots)
    assert a.scale == b.scale and a.law.solver == b.law.solver
    for name in ("s", "sd", "sdd", "t"):
        np.testing.assert_array_equal(getattr(a.law, name), getattr(b.law, name), err_msg=name)
    for name in ("t", "Y", "keep", "tol_used"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


@pytest.fixture(scope="module")
def smoothed():
    geom = make_geom(91, 2.0)
    _, plan = plan_random(geom, 3, step_deg=0.1, algorithm="markov")
    path = smooth_plan(plan, window_steps=200.0)
    limits = geom.limits.reshape(plan.n_robots, 2, 2)
    return plan, path, limits


@pytest.mark.parametrize("grid_steps,max_points,tol", [(4.0, 1024, 0.05), (200.0, 1024, 0.05),
                                                       (4.0, 6, 0.02)])
def test_every_robot_gets_the_per_group_values_bit_for_bit(smoothed, grid_steps, max_points, tol):
    """Straight intervals by ramp zones (4 steps) or uniform cuts (a grid step above the
    straight-interval step), and a point budget that raises the tolerances."""
    plan, path, limits = smoothed
    n = plan.n_robots
    mrange = path.moving_range()
    tols = np.full(n, tol)
    tols[::3] = 2 * tol                                  # per-robot tolerances
    robots = np.arange(n)
    got = time_singles(path, robots, V, A, tols, grid_steps=grid_steps, sample_s=0.01,
                       max_points=max_points, moving_range=mrange, limits=limits)
    moving = mrange[:, 1] > mrange[:, 0]
    assert moving.sum() > n // 2 and set(got) <= set(np.flatnonzero(moving).tolist())
    assert len(got) >= moving.sum() - 2                  # crawling laws are rare
    for i in range(n):
        ref = time_and_simplify(path, np.array([i]), V, A, tols, grid_steps=grid_steps,
                                backend="numba", sample_s=0.01, max_points=max_points,
                                moving_range=mrange, limits=limits)
        if i in got:
            assert_same_group(got[i], ref)
    if max_points == 6:
        assert max(g.keep.sum(axis=0).max() for g in got.values()) <= 6
        assert max(g.tol_used.max() for g in got.values()) > 2 * tol


def test_the_split_between_threads_changes_nothing(smoothed):
    plan, path, limits = smoothed
    n = plan.n_robots
    mrange = path.moving_range()
    kw = dict(grid_steps=4.0, sample_s=0.01, max_points=1024, moving_range=mrange, limits=limits)
    tols = np.full(n, 0.05)
    robots = np.arange(n)
    whole = time_singles(path, robots, V, A, tols, **kw)
    few = {}
    for i in range(0, n, 10):                            # < 16 robots: one thread
        few.update(time_singles(path, robots[i:i + 10], V, A, tols, **kw))
    assert whole.keys() == few.keys()
    for i in whole:
        assert_same_group(whole[i], few[i])


def test_bad_tolerances_are_left_to_the_per_group_path_which_names_them(smoothed):
    plan, path, limits = smoothed
    tols = np.full(plan.n_robots, 0.05)
    tols[4] = 0.0
    kw = dict(grid_steps=4.0, sample_s=0.01, moving_range=path.moving_range(), limits=limits)
    assert time_singles(path, np.arange(8), V, A, tols, max_points=1024, **kw) == {}
    assert time_singles(path, np.arange(4), V, A, tols, max_points=1, **kw) == {}
    with pytest.raises(Exception, match="tolerance_deg"):
        time_and_simplify(path, np.array([4]), V, A, tols, backend="numba", max_points=1024,
                          **kw)


@pytest.mark.parametrize("algorithm,buffer_mm,seed", [("markov", 2.0, 1), ("greedy", 2.5, 2)])
def test_the_pipeline_delivers_the_same_trajectory_with_and_without_it(monkeypatch, algorithm,
                                                                      buffer_mm, seed):
    geom = make_geom(127, buffer_mm)
    _, plan = plan_random(geom, seed, step_deg=0.1, algorithm=algorithm)
    batched = []

    def spy(*args, **kwargs):
        out = time_singles(*args, **kwargs)
        batched.append(len(out))
        return out
    monkeypatch.setattr(pipeline, "time_singles", spy)
    traj, rep = postprocess(plan, geom, verifier=check_trajectory)
    assert batched and batched[0] > rep.n_groups // 2       # most groups: one robot each
    monkeypatch.setattr(pipeline, "BATCH_SINGLES", False)
    ref, ref_rep = postprocess(plan, geom, verifier=check_trajectory)
    assert rep.final_check.ok and ref_rep.final_check.ok
    assert rep.check_rounds == ref_rep.check_rounds
    for ax in range(2):
        for a, b in zip(traj.times[ax] + traj.angles[ax], ref.times[ax] + ref.angles[ax]):
            np.testing.assert_array_equal(a, b)
