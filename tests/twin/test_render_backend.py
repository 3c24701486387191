"""Tests of rfp_twin.twin.render.backend: the offscreen OpenGL backend (EGL, else OSMesa) is chosen
before mujoco is imported, falls back in order, and fails with a clear message.

Nothing is skipped: on a machine where neither EGL nor OSMesa works, the first test fails
with the probe's message (install Debian libegl1 or libosmesa6).
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import rfp_twin.twin.render as render  # first: picks MUJOCO_GL before mujoco is imported here
from rfp_twin.twin.render import RenderError, RenderSettings, render_frame

ROOT = Path(__file__).resolve().parents[2]

#: Python lines that render a 64x48 frame of the 7-robot grid as ``img`` (module ``r``).
RENDER_7 = ("from rfp_twin.models.layout import Layout\nfrom rfp_twin.models.robot import load_spec\n"
            "from rfp_twin.models.mjcf import build_model\nimport rfp_twin.twin.render as r\n"
            "spec = load_spec('sdss-v')\n"
            "img = r.render_frame(build_model(spec, Layout.hex_grid(1, spec.pitch_mm)),\n"
            "                     settings=r.RenderSettings(width=64, height=48))\n")


def run_python(code: str, **env_extra: str) -> str:
    """Run ``code`` in a fresh Python with no MUJOCO_GL / PYOPENGL_PLATFORM (unless given
    in ``env_extra``); asserts it succeeds and returns its stdout."""
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    out = subprocess.run([sys.executable, "-c", code], env=dict(env, **env_extra), cwd=ROOT,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_an_offscreen_backend_works(twin7):
    try:
        backend = render.require_backend()
    except RenderError as exc:
        pytest.fail(f"no offscreen OpenGL: {exc}")
    assert render.BACKEND is not None and os.environ["MUJOCO_GL"] == backend
    try:
        img = render_frame(twin7, None, RenderSettings(width=16, height=16))
    except RenderError as exc:
        pytest.fail(f"MUJOCO_GL={backend} cannot render: {exc}")
    assert img.shape == (16, 16, 3)
    assert render.gl_renderer_info().startswith(f"{backend}: ")


def test_backend_is_chosen_in_a_fresh_process_before_mujoco_is_imported():
    out = run_python("import os, rfp_twin.twin.render as r, mujoco\n"
                     "from mujoco.rendering.classic import gl_context as g\n"
                     "print(r.BACKEND, os.environ['MUJOCO_GL'], g._MUJOCO_GL)\n")
    chosen, env_gl, mujoco_gl = out.split()
    assert chosen in ("egl", "osmesa") and chosen == env_gl == mujoco_gl


def test_importing_any_render_module_chooses_the_backend_first():
    """A render module that imports mujoco (frames) runs the package first, which picks
    the backend first."""
    out = run_python("import os\nimport rfp_twin.twin.render.frames\n"
                     "from mujoco.rendering.classic import gl_context as g\n"
                     "print(os.environ['MUJOCO_GL'], g._MUJOCO_GL)\n")
    env_gl, mujoco_gl = out.split()
    assert env_gl in ("egl", "osmesa") and env_gl == mujoco_gl


def test_rendering_works_even_if_mujoco_was_imported_first():
    out = run_python("import mujoco\n" + RENDER_7 + "print(img.shape, float(img.std()) > 5)\n")
    assert out.strip() == "(48, 64, 3) True"


def test_selection_falls_back_to_the_next_backend_and_osmesa_renders():
    out = run_python("import os, rfp_twin.twin.render as r\n"
                     "os.environ.pop('MUJOCO_GL'); os.environ.pop('PYOPENGL_PLATFORM', None)\n"
                     "print(r.select_gl_backend(('no-such-backend', 'osmesa')))\n")
    assert out.split()[-1] == "osmesa"
    out = run_python(RENDER_7 + "print(r.require_backend(), float(img.std()) > 5)\n",
                     MUJOCO_GL="osmesa")
    assert out.split()[-2:] == ["osmesa", "True"]


def test_no_working_backend_is_a_clear_error():
    out = run_python("import os, rfp_twin.twin.render as r\n"
                     "os.environ.pop('MUJOCO_GL'); os.environ.pop('PYOPENGL_PLATFORM', None)\n"
                     "try:\n    r.select_gl_backend(('bad1', 'bad2'))\n"
                     "except r.RenderError as e:\n    print('ERR', e)\n")
    assert out.startswith("ERR no offscreen OpenGL backend works (bad1: ")
    assert "; bad2: " in out and "libegl1" in out and "libosmesa6" in out


def test_a_broken_backend_is_reported_not_fatal():
    ok, why = render.probe_gl_backend("no-such-backend")
    assert not ok and "MUJOCO_GL" in why

