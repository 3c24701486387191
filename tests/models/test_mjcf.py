"""Tests of models.mjcf: the MuJoCo grid model built with MjSpec.

Every generated model must compile and step without a MuJoCo warning (mujoco_menagerie
practice); visual and collision geometry live in separate default classes; only robots
whose parts can reach each other may make contacts; the 3D arms stay inside the 2D
capsule the planner checks (Sayres 2021 Eq. 3 with buffer 1.5 mm, the arm half-width).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from models.array import ArrayGeometry
from models.errors import SpecError
from models.geometry import load_geometry
from models.layout import Layout
from models.mjcf import (BIT_BETA, COLLISION_GROUP, VISUAL_GROUP, ModelOptions, ServoParams,
                         build_model, collect_mujoco_warnings, export_model)
from models.robot import load_spec


def _step_clean(m: mujoco.MjModel, d: mujoco.MjData, n: int = 100) -> None:
    """Step n times; fail on any MuJoCo warning (message or counter)."""
    with collect_mujoco_warnings() as messages:
        for _ in range(n):
            mujoco.mj_step(m, d)
    assert messages == []
    assert [int(w.number) for w in d.warning] == [0] * int(mujoco.mjtWarning.mjNWARNING)


def _with_fiducials(n_rings: int, pitch: float, fid_ids) -> Layout:
    grid = Layout.hex_grid(n_rings, pitch)
    kinds = np.where(np.isin(grid.ids, fid_ids), "fiducial", "robot")
    return Layout(grid.ids, grid.xy, kinds, name="hex-fid")


@pytest.fixture(scope="module")
def sdss7():
    spec = load_spec("sdss-v")
    return build_model(spec, Layout.hex_grid(1, spec.pitch_mm))


@pytest.mark.parametrize("preset", ["sdss-v", "sdss-v-production", "desi"])
def test_every_preset_model_compiles_and_steps_without_warnings(preset):
    spec = load_spec(preset)
    with collect_mujoco_warnings() as messages:
        twin = build_model(spec, Layout.hex_grid(2, spec.pitch_mm))
    assert messages == []
    d = twin.make_data()
    d.ctrl[twin.index.actuator[:, 0]] += 0.2        # move a little: contacts, limits, servos
    _step_clean(twin.model, d, 200)


def test_model_with_fiducials_and_random_start_steps_without_warnings():
    spec = load_spec("sdss-v")
    lay = _with_fiducials(2, spec.pitch_mm, [0, 7, 12])
    twin = build_model(spec, lay, options=ModelOptions(timestep_s=0.002))
    assert twin.index.fiducial_ids.tolist() == [0, 7, 12]
    rng = np.random.default_rng(3)
    d = twin.make_data(rng.uniform(0, 360, (twin.n_robots, 2)))   # may start interpenetrating
    _step_clean(twin.model, d, 200)


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
    assert xyz[:, :, 2] == pytest.approx(np.full((7, 3), 143.1))    # kaiju-anchor focal z
    assert twin.angles(d) == pytest.approx(angles)


def _robot_contact_pairs(twin, d) -> set[tuple[int, int]]:
    g = np.asarray(d.contact.geom).reshape(-1, 2)
    r = twin.index.geom_robot[g]
    keep = (r[:, 0] >= 0) & (r[:, 1] >= 0) & (r[:, 0] != r[:, 1])
    return {tuple(sorted(map(int, p))) for p in r[keep]}


def test_only_neighbours_make_contacts_and_2d_clearance_means_no_3d_contact():
    """Random configurations of a 19-robot grid: every contact is between neighbours, and
    every pair whose 2D capsules (buffer 1.5 mm, the real head-centre segment) are clear has
    no contact; pairs that overlap by more than a millimetre do touch."""
    spec = load_spec("sdss-v")
    lay = Layout.hex_grid(2, spec.pitch_mm)
    geo = load_geometry("sdss-v")
    twin = build_model(spec, lay, geo)
    seg = geo.params.head_centre_mm + 1e-6
    arr = ArrayGeometry(spec.with_overrides(segment_end_mm=seg), lay, 1.5)
    neighbours = {tuple(p) for p in twin.neighbour_pairs().tolist()}
    d = mujoco.MjData(twin.model)
    rng = np.random.default_rng(11)
    clear_pairs = touching = deep = 0
    for _ in range(150):
        angles = rng.uniform(0, 360, (lay.n_robots, 2))
        twin.set_angles(d, angles)
        pairs = _robot_contact_pairs(twin, d)
        assert pairs <= neighbours
        clearance = arr.pair_clearance(angles)
        for (i, j), c in zip(arr.pairs.tolist(), clearance):
            if c > 1e-9:
                clear_pairs += 1
                assert (i, j) not in pairs, (i, j, c)
            elif c < -1.0:
                deep += 1
                touching += (i, j) in pairs
    assert clear_pairs > 1000 and deep > 50
    assert touching == deep


def test_alpha_arms_never_touch_at_the_sdss_pitch(sdss7):
    twin = sdss7
    d = mujoco.MjData(twin.model)
    alpha_geoms = np.zeros(twin.model.ngeom, bool)
    alpha_geoms[[g for k in range(7) for g in twin.index.robot_geoms(k, collision=True)
                 if twin.model.geom_bodyid[g] == twin.index.alpha_body[k]]] = True
    rng = np.random.default_rng(5)
    for _ in range(100):
        twin.set_angles(d, np.column_stack([rng.uniform(0, 360, 7), np.full(7, 180.0)]))
        g = np.asarray(d.contact.geom).reshape(-1, 2)
        assert not np.any(alpha_geoms[g[:, 0]] & alpha_geoms[g[:, 1]])


def test_export_writes_xml_and_meshes_that_load(tmp_path):
    spec = load_spec("sdss-v")
    lay = _with_fiducials(1, spec.pitch_mm, [6])
    path = export_model(spec, lay, tmp_path / "model")
    assert path.name == "rfp-twin.xml"
    meshes = sorted(p.name for p in (tmp_path / "model" / "meshes").iterdir())
    assert "beta_visual.stl" in meshes and "beta_collision_0.stl" in meshes
    assert not any(p.name.endswith(".tmp") for p in (tmp_path / "model").rglob("*"))
    text = path.read_text()
    assert 'class="visual"' in text and 'class="collision"' in text
    with collect_mujoco_warnings() as messages:
        m = mujoco.MjModel.from_xml_path(str(path))
    assert messages == []
    built = build_model(spec, lay).model
    assert (m.ngeom, m.nbody, m.nu, m.nmeshvert) == (built.ngeom, built.nbody, built.nu,
                                                     built.nmeshvert)
    _step_clean(m, mujoco.MjData(m), 50)


def test_cameras_and_closeup_aim(sdss7):
    twin = sdss7
    assert set(twin.index.camera) == {"top", "oblique", "closeup"}
    c = twin.index.camera["closeup"]
    before = twin.model.cam_pos[c].copy()
    twin.aim_closeup(int(twin.layout.robot_ids[0]))
    moved = twin.model.cam_pos[c] - before
    assert moved[:2] == pytest.approx(twin.layout.robot_xy[0] - twin.layout.robot_xy[3])
    assert twin.model.nlight == 2


def test_servo_params_from_the_actuators_table_and_errors():
    servo = ServoParams.from_tables({"actuators": {"servo_bandwidth_hz": 5.0,
                                                   "torque_limit_mNm": 20.0}})
    assert servo.bandwidth_hz == 5.0 and servo.torque_limit_mNm == 20.0
    kp, kv = servo.gains(300.0)
    assert kp == pytest.approx(300.0 * (2 * math.pi * 5.0) ** 2)
    assert kv == pytest.approx(2.0 * math.sqrt(kp * 300.0))
    with pytest.raises(SpecError, match="torque_limit_mNm"):
        ServoParams.from_tables({"actuators": {"torque_limit_mNm": -1.0}}, "x.toml")
    with pytest.raises(SpecError, match="timestep_s"):
        ModelOptions(timestep_s=1.0)
    with pytest.raises(SpecError, match="integrator"):
        ModelOptions(integrator="verlet")



def test_model_with_a_cad_beta_arm_compiles_and_steps(tmp_path):
    """A user's STL beta arm (spec file -> geometry_for_spec) is sliced into convex pieces
    that MuJoCo collides; the model steps without warnings."""
    import trimesh

    arm = trimesh.creation.box(extents=(17.0, 3.0, 2.0))
    arm.apply_translation([7.7, 0.0, 1.0])
    arm.export(tmp_path / "beta.stl")
    (tmp_path / "robot.toml").write_text('extends = "sdss-v"\n[geometry.meshes]\nbeta = "beta.stl"\n')
    spec = load_spec(tmp_path / "robot.toml")
    twin = build_model(spec, Layout.hex_grid(1, spec.pitch_mm))
    beta_col = [g for g in twin.index.robot_geoms(0, collision=True)
                if twin.model.geom_bodyid[g] == twin.index.beta_body[0]]
    assert len(beta_col) == twin.geometry.params.collision_slabs
    d = twin.make_data()
    d.ctrl[twin.index.actuator[:, 1]] -= 1.0
    _step_clean(twin.model, d, 100)
