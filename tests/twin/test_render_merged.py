"""Tests of rfp_twin.twin.render.merged: the merged-mesh renderer draws the same frames as
FrameRenderer (flat and curved woks, both wide cameras), updates its meshes every frame,
colours robots by state, and rejects bad input with one-line errors."""
from __future__ import annotations

import numpy as np
import pytest

import rfp_twin.twin.render  # noqa: F401  (first: picks MUJOCO_GL before mujoco is imported)
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.render import (ARRIVED, CONTACT, MOVING, WAITING, FrameRenderer, RenderError,
                                  RenderSettings, make_renderer)
from rfp_twin.twin.render.merged import (CAP_PITCH_PX, MERGED_MIN_ROBOTS, MergedFrameRenderer,
                                         cap_template, use_merged)


def _twin(preset: str, layout: str):
    spec = load_spec(preset)
    return build_model(spec, layout_by_name(layout, spec.pitch_mm))


@pytest.fixture(scope="module")
def twin19():
    return _twin("sdss-v", "hex:19")


@pytest.fixture(scope="module")
def curved():
    """The calibrated curved-wok instrument: each robot on its own tilted axis."""
    return _twin("sdss-v", "sdss-v-curved")


def _random_pose(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    angles = np.column_stack([rng.uniform(0, 360, n), rng.uniform(5, 175, n)])
    return angles, rng.integers(0, 4, n)


def _pixels(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    cols = np.clip(np.round(uv[:, 0]).astype(int), 0, img.shape[1] - 1)
    rows = np.clip(np.round(uv[:, 1]).astype(int), 0, img.shape[0] - 1)
    return img[rows, cols].astype(int)


def _colour_counts(img: np.ndarray) -> list[int]:
    """Pixels that are clearly blue (moving), red (contact), green (arrived)."""
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return [int(np.count_nonzero((b > r + 60) & (b > 120))),
            int(np.count_nonzero((r > g + 60) & (r > b + 60))),
            int(np.count_nonzero((g > r + 40) & (g > b + 40)))]


def _both(twin, settings, angles, states):
    with FrameRenderer(twin, settings) as fr:
        ref = fr.render(angles, states)
    with MergedFrameRenderer(twin.spec, twin.layout, twin.geometry, settings) as mr:
        img = mr.render(angles, states)
        mids = mr.project(mr.robot_points("beta", twin.spec.beta_length_mm / 2.0))
        caps = mr.caps
    return ref, img, mids, caps


@pytest.mark.parametrize("camera", ["top", "oblique"])
def test_merged_frame_matches_frame_renderer(twin19, camera):
    angles, states = _random_pose(twin19.n_robots, 3)
    s = RenderSettings(width=320, height=240, camera=camera)
    ref, img, mids, caps = _both(twin19, s, angles, states)
    assert not caps                                       # lean meshes at this size
    assert img.shape == ref.shape and img.dtype == np.uint8
    diff = np.abs(ref.astype(int) - img)
    assert diff.mean() < 0.5, diff.mean()
    assert (diff.max(axis=2) > 40).mean() < 0.005
    # the beta arms, halfway along, are in their state's colour
    px = _pixels(img, mids)
    blue, red, green = states == MOVING, states == CONTACT, states == ARRIVED
    assert np.all(px[blue, 2] > px[blue, 0] + 60), px[blue]
    assert np.all(px[red, 0] > px[red, 2] + 60), px[red]
    assert np.all(px[green, 1] > px[green, 0] + 40), px[green]
    wait = states == WAITING
    assert np.all(px[wait].min(axis=1) > 120), px[wait]


def test_curved_wok_robots_stand_where_the_grid_model_puts_them(curved):
    angles, states = _random_pose(curved.n_robots, 5)
    s = RenderSettings(width=640, height=360, camera="oblique")
    ref, img, _, caps = _both(curved, s, angles, states)
    assert not caps
    diff = np.abs(ref.astype(int) - img)
    assert diff.mean() < 0.5, diff.mean()


@pytest.mark.parametrize("size", [(64, 48), (80, 60)])
def test_top_caps_of_a_small_frame_look_like_the_full_render(twin19, size):
    # 19 robots in 64x48 / 80x60 pixels: pitch 7.6 / 9.5 px, under CAP_PITCH_PX: the
    # links are drawn as top caps (quads under QUAD_PITCH_PX)
    angles, states = _random_pose(twin19.n_robots, 7)
    s = RenderSettings(width=size[0], height=size[1], camera="top")
    ref, img, _, caps = _both(twin19, s, angles, states)
    assert caps
    assert np.abs(ref.astype(int) - img).mean() < 4.0
    # as many pixels of each state colour as in the full render
    for got, want in zip(_colour_counts(img), _colour_counts(ref)):
        assert want > 0 and 0.6 * want <= got <= 1.5 * want, (got, want)


def test_cap_template_is_a_flat_upward_outline(twin19):
    mesh = twin19.geometry.links["beta"].visual
    for corners in (4, 6):
        t = cap_template(mesh, corners)
        assert len(t.verts) <= corners and len(t.faces) == len(t.verts) - 2
        np.testing.assert_allclose(t.verts[:, 2], np.asarray(mesh.vertices)[:, 2].max())
        a, b, c = (t.verts[t.faces[:, i]] for i in range(3))
        assert np.all(np.cross(b - a, c - a)[:, 2] > 0)          # faces up
        lo, hi = np.asarray(mesh.vertices)[:, :2].min(0), np.asarray(mesh.vertices)[:, :2].max(0)
        assert np.all((t.verts[:, :2] >= lo - 1e-9) & (t.verts[:, :2] <= hi + 1e-9))


def test_meshes_follow_the_angles_and_states_between_frames(twin19):
    n = twin19.n_robots
    a1, a2 = np.tile([10.0, 170.0], (n, 1)), np.tile([100.0, 10.0], (n, 1))
    s = RenderSettings(width=160, height=120, camera="top")
    with MergedFrameRenderer(twin19.spec, twin19.layout, twin19.geometry, s) as mr:
        first = mr.render(a1, np.full(n, MOVING))
        second = mr.render(a2)                            # same states, new angles
        mids = mr.project(mr.robot_points("beta", twin19.spec.beta_length_mm / 2.0))
        third = mr.render(None, np.full(n, CONTACT))      # same angles, new states
        np.testing.assert_array_equal(mr.render(), third)  # nothing changed
        a3 = a2.copy()
        a3[9] = [200.0, 90.0]                             # one robot moves
        fourth = mr.render(a3)
    with MergedFrameRenderer(twin19.spec, twin19.layout, twin19.geometry, s) as fresh:
        expect = fresh.render(a2, np.full(n, MOVING))
        expect4 = fresh.render(a3, np.full(n, CONTACT))
    assert np.abs(first.astype(int) - second).mean() > 2
    np.testing.assert_array_equal(second, expect)
    assert np.abs(fourth.astype(int) - third).sum() > 0
    np.testing.assert_array_equal(fourth, expect4)
    blue, red = _pixels(second, mids), _pixels(third, mids)
    assert np.all(blue[:, 2] > blue[:, 0] + 60) and np.all(red[:, 0] > red[:, 2] + 60)


def test_bad_input_gives_one_line_errors(twin19):
    n = twin19.n_robots
    s = RenderSettings(width=64, height=48)
    with MergedFrameRenderer(twin19.spec, twin19.layout, None, s) as mr:
        with pytest.raises(RenderError, match=r"angles: shape \(18, 2\); allowed: \(19, 2\)"):
            mr.render(np.zeros((n - 1, 2)))
        with pytest.raises(RenderError, match=r"angles: shape \(38,\)"):
            mr.set_angles(np.zeros(2 * n))
        bad = np.zeros((n, 2))
        bad[4, 1] = np.nan
        with pytest.raises(RenderError, match="angles: robot .* allowed: finite"):
            mr.set_angles(bad)
        with pytest.raises(RenderError, match=r"states: robot .* = 7; allowed: 0\.\.3"):
            mr.set_states(np.full(n, 7))
    with pytest.raises(RenderError, match="render\\(\\) after close"):
        mr.render()
    with pytest.raises(RenderError, match="camera.*closeup.*allowed: top, oblique"):
        MergedFrameRenderer(twin19.spec, twin19.layout, None, RenderSettings(camera="closeup"))
    with pytest.raises(RenderError, match="field 'merged'"):
        RenderSettings(merged="yes")


def test_renderer_choice(twin19):
    big = MERGED_MIN_ROBOTS + 1
    assert use_merged(RenderSettings(), big) and not use_merged(RenderSettings(), 19)
    assert use_merged(RenderSettings(), big, pitch_px=CAP_PITCH_PX - 1)
    assert not use_merged(RenderSettings(), big, pitch_px=CAP_PITCH_PX + 1)   # lean meshes
    assert use_merged(RenderSettings(merged=True), 19)
    assert not use_merged(RenderSettings(merged=False), big)
    assert not use_merged(RenderSettings(camera="closeup", merged=True), big)
    with make_renderer(twin19, RenderSettings(width=64, height=48, merged=True)) as r:
        assert isinstance(r, MergedFrameRenderer) and r.n_robots == 19
    with make_renderer(twin19, RenderSettings(width=64, height=48)) as r:
        assert isinstance(r, FrameRenderer)


def test_render_run_draws_a_whole_run_with_the_merged_renderer(tmp_path, twin7):
    import imageio.v2 as iio2

    from rfp_twin.twin.render import render_run
    from tests.twin.builders import colliding_run

    traj, report = colliding_run(twin7)
    out = tmp_path / "fold.mp4"
    settings = RenderSettings(width=160, height=120, fps=10, speedup=2.0, merged=True)
    merged = render_run(twin7, traj, out, settings, sim_report=report)
    plain = render_run(twin7, traj, tmp_path / "plain.mp4",
                       RenderSettings(width=160, height=120, fps=10, speedup=2.0, merged=False),
                       sim_report=report)
    assert merged.frames == plain.frames > 1 and merged.state_counts["contact"] > 0
    with iio2.get_reader(out) as a, iio2.get_reader(tmp_path / "plain.mp4") as b:
        diffs = [np.abs(x.astype(int) - y).mean() for x, y in zip(a, b)]
    assert len(diffs) == merged.frames and max(diffs) < 0.5, diffs   # the same frames
