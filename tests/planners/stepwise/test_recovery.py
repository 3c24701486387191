"""Unwind and explode from any poses (planners/stepwise/recovery.py), checked independently."""
from __future__ import annotations

import numpy as np
import pytest

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import DEADLOCKED, OFFLINE, REACHED
from rfp_twin.planners.stepwise import array_max_displacement
from rfp_twin.planners.stepwise.recovery import explode_plan, min_clearance, unwind_plan
from rfp_twin.planners.plan.targets import random_targets
from rfp_twin.validation.checker2d import check_trajectory

SPEC = load_spec("sdss-v").with_overrides(buffer_mm=2.0)
STEP = 0.2


@pytest.fixture(scope="module")
def hex37():
    return ArrayGeometry(SPEC, Layout.hex_grid(3, SPEC.pitch_mm), 2.0)


def squeezed_poses(geom, seed):
    """Random right-armed poses drawn at a 1.2 mm buffer: some pairs collide at 2.0 mm."""
    tight = ArrayGeometry(SPEC.with_overrides(buffer_mm=1.2), geom.layout, 1.2)
    for s in range(seed, seed + 50):
        poses = random_targets(tight, np.random.default_rng(s), margin_mm=0.0)
        if min_clearance(geom, poses) < -0.2:
            return poses
    raise AssertionError("no squeezed draw")


def test_unwind_reaches_the_fold_and_passes_the_2d_check(hex37):
    md = array_max_displacement(hex37, STEP)
    poses = random_targets(hex37, np.random.default_rng(5), margin_mm=md)
    movable = np.ones(hex37.n_robots, bool)
    movable[[4, 11]] = False
    plan = unwind_plan(hex37, poses, movable, step_deg=STEP)
    fold = np.asarray(SPEC.fold_deg)
    reached, stuck = plan.status == REACHED, plan.status == DEADLOCKED
    assert set(plan.status[~movable]) == {OFFLINE} and np.all(reached | stuck | ~movable)
    assert reached.sum() >= 30 and plan.metrics["n_deadlocked"] == stuck.sum()
    np.testing.assert_allclose(plan.start(), poses)
    np.testing.assert_allclose(plan.end()[reached], np.tile(fold, (reached.sum(), 1)))
    assert not np.any(np.all(np.isclose(plan.end()[stuck], fold), axis=1))
    np.testing.assert_array_equal(plan.end()[~movable], poses[~movable])
    report = check_trajectory(Trajectory.from_plan(plan), SPEC, hex37.layout, 2.0)
    assert report.ok and report.min_clearance_mm >= 0.0


def test_unwind_blocked_by_an_offline_robot_reports_deadlock():
    """Robot 1 is offline with its arm along the line of centres towards robot 0, over
    robot 0's fold pose (clearance there -2.6 mm): robot 0 cannot fold. The run stops,
    robot 0 is DEADLOCKED where it stands, and the motion up to there is clear."""
    lay = Layout(np.array([0, 1]), np.array([[0.0, 0.0], [22.4, 0.0]]), ["robot", "robot"],
                 name="pair")
    geom = ArrayGeometry(SPEC, lay, 2.0)
    poses = np.array([[180.0, 0.0], [170.0, 0.0]])
    assert min_clearance(geom, poses) > 0.0
    assert min_clearance(geom, np.array([SPEC.fold_deg, poses[1]])) < 0.0
    plan = unwind_plan(geom, poses, np.array([True, False]), step_deg=STEP)
    assert plan.status.tolist() == [DEADLOCKED, OFFLINE]
    assert plan.metrics["n_deadlocked"] == 1
    assert not np.allclose(plan.end()[0], SPEC.fold_deg)
    report = check_trajectory(Trajectory.from_plan(plan), SPEC, lay, 2.0)
    assert report.ok


@pytest.mark.parametrize("seed", [1, 2])
def test_explode_pulls_colliding_robots_apart_without_new_collisions(hex37, seed):
    poses = squeezed_poses(hex37, seed)
    movable = np.ones(hex37.n_robots, bool)
    movable[0] = False
    plan = explode_plan(hex37, poses, movable, degrees=20.0, step_deg=STEP)
    m = plan.metrics
    assert m["min_clearance_start_mm"] < -0.2
    assert m["min_clearance_end_mm"] > m["min_clearance_start_mm"] + 0.2
    np.testing.assert_array_equal(plan.end()[0], poses[0])            # offline: never moves
    traj = Trajectory.from_plan(plan)
    report = check_trajectory(traj, SPEC, hex37.layout, 2.0)
    # the only collisions are those of the start poses: none begins later
    assert report.collisions and all(c.t_start == 0.0 for c in report.collisions)
    # and no pair ends closer than it started
    start_pairs = hex37.pair_clearance(poses)
    end_pairs = hex37.pair_clearance(plan.end())
    md = array_max_displacement(hex37, STEP)
    assert np.all(end_pairs >= np.minimum(start_pairs, md) - 1e-9)


def test_explode_one_robot_moves_that_robot_only(hex37):
    poses = squeezed_poses(hex37, 3)
    movable = np.ones(hex37.n_robots, bool)
    pair = np.argmin(hex37.pair_clearance(poses))
    i = int(hex37.pairs[pair, 0])
    plan = explode_plan(hex37, poses, movable, degrees=10.0, step_deg=STEP, robots=np.array([i]))
    moved = np.flatnonzero(np.any(plan.end() != poses, axis=1))
    assert moved.tolist() == [i]
    assert hex37.pair_clearance(plan.end())[pair] > hex37.pair_clearance(poses)[pair]


def test_explode_rejects_a_non_positive_travel(hex37):
    from rfp_twin.models.errors import PlanningError

    poses = np.tile(SPEC.fold_deg, (hex37.n_robots, 1)).astype(float)
    with pytest.raises(PlanningError, match="explode degrees 0.0; allowed: a finite number > 0"):
        explode_plan(hex37, poses, np.ones(hex37.n_robots, bool), degrees=0.0)
