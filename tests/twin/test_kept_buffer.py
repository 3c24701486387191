"""The buffer a trajectory kept (twin/kept_buffer.py): the largest 2D buffer it passes at.

Robot 1 (27 mm from robot 0) is parked with its beta arm's tip pointing at the side of
robot 0's beta arm; robot 0 turns its arm a little away and back, its tip passing below a
fiducial. The kept buffer must be the boundary: the independent 2D check passes just
below it and fails just above it, for a fixed segment (sdss-v) and for production's
buffer-dependent one (sdss-v-production, whose tip moves in as the buffer grows).
"""
from __future__ import annotations

import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.kept_buffer import kept_buffer
from rfp_twin.validation.checker2d import check_trajectory


def scene(fiducial_y: float = 21.5):
    """Robot 0 (alpha 0) turns beta 90 -> 100 -> 90: its segment on x = 7.4 at the ends;
    robot 1 at (27, 0), alpha 90, beta 90: its segment along y = 7.4 ending at
    x = 27 - segment end. The fiducial sits ``fiducial_y - 15`` mm beyond robot 0's tip."""
    lay = Layout([0, 1, 9], [[0.0, 0.0], [27.0, 0.0], [7.4, fiducial_y]],
                 ["robot", "robot", "fiducial"], name="pair")
    traj = Trajectory.from_breakpoints([0, 1], [[0, 2], [0, 2]], [[0, 0], [90, 90]],
                                       [[0, 1, 2], [0, 2]], [[90, 100, 90], [90, 90]])
    return lay, traj


@pytest.mark.parametrize("preset", ["sdss-v", "sdss-v-production"])
def test_the_kept_buffer_is_where_the_2d_check_turns(preset):
    spec = load_spec(preset)
    lay, traj = scene()
    first = check_trajectory(traj, spec, lay, 2.0)
    kept = kept_buffer(traj, spec, lay, first)
    assert kept.robot_pair == (0, 1) and kept.obstacle_pair == (0, 9)
    assert kept.buffer_mm == min(kept.robot_mm, kept.obstacle_mm)
    assert 0.5 < kept.buffer_mm < 5.0
    below = check_trajectory(traj, spec, lay, kept.buffer_mm - 0.01)
    above = check_trajectory(traj, spec, lay, kept.buffer_mm + 0.01)
    assert below.ok and not above.ok
    if preset == "sdss-v":
        # fixed segment: half the smallest distance at any buffer, no re-check
        assert kept.rounds == 0
        assert kept.robot_mm == pytest.approx(first.pair_min_distance_mm[0] / 2, abs=1e-12)
    else:
        # production's segment is shorter at a larger buffer: the pair is farther apart
        # there than at 2.0 mm, and the fixed point needed re-checks
        assert kept.rounds >= 1
        assert kept.robot_mm > first.pair_min_distance_mm[0] / 2 + 0.01


def test_the_obstacle_sets_the_kept_buffer_when_it_is_closer():
    spec = load_spec("sdss-v")
    lay, traj = scene(fiducial_y=18.0)
    kept = kept_buffer(traj, spec, lay, check_trajectory(traj, spec, lay, 2.0))
    assert kept.buffer_mm == kept.obstacle_mm < kept.robot_mm
    assert check_trajectory(traj, spec, lay, kept.buffer_mm - 0.01).ok
    assert not check_trajectory(traj, spec, lay, kept.buffer_mm + 0.01).ok
