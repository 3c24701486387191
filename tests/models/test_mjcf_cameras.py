"""Tests of rfp_twin.models.mjcf.cameras: the three cameras, the close-up pose, lights and plate."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rfp_twin.models.mjcf import closeup_pose, look_at_quat
from rfp_twin.models.robot import load_spec


def test_cameras_and_closeup_aim(sdss7):
    twin = sdss7
    assert set(twin.index.camera) == {"top", "oblique", "closeup"}
    c = twin.index.camera["closeup"]
    before = twin.model.cam_pos[c].copy()
    twin.aim_closeup(int(twin.layout.robot_ids[0]))
    moved = twin.model.cam_pos[c] - before
    assert moved[:2] == pytest.approx(twin.layout.robot_xy[0] - twin.layout.robot_xy[3])
    assert twin.model.nlight == 2


def _camera_axes(quat):
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, float))
    return mat.reshape(3, 3)


@pytest.mark.parametrize("pos, target", [((10.0, -20.0, 50.0), (1.0, 2.0, 3.0)),
                                         ((0.0, 0.0, 100.0), (0.0, 0.0, 0.0))])
def test_look_at_points_the_camera_minus_z_at_the_target(pos, target):
    axes = _camera_axes(look_at_quat(np.array(pos), np.array(target)))
    view = np.array(target) - np.array(pos)
    assert -axes[:, 2] == pytest.approx(view / np.linalg.norm(view))
    assert axes.T @ axes == pytest.approx(np.eye(3), abs=1e-12)


def test_closeup_pose_stands_off_three_reaches_south_west():
    spec = load_spec("sdss-v")
    base = np.array([100.0, 50.0, 135.3])
    pos, quat = closeup_pose(base, spec)
    target = base + [0.0, 0.0, 3.0]
    assert np.linalg.norm(pos - target) == pytest.approx(3.0 * 22.4 * np.linalg.norm([-0.5, -0.6, 0.62]))
    assert pos[0] < base[0] and pos[1] < base[1] and pos[2] > base[2]
    near, _ = closeup_pose(base, spec, distance_mm=10.0)
    assert np.linalg.norm(near - target) == pytest.approx(10.0 * np.linalg.norm([-0.5, -0.6, 0.62]))


def test_plate_sits_below_the_fixed_bodies(sdss7):
    m = sdss7.model
    plate = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "focal_plate")
    top = m.geom_pos[plate][2] + m.geom_size[plate][2]
    assert top == pytest.approx(sdss7.base_z_mm - sdss7.geometry.params.body_length_mm)
    assert m.geom_size[plate][0] > np.abs(sdss7.layout.xy[:, 0]).max()
