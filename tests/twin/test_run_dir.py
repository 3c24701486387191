"""The run folder's angle conventions: model angles, and encoder angles for an instrument."""
from __future__ import annotations

import numpy as np

from rfp_twin.models.instrument import calibration_folder, read_calibration
from rfp_twin.models.layout import Layout, layout_by_name
from rfp_twin.models.robot import load_spec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.run_dir import angle_offsets, fiber_positions, to_encoder


def test_encoder_angles_are_model_minus_each_robots_offset():
    lay = layout_by_name("sdss-v-apo", 22.4)
    cal = read_calibration(calibration_folder("sdss-v-apo"))
    offsets = angle_offsets(lay)
    np.testing.assert_array_equal(offsets, cal.angle_offset)
    ids = lay.robot_ids[[5, 0, 42]]                       # not in layout order
    times = tuple(tuple(np.array([0.0, 2.0, 3.5]) for _ in ids) for _ in range(2))
    angles = (tuple(np.array([10.0, 50.0, 120.0]) for _ in ids),
              tuple(np.array([170.0, 90.0, 30.0]) for _ in ids))
    enc = to_encoder(Trajectory(ids, times, angles), offsets, lay)
    for i, k in enumerate((5, 0, 42)):
        np.testing.assert_allclose(enc.angles[0][i], angles[0][i] - cal.angle_offset[k, 0])
        np.testing.assert_allclose(enc.angles[1][i], angles[1][i] - cal.angle_offset[k, 1])
    assert np.abs(cal.angle_offset).max() > 1.0              # the conversion matters
    assert angle_offsets(Layout.hex_grid_positions(7, 22.4)) is None


def test_written_fiber_positions_use_each_robots_metrology_fiber():
    lay = layout_by_name("sdss-v-apo", 22.4)
    cal = read_calibration(calibration_folder("sdss-v-apo"))
    spec = load_spec("sdss-v-production")
    angles = np.tile([0.0, 0.0], (lay.n_robots, 1))          # both arms along +x
    xy = fiber_positions(spec, lay, angles)
    reach = cal.alpha_len + cal.fibers[:, 0, 0]
    np.testing.assert_allclose(xy - lay.robot_xy, np.column_stack([reach, 0.0 * reach]), atol=1e-12)


def test_a_run_is_checked_against_each_robots_own_range(tmp_path):
    """Robot 0's encoder zero sits at alpha -30 (range [-30, 330] in model angles): a
    trajectory through alpha -20 is legal for it, the same on a robot without an offset is
    refused, naming the file, the robot and the range."""
    import pytest

    from rfp_twin.models.errors import TrajectoryError
    from rfp_twin.twin.run_dir import check_run_trajectory

    spec = load_spec("sdss-v")
    g = Layout.hex_grid(1, spec.pitch_mm)
    lay = Layout(g.ids, g.xy, g.kinds, name="t",
                 extra={"alpha_offset_deg": ["-30"] + [""] * 6})
    ids = lay.robot_ids
    alpha = [[10.0, -20.0]] + [[10.0, 10.0]] * 6
    traj = Trajectory.from_breakpoints(ids, [[0.0, 1.0]] * 7, alpha, [[0.0, 1.0]] * 7,
                                       [[170.0, 170.0]] * 7)
    check_run_trajectory(traj, spec, lay, tmp_path / "trajectories.json")
    with pytest.raises(TrajectoryError, match=r"trajectories.json: robot 0: field 'alpha' = "
                                              r"-20.0 deg at t = 1 s; allowed: \[0, 360\] deg"):
        check_run_trajectory(traj, spec, g, tmp_path / "trajectories.json")
    moved = Layout(g.ids, g.xy, g.kinds, name="t", extra={"alpha_offset_deg": [""] + ["-30"] * 6})
    with pytest.raises(TrajectoryError, match=r"robot 0: .*allowed: \[0, 360\]"):
        check_run_trajectory(traj, spec, moved, tmp_path / "trajectories.json")
