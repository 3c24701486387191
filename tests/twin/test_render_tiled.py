"""Tests of drawing a tiled twin (twin/render/run.py make_renderer, twin/render/tile_closeup.py):
the wide cameras go to MergedFrameRenderer; the close-up is a model of the part of the array
around the robot, posed from the whole-array angles, and draws the frame the whole-array
model draws."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import rfp_twin.twin.render  # noqa: F401  (first: picks MUJOCO_GL before mujoco is imported)
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.mjcf.tiled_twin import build_tiled
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.render import (FrameRenderer, MergedFrameRenderer, RenderError, RenderSettings,
                                  make_renderer)
from rfp_twin.twin.render.tile_closeup import TileCloseupRenderer, closeup_robot

SPEC = load_spec("sdss-v")


@pytest.fixture(scope="module")
def pair():
    lay = layout_by_name("hex:919", SPEC.pitch_mm)
    return build_model(SPEC, lay), build_tiled(SPEC, lay, max_robots=300)


def test_wide_cameras_of_a_tiled_twin_draw_what_the_one_model_draws(pair):
    """919 robots >= 10 px apart: FrameRenderer of a one-model copy (the merged renderer
    when asked for)."""
    one, tiled = pair
    settings = RenderSettings(width=320, height=240, camera="oblique")
    rng = np.random.default_rng(4)
    angles = np.column_stack([rng.uniform(0, 360, 919), rng.uniform(5, 175, 919)])
    with make_renderer(one, settings) as a, make_renderer(tiled, settings) as b:
        assert type(a) is type(b) is FrameRenderer
        assert np.array_equal(a.render(angles), b.render(angles))
    with make_renderer(tiled, replace(settings, merged=True)) as fr:
        assert isinstance(fr, MergedFrameRenderer)
        assert fr.render().shape == (240, 320, 3)


@pytest.mark.parametrize("robot", [None, 40, 700])
def test_tile_closeup_draws_the_whole_model_closeup(pair, robot):
    one, tiled = pair
    n = one.n_robots
    rng = np.random.default_rng(2)
    angles = np.column_stack([rng.uniform(0, 360, n), rng.uniform(5, 175, n)])
    states = rng.integers(0, 4, n)
    settings = RenderSettings(width=320, height=240, camera="closeup", robot_id=robot)
    with make_renderer(one, settings) as a, make_renderer(tiled, settings) as b:
        assert isinstance(b, TileCloseupRenderer)
        img_a, img_b = a.render(angles, states), b.render(angles, states)
        # the close-up model is a true part of the array
        assert b._robots.size < 0.6 * n
    assert np.abs(img_a.astype(int) - img_b.astype(int)).mean() < 1.0
    assert img_b.std() > 10                                  # not a blank frame
    if robot is None:
        centre = one.layout.robot_index(closeup_robot(tiled, settings))
        assert np.hypot(*one.layout.robot_xy[centre]) < 1e-9  # the hex centre robot


def test_tile_closeup_rejects_wrong_shapes(pair):
    _, tiled = pair
    with TileCloseupRenderer(tiled, RenderSettings(width=64, height=48, camera="closeup")) as r:
        with pytest.raises(RenderError, match="allowed: \\(919, 2\\)"):
            r.render(np.zeros((60, 2)))
        with pytest.raises(RenderError, match="closeup"):
            TileCloseupRenderer(tiled, RenderSettings(width=64, height=48, camera="top"))
