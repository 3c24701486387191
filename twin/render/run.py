"""A whole run to video: simulate (unless given the report), build the frame timeline,
draw every frame and encode it to MP4, timing the drawing and the encoding.

Frames are (height, width, 3) uint8; times are seconds (simulated time for the timeline,
wall time for the report's timings).
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Callable

import numpy as np

from rfp_twin.models.mjcf import TwinModel, build_model
from rfp_twin.models.mjcf.tiled_twin import TiledTwin
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.render.backend import RenderError, require_backend
from rfp_twin.twin.render.frames import FrameRenderer
from rfp_twin.twin.render.camera import wide_camera_setup
from rfp_twin.twin.render.merged import MERGED_MIN_ROBOTS, MergedFrameRenderer, use_merged
from rfp_twin.twin.render.report import RenderReport
from rfp_twin.twin.render.settings import RenderSettings
from rfp_twin.twin.render.timeline import frame_timeline
from rfp_twin.twin.render.video import Mp4Writer
from rfp_twin.twin.sim import SimReport, SimSettings, simulate

#: ``progress(frames_done, frames_total)``.
Progress = Callable[[int, int], None]


#: A tiled twin whose robots are too far apart in the frame for top caps is drawn from a
#: one-model copy up to this many robots (its compile is quadratic: ~4 s at 5,000).
ONE_MODEL_RENDER_MAX = 5000


def make_renderer(twin: TwinModel, settings: RenderSettings):
    """The renderer for ``twin`` with ``settings``: :class:`MergedFrameRenderer` when
    :func:`rfp_twin.twin.render.merged.use_merged` says so (``settings.merged``, or auto:
    a wide camera and a large array whose robots are a few pixels, drawn as top caps),
    else :class:`FrameRenderer`. A tiled twin has no whole-array model: its close-up is
    drawn from the part of the array around the robot
    (:class:`rfp_twin.twin.render.tile_closeup.TileCloseupRenderer`), and where
    FrameRenderer is the choice on a wide camera, from a one-model copy of up to
    :data:`ONE_MODEL_RENDER_MAX` robots (larger: MergedFrameRenderer with full meshes)."""
    tiled = isinstance(twin, TiledTwin)
    if tiled and not settings.wide:
        from rfp_twin.twin.render.tile_closeup import TileCloseupRenderer

        return TileCloseupRenderer(twin, settings)
    pitch_px = None
    if settings.wide and settings.merged is None and twin.n_robots > MERGED_MIN_ROBOTS:
        pitch_px = wide_camera_setup(twin.spec, twin.layout, twin.geometry.params,
                                     settings)[3]
    if use_merged(settings, twin.n_robots, pitch_px) or (
            tiled and twin.n_robots > ONE_MODEL_RENDER_MAX):
        return MergedFrameRenderer(twin.spec, twin.layout, twin.geometry, settings)
    if tiled:
        twin = build_model(twin.spec, twin.layout, twin.geometry, twin.options)
    return FrameRenderer(twin, settings)


def render_run(twin: TwinModel, trajectory: Trajectory | None, out_mp4: str | Path,
               settings: RenderSettings | None = None, sim_report: SimReport | None = None,
               faults=(), sim_settings: SimSettings | None = None,
               progress: Progress | None = None) -> RenderReport:
    """Render a run to an MP4.

    Parameters
    ----------
    twin : TwinModel
    trajectory : what to simulate (ignored when ``sim_report`` is given).
    out_mp4 : path of the video (written atomically).
    settings : RenderSettings (``settings.merged``: which renderer, :func:`make_renderer`)
    sim_report : a finished simulation with its record; default: simulate ``trajectory``
        with ``faults`` and ``sim_settings`` (:func:`rfp_twin.twin.sim.simulate`).
    progress : called as ``progress(frames_done, frames_total)`` after each frame.

    Returns
    -------
    RenderReport
    """
    settings = settings or RenderSettings()
    backend = require_backend()
    sim_wall = 0.0
    if sim_report is None:
        if trajectory is None:
            raise RenderError("render_run needs a trajectory or a simulation report")
        t0 = time.perf_counter()
        sim_report = simulate(twin, trajectory, faults, sim_settings, record=True)
        sim_wall = time.perf_counter() - t0
    timeline = frame_timeline(twin, sim_report, settings)
    t_total = time.perf_counter()
    t_render = 0.0
    with make_renderer(twin, settings) as fr, \
            Mp4Writer(out_mp4, settings.width, settings.height, settings.fps, settings.crf,
                      settings.preset) as writer:
        frame = np.empty((settings.height, settings.width, 3), dtype=np.uint8)
        for j in range(timeline.n_frames):
            t0 = time.perf_counter()
            fr.render(timeline.angles[j], timeline.states[j], out=frame)
            t_render += time.perf_counter() - t0
            writer.write(frame)
            if progress is not None:
                progress(j + 1, timeline.n_frames)
        frames = writer.frames
    total = time.perf_counter() - t_total
    return RenderReport(Path(out_mp4), frames, frames / settings.fps, float(sim_report.sim_s),
                        settings.width, settings.height, float(settings.fps),
                        float(settings.speedup), settings.camera, backend, t_render, total,
                        sim_wall, timeline.state_counts(), sim_report)
