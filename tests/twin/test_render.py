"""Tests of twin.render: offscreen frames (EGL, else OSMesa) and MP4 videos of small grids.

Nothing is skipped: on a machine where neither EGL nor OSMesa works, the first test fails
with the probe's message (install Debian libegl1 or libosmesa6).
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import imageio.v2 as iio2
import numpy as np
import pytest

import twin.render as render  # first: picks MUJOCO_GL before mujoco is imported here
from twin.render import (ARRIVED, CONTACT, MOVING, WAITING, FrameRenderer, RenderError,
                         RenderSettings, frame_timeline, frame_times, render_frame, render_run)
from twin.sim import simulate
from tests.twin.builders import centre_robot as _centre, moves_trajectory as _moves

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def colliding7(twin7):
    """The centre robot unfolds straight into its +x neighbour (as in test_sim)."""
    lay = twin7.layout
    c = _centre(lay)
    traj = _moves(lay, {c: ([0.0, 6.0], [10.0, 0.0], [170.0, 0.0])})
    return traj, simulate(twin7, traj)


def _beta_midpoints(fr: FrameRenderer) -> np.ndarray:
    """(n, 3) world points halfway along each beta arm, on its top face."""
    idx = fr.twin.index
    base = fr.data.xpos[idx.beta_body]
    tip = fr.data.site_xpos[idx.fiber_site[:, 0]]
    mid = (base + tip) / 2.0
    mid[:, 2] = tip[:, 2]
    return mid


def _pixels(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    cols = np.clip(np.round(uv[:, 0]).astype(int), 0, img.shape[1] - 1)
    rows = np.clip(np.round(uv[:, 1]).astype(int), 0, img.shape[0] - 1)
    return img[rows, cols].astype(int)


# -- backend ---------------------------------------------------------------------------------
def test_an_offscreen_backend_works(twin7):
    assert render.BACKEND is not None, f"no offscreen OpenGL: {render._BACKEND_ERROR}"
    assert os.environ["MUJOCO_GL"] == render.require_backend()
    try:
        img = render_frame(twin7, None, RenderSettings(width=16, height=16))
    except RenderError as exc:
        pytest.fail(f"MUJOCO_GL={render.require_backend()} cannot render: {exc}")
    assert img.shape == (16, 16, 3)


def test_backend_is_chosen_in_a_fresh_process_before_mujoco_is_imported():
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    code = ("import os, twin.render as r, mujoco\n"
            "from mujoco.rendering.classic import gl_context as g\n"
            "print(r.BACKEND, os.environ['MUJOCO_GL'], g._MUJOCO_GL)\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    chosen, env_gl, mujoco_gl = out.stdout.split()
    assert chosen in ("egl", "osmesa") and chosen == env_gl == mujoco_gl


def test_rendering_works_even_if_mujoco_was_imported_first():
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    code = ("import mujoco\n"
            "from models.layout import Layout\nfrom models.robot import load_spec\n"
            "from models.mjcf import build_model\n"
            "import twin.render as r\n"
            "spec = load_spec('sdss-v')\n"
            "img = r.render_frame(build_model(spec, Layout.hex_grid(1, spec.pitch_mm)),\n"
            "                     settings=r.RenderSettings(width=64, height=48))\n"
            "print(img.shape, float(img.std()) > 5)\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "(48, 64, 3) True"


def test_selection_falls_back_to_the_next_backend_and_osmesa_renders():
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    code = ("import os, twin.render as r\n"
            "os.environ.pop('MUJOCO_GL'); os.environ.pop('PYOPENGL_PLATFORM', None)\n"
            "print(r.select_gl_backend(('no-such-backend', 'osmesa')))\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[-1] == "osmesa"
    code = ("from models.layout import Layout\nfrom models.robot import load_spec\n"
            "from models.mjcf import build_model\nimport twin.render as r\n"
            "spec = load_spec('sdss-v')\n"
            "img = r.render_frame(build_model(spec, Layout.hex_grid(1, spec.pitch_mm)),\n"
            "                     settings=r.RenderSettings(width=64, height=48))\n"
            "print(r.require_backend(), float(img.std()) > 5)\n")
    out = subprocess.run([sys.executable, "-c", code], env=dict(env, MUJOCO_GL="osmesa"), cwd=ROOT,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[-2:] == ["osmesa", "True"]


def test_no_working_backend_is_a_clear_error():
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    code = ("import os, twin.render as r\n"
            "os.environ.pop('MUJOCO_GL'); os.environ.pop('PYOPENGL_PLATFORM', None)\n"
            "try:\n    r.select_gl_backend(('bad1', 'bad2'))\n"
            "except r.RenderError as e:\n    print('ERR', e)\n")
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("ERR no offscreen OpenGL backend works (bad1: ")
    assert "; bad2: " in out.stdout and "libegl1" in out.stdout and "libosmesa6" in out.stdout


def test_a_broken_backend_is_reported_not_fatal():
    ok, why = render.probe_gl_backend("no-such-backend")
    assert not ok and "MUJOCO_GL" in why


# -- settings ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, message", [
    ({"width": 641}, "field 'width' = 641; allowed: an even integer"),
    ({"height": 8}, "field 'height' = 8"),
    ({"fps": 0}, "field 'fps' = 0; allowed: a finite number > 0"),
    ({"speedup": float("nan")}, "field 'speedup'"),
    ({"camera": "side"}, "field 'camera' = 'side'; allowed: top, oblique, closeup"),
    ({"robot_id": 3}, "allowed: a robot id only with camera 'closeup'"),
    ({"crf": 60}, "field 'crf' = 60"),
    ({"preset": "quick"}, "field 'preset' = 'quick'; allowed: ultrafast"),
])
def test_bad_settings_raise_one_line_errors(kwargs, message):
    with pytest.raises(RenderError) as err:
        RenderSettings(**kwargs)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_frame_times_cover_the_run_at_fps_and_speedup():
    t = frame_times(6.5, RenderSettings(fps=10, speedup=2.0))
    assert t.size == 33 and t[0] == 0.0 and math.isclose(t[-1], 6.4)
    assert frame_times(1.0, RenderSettings(fps=30)).size == 31


# -- frames ------------------------------------------------------------------------------------
def test_top_frame_is_not_blank_and_shows_robots_in_state_colours(twin7):
    s = RenderSettings(width=320, height=240, camera="top")
    rgba_before = twin7.model.geom_rgba.copy()
    with FrameRenderer(twin7, s) as fr:
        n = twin7.n_robots
        img = fr.render(None, np.full(n, MOVING))
        assert img.shape == (240, 320, 3) and img.dtype == np.uint8
        assert img.std() > 20
        assert len(np.unique(img.reshape(-1, 3) // 16, axis=0)) > 20   # many distinct colours
        # each robot's beta arm, halfway along, is blue (moving)
        px = _pixels(img, fr.project(_beta_midpoints(fr)))
        assert np.all(px[:, 2] > px[:, 0] + 60) and np.all(px[:, 2] > 120), px
        # in contact: red; arrived: green
        img = fr.render(None, np.full(n, CONTACT))
        px = _pixels(img, fr.project(_beta_midpoints(fr)))
        assert np.all(px[:, 0] > px[:, 1] + 60) and np.all(px[:, 0] > px[:, 2] + 60), px
        img = fr.render(None, np.full(n, ARRIVED))
        px = _pixels(img, fr.project(_beta_midpoints(fr)))
        assert np.all(px[:, 1] > px[:, 0] + 40) and np.all(px[:, 1] > px[:, 2] + 40), px
        # waiting: the beta arm's own light grey
        img = fr.render(None, np.full(n, WAITING))
        px = _pixels(img, fr.project(_beta_midpoints(fr)))
        assert np.all(px.min(axis=1) > 120) and np.all(px.max(axis=1) - px.min(axis=1) < 50), px
    np.testing.assert_array_equal(twin7.model.geom_rgba, rgba_before)   # the twin is untouched


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
    with pytest.raises(Exception, match="robot"):
        FrameRenderer(twin7, RenderSettings(camera="closeup", robot_id=99999))


def test_lean_and_full_settings_both_render(twin7):
    full = render_frame(twin7, None, RenderSettings(width=160, height=120, lean=False))
    lean = render_frame(twin7, None, RenderSettings(width=160, height=120, lean=True))
    assert full.std() > 20 and lean.std() > 20


# -- whole runs --------------------------------------------------------------------------------
def test_timeline_states_of_a_colliding_run(twin7, colliding7):
    _, report = colliding7
    lay = twin7.layout
    c = lay.robot_index(_centre(lay))
    s = RenderSettings(width=160, height=120, fps=10, speedup=2.0)
    tl = frame_timeline(twin7, report, s)
    assert tl.n_frames == int(math.floor(report.sim_s * 10 / 2.0 + 1e-9)) + 1
    assert tl.states[1, c] == MOVING                       # on its way
    assert np.any(tl.states[:, c] == CONTACT)              # then blocked by its neighbour
    touched = {lay.robot_index(int(r)) for p in report.contacts.pairs()
               for r in (p["robot_a"], p["robot_b"])}
    assert touched == {int(k) for k in np.flatnonzero((tl.states == CONTACT).any(axis=0))}
    others = [k for k in range(7) if k not in touched]
    assert np.all(tl.states[:, others] == ARRIVED)         # never moved, at their end


def test_render_run_writes_an_mp4_with_the_expected_frames(tmp_path, twin7, colliding7):
    traj, report = colliding7
    s = RenderSettings(width=160, height=120, fps=10, speedup=2.0)
    out = tmp_path / "fold.mp4"
    seen = []
    r = render_run(twin7, traj, out, s, sim_report=report, progress=lambda i, n: seen.append((i, n)))
    expected = int(math.floor(report.sim_s * 10 / 2.0 + 1e-9)) + 1
    assert r.frames == expected and seen[-1] == (expected, expected)
    assert r.backend == render.require_backend() and r.fps_rendered > 0
    assert r.state_counts["contact"] > 0
    reader = iio2.get_reader(out)
    assert reader.count_frames() == expected
    frames = [f for f in reader]
    reader.close()
    assert len(frames) == expected and frames[0].shape == (120, 160, 3)
    assert max(f.std() for f in frames) > 20
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fold.mp4"]   # no temp file left


def test_render_run_simulates_when_given_no_report(tmp_path, twin7):
    lay = twin7.layout
    traj = _moves(lay, {_centre(lay): ([0.0, 1.0], [10.0, 40.0], [170.0, 170.0])})
    r = render_run(twin7, traj, tmp_path / "a.mp4", RenderSettings(width=64, height=48, fps=5))
    assert r.sim_report is not None and r.frames == int(math.floor(r.sim_s * 5 + 1e-9)) + 1
    assert (tmp_path / "a.mp4").stat().st_size > 0


def test_failed_render_leaves_nothing(tmp_path, twin7, colliding7):
    traj, report = colliding7
    out = tmp_path / "x.mp4"

    def boom(i, n):
        if i == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        render_run(twin7, traj, out, RenderSettings(width=64, height=48, fps=5),
                   sim_report=report, progress=boom)
    assert list(tmp_path.iterdir()) == []


def test_report_without_record_is_refused(tmp_path, twin7, colliding7):
    traj, _ = colliding7
    report = simulate(twin7, traj, record=False)
    with pytest.raises(RenderError, match="no sampled record"):
        render_run(twin7, traj, tmp_path / "x.mp4", sim_report=report)
    assert list(tmp_path.iterdir()) == []
