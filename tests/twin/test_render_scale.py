"""Tests of the renderer on a large-ish array: the scene holds every visible geom of the
render model (none dropped by a full ``mjvScene``), and the frame shows the whole plate."""
from __future__ import annotations

import numpy as np
import pytest

import rfp_twin.twin.render  # noqa: F401  (first: picks MUJOCO_GL before mujoco is imported)
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.render import FrameRenderer, RenderSettings
from rfp_twin.twin.render.frames import SCENE_SPARE, scene_capacity, visible_geoms


@pytest.fixture(scope="module")
def raft4():
    """The MuJoCo twin of 252 raft robots (4 rafts of 63)."""
    spec = load_spec("raft-6p2")
    return build_model(spec, layout_by_name("raft:4", spec.pitch_mm))


@pytest.mark.parametrize("camera", ["top", "oblique"])
def test_no_geom_is_dropped_and_the_plate_fills_the_frame(raft4, camera):
    with FrameRenderer(raft4, RenderSettings(width=320, height=180, camera=camera)) as fr:
        m = fr.model
        assert fr.scene.maxgeom == scene_capacity(m) == m.ngeom + m.nsite + SCENE_SPARE
        img = fr.render(np.tile(raft4.spec.fold_deg, (raft4.n_robots, 1)))
        drawn = fr.scene.ngeom
        expected = visible_geoms(m, fr.option)
        # body, alpha and beta meshes of every robot, and the plate; collision pieces hidden
        assert expected == 3 * raft4.n_robots + 1
        assert drawn == expected
        # every robot base projects inside the frame
        uv = fr.project(fr.data.xpos[fr.twin.index.base_body])
        assert np.all((uv >= 0) & (uv < [320, 180]))
        assert img.std() > 5.0                                  # not a blank frame


def test_visible_geoms_follows_the_group_switches(raft4):
    with FrameRenderer(raft4, RenderSettings(width=64, height=64)) as fr:
        m = fr.model
        fr.option.geomgroup[:] = 1                               # collision pieces too
        fr.render()
        assert fr.scene.ngeom == visible_geoms(m, fr.option) == m.ngeom
