"""Offscreen video of a run: MuJoCo frames on the CPU (Mesa), encoded to MP4.

Importing this package picks the OpenGL backend (``MUJOCO_GL``) before anything in it
imports mujoco: :mod:`rfp_twin.twin.render.backend` is imported first, and every submodule import
runs this file first. The parts, in pipeline order:

- :mod:`~rfp_twin.twin.render.backend`: OpenGL backend selection (egl, osmesa), :class:`RenderError`
- :mod:`~rfp_twin.twin.render.settings`: :class:`RenderSettings` (pixels, fps, speed-up, camera)
- :mod:`~rfp_twin.twin.render.camera`: the render copy of the model, fitted cameras, lean re-meshing (mm)
- :mod:`~rfp_twin.twin.render.timeline`: frame times (s), joint angles (deg) and robot states per frame
- :mod:`~rfp_twin.twin.render.frames`: :class:`FrameRenderer`, robots coloured by state, (h, w, 3) uint8
- :mod:`~rfp_twin.twin.render.merged`: :class:`MergedFrameRenderer`, large arrays in a handful
  of merged meshes (no compiled grid model needed)
- :mod:`~rfp_twin.twin.render.video`: :class:`Mp4Writer` (H.264) and :func:`save_png`
- :mod:`~rfp_twin.twin.render.run`: :func:`render_run`, a whole run to MP4, and its
  :class:`RenderReport` (:mod:`~rfp_twin.twin.render.report`)
"""
# The backend first (before mujoco is imported): keep this import at the top.
from rfp_twin.twin.render.backend import (BACKEND, GL_BACKENDS, PROBE_TIMEOUT_S, RenderError,
                                 gl_renderer_info, probe_gl_backend, require_backend,
                                 select_gl_backend)
from rfp_twin.twin.render.camera import (FIT_MARGIN, LEAN_MIN_SECTIONS, LEAN_SAGITTA_PX,
                                         fit_camera_pose, fitted_camera, lean_circle_sections,
                                         lean_sections_for, render_model, wide_camera_setup)
from rfp_twin.twin.render.frames import ALPHA_SHADE, LEAN_OFF_FLAGS, STATE_RGBA, FrameRenderer, render_frame
from rfp_twin.twin.render.merged import MERGED_MIN_ROBOTS, MergedFrameRenderer, use_merged
from rfp_twin.twin.render.report import RenderReport
from rfp_twin.twin.render.run import Progress, make_renderer, render_run
from rfp_twin.twin.render.settings import MAX_SIZE, X264_PRESETS, RenderSettings
from rfp_twin.twin.render.timeline import (ARRIVED, ARRIVED_TOL_DEG, CONTACT, MOVING, MOVING_DEG_S,
                                  STATE_NAMES, WAITING, FrameTimeline, frame_timeline,
                                  frame_times)
from rfp_twin.twin.render.video import Mp4Writer, save_png

__all__ = ["ALPHA_SHADE", "ARRIVED", "ARRIVED_TOL_DEG", "BACKEND", "CONTACT", "FIT_MARGIN",
           "FrameRenderer", "FrameTimeline", "GL_BACKENDS", "LEAN_MIN_SECTIONS", "LEAN_OFF_FLAGS",
           "LEAN_SAGITTA_PX", "MAX_SIZE", "MERGED_MIN_ROBOTS", "MOVING", "MOVING_DEG_S",
           "MergedFrameRenderer", "Mp4Writer",
           "PROBE_TIMEOUT_S", "Progress", "RenderError", "RenderReport", "RenderSettings",
           "STATE_NAMES", "STATE_RGBA", "WAITING", "X264_PRESETS", "fit_camera_pose",
           "fitted_camera", "frame_timeline", "frame_times", "gl_renderer_info",
           "lean_circle_sections", "lean_sections_for", "make_renderer", "probe_gl_backend",
           "render_frame", "render_model", "render_run", "require_backend", "save_png",
           "select_gl_backend", "use_merged", "wide_camera_setup"]
