"""Tests of rfp_twin.twin.render.frames: offscreen frames of a small grid show the robots where
their angles put them, coloured by state, with every camera and quality setting."""
from __future__ import annotations

import numpy as np
import pytest

import rfp_twin.twin.render  # noqa: F401  (first: picks MUJOCO_GL before mujoco is imported)
from rfp_twin.twin.render import (ALPHA_SHADE, ARRIVED, CONTACT, MOVING, STATE_RGBA, WAITING,
                         FrameRenderer, RenderError, RenderSettings, render_frame)
from rfp_twin.twin.render.frames import state_palette


def _beta_midpoints(fr: FrameRenderer) -> np.ndarray:
    """(n, 3) world points halfway along each beta arm, on its top face, mm."""
    idx = fr.twin.index
    base = fr.data.xpos[idx.beta_body]
    tip = fr.data.site_xpos[idx.fiber_site[:, 0]]
    mid = (base + tip) / 2.0
    mid[:, 2] = tip[:, 2]
    return mid


def _pixels(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(k, 3) int colours of ``img`` at pixel coordinates (k, 2) (column, row)."""
    cols = np.clip(np.round(uv[:, 0]).astype(int), 0, img.shape[1] - 1)
    rows = np.clip(np.round(uv[:, 1]).astype(int), 0, img.shape[0] - 1)
    return img[rows, cols].astype(int)


def test_top_frame_is_not_blank_and_shows_robots_in_state_colours(twin7):
    s = RenderSettings(width=320, height=240, camera="top")
    rgba_before = twin7.model.geom_rgba.copy()
    with FrameRenderer(twin7, s) as fr:
        n = twin7.n_robots

        def beta_colours(state):
            img = fr.render(None, np.full(n, state))
            return img, _pixels(img, fr.project(_beta_midpoints(fr)))

        img, px = beta_colours(MOVING)
        assert img.shape == (240, 320, 3) and img.dtype == np.uint8
        assert img.std() > 20
        assert len(np.unique(img.reshape(-1, 3) // 16, axis=0)) > 20   # many distinct colours
        # each robot's beta arm, halfway along, is blue (moving)
        assert np.all(px[:, 2] > px[:, 0] + 60) and np.all(px[:, 2] > 120), px
        # in contact: red; arrived: green
        _, px = beta_colours(CONTACT)
        assert np.all(px[:, 0] > px[:, 1] + 60) and np.all(px[:, 0] > px[:, 2] + 60), px
        _, px = beta_colours(ARRIVED)
        assert np.all(px[:, 1] > px[:, 0] + 40) and np.all(px[:, 1] > px[:, 2] + 40), px
        # waiting: the beta arm's own light grey
        _, px = beta_colours(WAITING)
        assert np.all(px.min(axis=1) > 120) and np.all(px.max(axis=1) - px.min(axis=1) < 50), px
    np.testing.assert_array_equal(twin7.model.geom_rgba, rgba_before)   # the twin is untouched


def test_state_palette_colours_beta_then_darker_alpha_geoms(twin7):
    m, idx = twin7.model, twin7.index
    geoms, robot, pal = state_palette(m, idx)
    assert pal.shape == (geoms.size, 4, 4) and robot.shape == geoms.shape
    body = np.asarray(m.geom_bodyid)[geoms]
    is_beta = np.isin(body, idx.beta_body)
    assert np.isin(body, np.concatenate([idx.alpha_body, idx.beta_body])).all()
    assert not idx.geom_collision[geoms].any()
    assert set(robot.tolist()) == set(range(twin7.n_robots))
    np.testing.assert_allclose(idx.beta_body[robot[is_beta]], body[is_beta])
    blue = np.asarray(STATE_RGBA[MOVING], np.float32)
    np.testing.assert_allclose(pal[is_beta, MOVING], np.tile(blue, (is_beta.sum(), 1)))
    np.testing.assert_allclose(pal[~is_beta, MOVING, :3], np.tile(blue[:3] * ALPHA_SHADE,
                                                                  ((~is_beta).sum(), 1)), rtol=1e-6)


def test_frames_follow_the_angles(twin7):
    s = RenderSettings(width=160, height=120, camera="top")
    a = render_frame(twin7, np.tile([10.0, 170.0], (7, 1)), s)
    b = render_frame(twin7, np.tile([100.0, 10.0], (7, 1)), s)
    assert np.abs(a.astype(int) - b).mean() > 2


@pytest.mark.parametrize("camera", ["oblique", "closeup"])
def test_other_cameras_show_the_robots(twin7, camera):
    img = render_frame(twin7, None, RenderSettings(width=160, height=120, camera=camera),
                       np.full(7, CONTACT))
    assert img.std() > 20
    red = (img[..., 0] > 150) & (img[..., 1] < 80) & (img[..., 2] < 80)
    assert red.mean() > 0.01


def test_closeup_looks_at_the_chosen_robot(twin7):
    lay = twin7.layout
    rid = int(lay.robot_ids[-1])
    s = RenderSettings(width=160, height=120, camera="closeup", robot_id=rid)
    with FrameRenderer(twin7, s) as fr:
        k = lay.robot_index(rid)
        uv = fr.project(fr.data.xpos[fr.twin.index.alpha_body[k]][None])[0]
        assert abs(uv[0] - 80) < 20 and abs(uv[1] - 60) < 30
        c = fr.camera.fixedcamid
        backwards = fr.data.cam_xmat[c].reshape(3, 3)[:, 2]            # camera z: backwards
        assert np.isnan(fr.project((fr.data.cam_xpos[c] + 10.0 * backwards)[None])).all()
    with pytest.raises(Exception, match="robot"):
        FrameRenderer(twin7, RenderSettings(camera="closeup", robot_id=99999))


def test_lean_and_full_settings_both_render(twin7):
    full = render_frame(twin7, None, RenderSettings(width=160, height=120, lean=False))
    lean = render_frame(twin7, None, RenderSettings(width=160, height=120, lean=True))
    assert full.std() > 20 and lean.std() > 20


def test_a_closed_renderer_refuses_to_draw(twin7):
    fr = FrameRenderer(twin7, RenderSettings(width=32, height=32))
    out = np.zeros((32, 32, 3), np.uint8)
    assert fr.render(out=out) is out and out.std() > 0
    fr.close()
    fr.close()                                                      # idempotent
    with pytest.raises(RenderError, match="after close"):
        fr.render()
