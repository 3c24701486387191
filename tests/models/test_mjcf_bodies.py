"""Tests of rfp_twin.models.mjcf.bodies: robot trees, joints, servos, visual/collision geoms, contact bits."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf import BIT_ALPHA, BIT_BETA, COLLISION_GROUP, VISUAL_GROUP, ModelOptions, ServoParams, build_model
from rfp_twin.models.robot import load_spec


def test_tree_joints_and_actuators(sdss7):
    m, idx, spec = sdss7.model, sdss7.index, sdss7.spec
    assert m.njnt == 14 and m.nu == 14 and idx.n_robots == 7
    for k, rid in enumerate(idx.robot_ids):
        assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, idx.alpha_joint[k]) == f"r{rid}_alpha"
        assert m.body_parentid[idx.beta_body[k]] == idx.alpha_body[k]
        assert m.body_parentid[idx.alpha_body[k]] == idx.base_body[k]
        assert m.jnt_range[idx.alpha_joint[k]] == pytest.approx(np.radians(spec.alpha_limits_deg))
        assert m.jnt_range[idx.beta_joint[k]] == pytest.approx(np.radians(spec.beta_limits_deg))
        # beta hinge at l_alpha along the alpha arm
        assert m.body_pos[idx.beta_body[k]][0] == pytest.approx(spec.alpha_length_mm)
    a = idx.actuator.ravel()
    assert np.all(m.actuator_gainprm[a, 0] > 0)                     # kp
    assert np.all(m.actuator_biasprm[a, 2] < 0)                     # -kv
    servo = ServoParams()
    assert m.actuator_forcerange[a] == pytest.approx(
        np.tile([-servo.torque_limit_mNm * 1e3, servo.torque_limit_mNm * 1e3], (a.size, 1)))
    assert np.all(m.actuator_forcelimited[a] == 1)


def test_visual_and_collision_classes_are_separate(sdss7):
    m, idx = sdss7.model, sdss7.index
    vis = m.geom_group == VISUAL_GROUP
    col = m.geom_group == COLLISION_GROUP
    assert np.all(vis | col)
    assert np.all(m.geom_contype[vis] == 0) and np.all(m.geom_conaffinity[vis] == 0)
    assert np.all((m.geom_contype[col] | m.geom_conaffinity[col]) > 0)
    assert np.all(m.geom_type[col] == mujoco.mjtGeom.mjGEOM_MESH)
    beta_col = [g for g in idx.robot_geoms(0, collision=True) if m.geom_bodyid[g] == idx.beta_body[0]]
    assert len(beta_col) == 3                                        # bar, post, ferrule
    assert all(m.geom_contype[g] == BIT_BETA for g in beta_col)
    assert (idx.geom_robot >= 0).sum() == 7 * len(idx.robot_geoms(0))


def test_fiber_sites_sit_on_the_focal_surface_where_kinematics_puts_them(sdss7):
    twin = sdss7
    rng = np.random.default_rng(0)
    angles = rng.uniform(0, 360, (7, 2))
    d = twin.make_data(angles)
    xyz = twin.fiber_xyz(d)
    k = twin.index.fiber_names.index("metrology")
    a, ab = np.radians(angles[:, 0]), np.radians(angles.sum(axis=1))
    expect = twin.layout.robot_xy + np.column_stack([7.4 * np.cos(a) + 14.314 * np.cos(ab),
                                                     7.4 * np.sin(a) + 14.314 * np.sin(ab)])
    assert xyz[:, k, :2] == pytest.approx(expect, abs=1e-9)
    assert xyz[:, :, 2] == pytest.approx(np.full((7, 3), 143.1))    # focal surface z (coordio)
    assert twin.angles(d) == pytest.approx(angles)


def _alpha_geoms(twin) -> np.ndarray:
    m, idx = twin.model, twin.index
    return np.flatnonzero((m.geom_group == COLLISION_GROUP) & np.isin(m.geom_bodyid, idx.alpha_body))


def test_alpha_pieces_skip_each_other_where_they_cannot_meet(sdss7):
    """At the SDSS pitch two alpha arms never touch (2 x 10.6 mm < 22.4 mm): the model does
    not test them against each other (their contact bits), and geometry agrees."""
    twin = sdss7
    m, idx = twin.model, twin.index
    alpha = _alpha_geoms(twin)
    assert alpha.size and not np.any(m.geom_conaffinity[alpha] & BIT_ALPHA)
    assert np.all(m.geom_conaffinity[alpha] & BIT_BETA)          # still meet beta arms
    d = mujoco.MjData(m)
    rng = np.random.default_rng(5)
    owner = idx.geom_robot[alpha]
    for _ in range(30):
        twin.set_angles(d, np.column_stack([rng.uniform(0, 360, 7), np.full(7, 180.0)]))
        for i in range(alpha.size):
            for j in range(i + 1, alpha.size):
                if owner[i] != owner[j]:
                    assert mujoco.mj_geomDistance(m, d, alpha[i], alpha[j], 50.0, None) > 0.5


def test_alpha_pieces_meet_where_the_pitch_lets_them():
    spec = load_spec("sdss-v")
    twin = build_model(spec, Layout.hex_grid(1, 18.0))              # 2 x 10.6 mm > 18 mm
    m, idx = twin.model, twin.index
    alpha = _alpha_geoms(twin)
    assert np.all(m.geom_conaffinity[alpha] & BIT_ALPHA)
    xy = twin.layout.robot_xy
    centre = int(np.argmin(np.hypot(*xy.T)))
    east = int(np.flatnonzero((np.abs(xy[:, 1]) < 1e-9) & (xy[:, 0] > 1.0))[0])
    angles = np.column_stack([np.full(7, 90.0), np.full(7, 180.0)])
    angles[centre, 0], angles[east, 0] = 0.0, 180.0                 # alpha arms face each other
    d = twin.make_data(angles)
    g = np.asarray(d.contact.geom).reshape(-1, 2)
    pair = {int(idx.geom_robot[g[k, 0]]) for k in range(len(g))
            if np.isin(g[k], alpha).all()} | {int(idx.geom_robot[g[k, 1]]) for k in range(len(g))
                                              if np.isin(g[k], alpha).all()}
    assert pair == {centre, east}


def test_without_alpha_collisions_only_beta_and_fiducials_collide():
    spec = load_spec("sdss-v")
    twin = build_model(spec, Layout.hex_grid(1, spec.pitch_mm), options=ModelOptions(collide_alpha=False))
    m, idx = twin.model, twin.index
    col = np.flatnonzero(m.geom_group == COLLISION_GROUP)
    assert not np.any(np.isin(m.geom_bodyid[col], idx.alpha_body))
    assert np.all(np.isin(m.geom_bodyid[col], idx.beta_body))
