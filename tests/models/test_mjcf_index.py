"""Tests of rfp_twin.models.mjcf.index: ids of the compiled model per robot and fiducial index."""
from __future__ import annotations

import mujoco
import numpy as np

from rfp_twin.models.mjcf import build_model
from rfp_twin.models.robot import load_spec
from tests.models.conftest import with_fiducials


def test_index_maps_every_geom_to_its_robot_or_fiducial():
    spec = load_spec("sdss-v")
    lay = with_fiducials(1, spec.pitch_mm, [2, 5])
    twin = build_model(spec, lay)
    m, idx = twin.model, twin.index
    assert idx.robot_ids.tolist() == [0, 1, 3, 4, 6] and idx.fiducial_ids.tolist() == [2, 5]
    for k, rid in enumerate(idx.robot_ids):
        names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.geom_bodyid[g]))
                 for g in idx.robot_geoms(k)}
        assert names == {f"r{rid}", f"r{rid}_alpha", f"r{rid}_beta"}
        both = idx.robot_geoms(k)
        split = np.concatenate([idx.robot_geoms(k, collision=True), idx.robot_geoms(k, collision=False)])
        assert sorted(split.tolist()) == both.tolist()
    for f, fid in enumerate(idx.fiducial_ids):
        geoms = np.flatnonzero(idx.geom_fiducial == f)
        assert {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(g)) for g in geoms} == \
            {f"fid{fid}_visual", f"fid{fid}_c0"}
    plate = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "focal_plate")
    assert idx.geom_robot[plate] == -1 and idx.geom_fiducial[plate] == -1


def test_addresses_and_sites_are_per_robot_and_axis(sdss7):
    m, idx = sdss7.model, sdss7.index
    assert idx.qpos_adr.shape == idx.dof_adr.shape == idx.actuator.shape == (7, 2)
    assert len(set(idx.qpos_adr.ravel().tolist())) == 14 == m.nq
    assert idx.fiber_names == ("metrology", "boss", "apogee") and idx.fiber_site.shape == (7, 3)
    assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, int(idx.fiber_site[2, 1])) == \
        f"r{idx.robot_ids[2]}_boss"
    assert m.actuator_trnid[idx.actuator[:, 1], 0].tolist() == idx.beta_joint.tolist()
    assert set(idx.camera) == {"top", "oblique", "closeup"}
