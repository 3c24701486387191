"""Tests of rfp_twin.twin.render.camera: a fitted camera frames the whole grid, centred; lean
renders re-mesh round parts with as few facets as keep them round on screen; the render
model is a copy (the twin is never changed)."""
from __future__ import annotations

import math

import rfp_twin.twin.render  # noqa: F401, I001  (first: picks MUJOCO_GL before mujoco is imported)

import mujoco
import numpy as np
import pytest

from rfp_twin.twin.render import RenderSettings
from rfp_twin.twin.render.camera import (FIT_MARGIN, LEAN_MIN_SECTIONS, LEAN_SAGITTA_PX, fitted_camera,
                                focal_px, lean_circle_sections, render_model)


def grid_extent_points(twin) -> np.ndarray:
    """(k, 3) mm: every base plus the arm reach in 16 directions, at the bottom of the
    fixed bodies and at the focal surface (what a fitted camera must show)."""
    spec, p = twin.spec, twin.geometry.params
    reach = spec.alpha_length_mm + spec.beta_length_mm + p.beta_half_width_mm
    ang = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    xy = (twin.layout.xy[:, None, :] + reach * np.stack([np.cos(ang), np.sin(ang)], 1)[None])
    xy = xy.reshape(-1, 2)
    zs = (twin.base_z_mm - p.body_length_mm, p.focal_z_mm)
    return np.vstack([np.column_stack([xy, np.full(len(xy), z)]) for z in zs])


def normalised_image_xy(twin, camera: str, pos: np.ndarray, aspect: float, pts: np.ndarray,
                        xmat: np.ndarray | None = None):
    """Image coordinates of ``pts`` seen by the camera at ``pos`` with orientation ``xmat``
    (default: the model's ``cam_quat``) and the model's field of view: (u, v), each in
    [-1, 1] inside the frame."""
    c = twin.index.camera[camera]
    mat = np.zeros(9)
    if xmat is None:
        mujoco.mju_quat2Mat(mat, np.asarray(twin.model.cam_quat[c], float))
    else:
        mat[:] = np.ravel(xmat)
    rel = (pts - pos) @ mat.reshape(3, 3)
    depth = -rel[:, 2]
    assert np.all(depth > 0)
    t = math.tan(math.radians(float(twin.model.cam_fovy[c])) / 2.0)
    return rel[:, 0] / depth / (t * aspect), rel[:, 1] / depth / t


@pytest.mark.parametrize("camera", ["top", "oblique"])
@pytest.mark.parametrize("aspect", [16 / 9, 1.0, 0.5])
def test_fitted_camera_frames_the_whole_grid_centred(twin7, camera, aspect):
    pos, dist = fitted_camera(twin7, camera, aspect)
    pts = grid_extent_points(twin7)
    u, v = normalised_image_xy(twin7, camera, pos, aspect, pts)
    reach = max(np.abs(u).max(), np.abs(v).max())
    assert reach == pytest.approx(1.0 - FIT_MARGIN, abs=1e-6)      # fills the frame
    assert np.abs(u).max() <= 1.0 - FIT_MARGIN + 1e-6 and np.abs(v).max() <= 1.0 - FIT_MARGIN + 1e-6
    assert abs(u.max() + u.min()) / 2 < 0.02 and abs(v.max() + v.min()) / 2 < 0.02  # centred
    assert dist > 0


def test_lean_sections_are_the_fewest_that_look_round(twin7):
    p = twin7.geometry.params
    s = RenderSettings(width=1280, height=720)
    f = focal_px(twin7.model, twin7.index.camera["top"], 720)
    radius_mm = max(p.body_radius_mm, p.alpha_hub_radius_mm)
    seen = []
    for distance in (50.0, 150.0, 400.0, 1500.0, 1e5):
        n = lean_circle_sections(twin7, s, distance)
        seen.append(n)
        assert n % 4 == 0 and LEAN_MIN_SECTIONS <= n <= p.circle_sections
        r_px = radius_mm * f / distance
        sagitta = lambda k: r_px * (1.0 - math.cos(math.pi / k))  # noqa: E731
        if n < p.circle_sections:
            assert sagitta(n) <= LEAN_SAGITTA_PX + 1e-9
        if n > LEAN_MIN_SECTIONS:
            assert sagitta(n - 4) > LEAN_SAGITTA_PX                # fewer would look faceted
    assert seen == sorted(seen, reverse=True) and seen[-1] == LEAN_MIN_SECTIONS


def test_render_model_is_a_lean_copy_with_the_fitted_camera(twin7):
    before = {k: np.array(getattr(twin7.model, k)) for k in ("cam_pos", "cam_quat", "mesh_vert")}
    s = RenderSettings(width=320, height=180, camera="top")
    lean = render_model(twin7, s)
    full = render_model(twin7, RenderSettings(width=320, height=180, camera="top", lean=False))
    for k, v in before.items():
        np.testing.assert_array_equal(getattr(twin7.model, k), v)    # the twin is untouched
    assert lean.model is not twin7.model and full.model is not twin7.model
    assert lean.model.nmeshvert < full.model.nmeshvert == twin7.model.nmeshvert
    c = twin7.index.camera["top"]
    pos, _ = fitted_camera(twin7, "top", 320 / 180)
    np.testing.assert_allclose(lean.model.cam_pos[c], pos)
    np.testing.assert_array_equal(lean.model.cam_quat[c], twin7.model.cam_quat[c])
    assert lean.model.vis.global_.offwidth >= 320 and lean.model.vis.global_.offheight >= 180
    assert lean.model.vis.quality.offsamples == 0


def test_render_model_aims_the_closeup_at_the_chosen_robot(twin7):
    rid = int(twin7.layout.robot_ids[-1])
    rt = render_model(twin7, RenderSettings(camera="closeup", robot_id=rid))
    c = twin7.index.camera["closeup"]
    assert not np.array_equal(rt.model.cam_pos[c], twin7.model.cam_pos[c])
    d = mujoco.MjData(rt.model)
    mujoco.mj_kinematics(rt.model, d)
    mujoco.mj_camlight(rt.model, d)
    k = twin7.layout.robot_index(rid)
    u, v = normalised_image_xy(rt, "closeup", d.cam_xpos[c], 16 / 9,
                               d.xpos[rt.index.alpha_body[k]][None], d.cam_xmat[c])
    assert abs(u[0]) < 0.05 and abs(v[0]) < 0.2          # near the centre of the frame
