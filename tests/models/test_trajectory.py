"""Trajectory: breakpoints, sampling, JSON in the SDSS-V control-software form."""
from __future__ import annotations

import json

import numpy as np
import pytest

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.trajectory import Trajectory, simplify_exact
from tests.planners.conftest import make_geom, plan_random


def two_robot_traj() -> Trajectory:
    return Trajectory.from_breakpoints(
        [5, 9],
        [np.array([0.0, 1.0, 2.0]), np.array([0.0, 4.0])],
        [np.array([10.0, 40.0, 70.0]), np.array([0.0, 120.0])],   # robot 5 alpha: straight line
        [np.array([0.0, 2.0]), np.array([0.0, 1.0, 4.0])],
        [np.array([170.0, 110.0]), np.array([170.0, 170.0, 80.0])],
    )


def test_exact_simplification_drops_only_collinear_points():
    t = two_robot_traj()
    assert t.point_counts().tolist() == [[2, 2], [2, 3]]
    np.testing.assert_allclose(t.sample([1.0])[0, 0], [40.0, 140.0])
    tt, aa = simplify_exact(np.array([0.0, 1.0, 1.0, 2.0, 3.0]), np.array([0.0, 1.0, 1.0, 3.0, 5.0]))
    assert tt.tolist() == [0.0, 1.0, 3.0] and aa.tolist() == [0.0, 1.0, 5.0]


def test_sampling_holds_ends_and_interpolates_linearly():
    t = two_robot_traj()
    s = t.sample(np.array([-1.0, 0.5, 3.0, 10.0]))
    assert s.shape == (4, 2, 2)
    np.testing.assert_allclose(s[:, 0, 0], [10.0, 25.0, 70.0, 70.0])
    np.testing.assert_allclose(s[:, 1, 1], [170.0, 170.0, 110.0, 80.0])
    assert t.duration == 4.0
    np.testing.assert_allclose(t.max_speed(), [[30.0, 30.0], [30.0, 30.0]])


def test_json_round_trip_in_control_software_form(tmp_path):
    t = two_robot_traj()
    path = tmp_path / "t.json"
    t.to_json(path)
    raw = json.loads(path.read_text())
    assert set(raw) == {"5", "9"}
    assert raw["5"]["alpha"][0] == [10.0, 0.0]            # [deg, s]
    back = Trajectory.from_json(path)
    np.testing.assert_array_equal(back.robot_ids, [5, 9])
    grid = np.linspace(0, 4, 41)
    np.testing.assert_allclose(back.sample(grid), t.sample(grid))


def test_reversal_plays_the_motion_backwards():
    t = two_robot_traj()
    r = t.reversed()
    grid = np.linspace(0, 4, 17)
    np.testing.assert_allclose(r.sample(grid), t.sample(4.0 - grid))
    np.testing.assert_allclose(r.reversed().sample(grid), t.sample(grid))


def test_plan_to_trajectory_uses_the_robot_speed():
    geom = make_geom(37, 2.0)
    _, plan = plan_random(geom, 2, step_deg=0.2)
    traj = Trajectory.from_plan(plan)
    assert traj.duration == pytest.approx(plan.n_steps * 0.2 / 30.0)
    assert traj.max_speed().max() <= 30.0 * (1 + 1e-9)
    steps = np.linspace(0, plan.n_steps, 97)
    np.testing.assert_allclose(traj.sample(steps * plan.step_s), plan.angles_at(steps), atol=1e-9)
    rev = plan.reversed()
    np.testing.assert_allclose(rev.angles_at(steps), plan.angles_at(plan.n_steps - steps), atol=1e-9)


@pytest.mark.parametrize("text,msg", [
    ("{not json", "malformed JSON"),
    ('{"x1": {"alpha": [], "beta": []}}', "not an integer"),
    ('{"1": {"alpha": [[0, 0]]}}', "'alpha' and 'beta'"),
    ('{"1": {"alpha": [[0, 1], [1, 0]], "beta": [[0, 0]]}}', "times decrease"),
    ('{"1": {"alpha": [[NaN, 0]], "beta": [[0, 0]]}}', "NaN"),
    ('{"1": {"alpha": "fast", "beta": [[0, 0]]}}', "list of"),
])
def test_malformed_json_is_named(tmp_path, text, msg):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(TrajectoryError, match=msg):
        Trajectory.from_json(path)


def test_joined_trajectories_hold_the_joint_and_shift_the_second():
    from rfp_twin.models.trajectory import join_trajectories

    first = Trajectory.from_breakpoints([1, 2], [[0.0, 2.0], [0.0, 4.0]], [[0.0, 10.0], [5.0, 9.0]],
                                        [[0.0, 1.0], [0.0, 4.0]], [[0.0, 0.0], [1.0, 1.0]])
    second = Trajectory.from_breakpoints([1, 2], [[0.0, 1.0], [0.0, 3.0]], [[10.0, 20.0], [9.0, 0.0]],
                                         [[0.0, 1.0], [0.0, 3.0]], [[0.0, 5.0], [1.0, 2.0]])
    j = join_trajectories(first, second)
    assert j.duration == pytest.approx(4.0 + 3.0)
    s = j.sample(np.array([0.0, 2.0, 4.0, 5.0, 7.0]))
    assert s[:, 0, 0].tolist() == [0.0, 10.0, 10.0, 20.0, 20.0]   # robot 1 waits at the joint
    assert s[:, 1, 0].tolist() == [5.0, 7.0, 9.0, 6.0, 0.0]
    with pytest.raises(TrajectoryError, match="allowed: the same angle"):
        join_trajectories(second, first)
