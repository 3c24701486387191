"""Tests of rfp_twin.models.mjcf.build: every generated model compiles and steps without a MuJoCo
warning (mujoco_menagerie practice); export writes XML and meshes that load."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rfp_twin.models.errors import SpecError
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf import ModelOptions, build_model, build_spec, collect_mujoco_warnings, export_model
from rfp_twin.models.robot import load_spec
from tests.models.conftest import step_clean, with_fiducials


@pytest.mark.parametrize("preset, rings", [("sdss-v", 2), ("sdss-v-production", 2), ("desi", 2),
                                           ("pfs-cobra", 1), ("raft-6p2", 1)])
def test_every_preset_model_compiles_and_steps_without_warnings(preset, rings):
    spec = load_spec(preset)
    with collect_mujoco_warnings() as messages:
        twin = build_model(spec, Layout.hex_grid(rings, spec.pitch_mm))
    assert messages == []
    d = twin.make_data()
    d.ctrl[twin.index.actuator[:, 0]] += 0.2        # move a little: contacts, limits, servos
    step_clean(twin.model, d, 200)


def test_model_with_fiducials_and_random_start_steps_without_warnings():
    spec = load_spec("sdss-v")
    lay = with_fiducials(2, spec.pitch_mm, [0, 7, 12])
    twin = build_model(spec, lay, options=ModelOptions(timestep_s=0.002))
    assert twin.index.fiducial_ids.tolist() == [0, 7, 12]
    rng = np.random.default_rng(3)
    d = twin.make_data(rng.uniform(0, 360, (twin.n_robots, 2)))   # may start interpenetrating
    step_clean(twin.model, d, 200)


def test_export_writes_xml_and_meshes_that_load(tmp_path):
    spec = load_spec("sdss-v")
    lay = with_fiducials(1, spec.pitch_mm, [6])
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
    step_clean(m, mujoco.MjData(m), 50)


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
    step_clean(twin.model, d, 100)


def test_a_layout_without_robots_is_refused():
    spec = load_spec("sdss-v")
    only_fiducials = Layout([0, 1], [[0.0, 0.0], [30.0, 0.0]], ["fiducial", "fiducial"], name="fids")
    with pytest.raises(SpecError, match="layout 'fids': no robots"):
        build_spec(spec, only_fiducials)


def test_spec_options_and_name():
    spec = load_spec("desi")
    s = build_spec(spec, Layout.hex_grid(1, spec.pitch_mm),
                   options=ModelOptions(timestep_s=0.001, integrator="rk4"))
    assert s.modelname == "rfp-twin-desi-hex-7"
    assert s.option.timestep == 0.001 and s.option.integrator == mujoco.mjtIntegrator.mjINT_RK4


def test_a_model_without_robot_visuals_moves_the_robots_identically():
    """``robot_visuals=False`` (the tiles of a tiled twin) drops only the robots' visual
    meshes: the same collision pieces, fiber sites and obstacles, the same motion."""
    spec = load_spec("sdss-v")
    lay = with_fiducials(2, spec.pitch_mm, [0, 7, 12])
    full = build_model(spec, lay)
    lean = build_model(spec, lay, options=ModelOptions(robot_visuals=False))
    n = lay.n_robots
    for tw, visuals in ((full, 3 * n), (lean, 0)):
        robot_vis = sum(tw.index.robot_geoms(i, collision=False).size for i in range(n))
        assert robot_vis == visuals
    assert sum(full.index.robot_geoms(i, collision=True).size for i in range(n)) == \
        sum(lean.index.robot_geoms(i, collision=True).size for i in range(n)) > 0
    assert lean.model.nsite == full.model.nsite and lean.model.nbody == full.model.nbody
    out = []
    for tw in (full, lean):
        d = tw.make_data()
        d.ctrl[tw.index.actuator[:, 0]] += 0.8
        d.ctrl[tw.index.actuator[:, 1]] -= 0.5
        step_clean(tw.model, d, 150)
        out.append(tw.angles(d))
    np.testing.assert_array_equal(out[0], out[1])
