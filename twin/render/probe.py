"""A video of a probe-arm plan: the MIRADAS bench in MuJoCo, seen from above.

:func:`render_probe_plan` poses the bench of the plan's kind
(:func:`rfp_twin.models.mjcf.probe_bench.build_probe_bench`, every loop closed) at the
plan's motor angles frame by frame (a kinematic replay; :mod:`rfp_twin.twin.sim.probe`
simulates the servos) and writes an H.264 MP4 through :class:`Mp4Writer`. Units: s, mm.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rfp_twin.twin.render.backend import gl_context_class, require_backend
from rfp_twin.twin.render.video import Mp4Writer


def render_probe_plan(plan, path: str | Path, *, fps: float = 10.0, speedup: float = 10.0,
                      width: int = 640, height: int = 640) -> Path:
    """Write ``path`` (MP4): the plan from its start to its end, ``speedup`` plan seconds
    per video second, top view of the whole bench. Returns the path."""
    backend = require_backend()        # MUJOCO_GL chosen before mujoco is imported
    import mujoco

    from rfp_twin.models.mjcf.probe_bench import build_probe_bench

    bench = build_probe_bench(plan.kind)
    m = bench.model
    d = mujoco.MjData(m)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = [0.0, 0.0, 0.0]
    cam.distance = 3.4 * plan.kind.spec.bench_radius_mm
    cam.elevation, cam.azimuth = -90.0, 90.0
    n_frames = int(plan.makespan_s / speedup * fps) + 1
    # an explicit context of the chosen backend: works even if mujoco was imported first
    gl = gl_context_class(backend)(int(width), int(height))
    gl.make_current()
    try:
        con = mujoco.MjrContext(m, mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, con)
        scene = mujoco.MjvScene(m, maxgeom=1000)
        opt = mujoco.MjvOption()
        view = mujoco.MjrRect(0, 0, int(width), int(height))
        rgb = np.empty((int(height), int(width), 3), dtype=np.uint8)
        with Mp4Writer(path, width, height, fps) as writer:
            for f in range(n_frames):
                bench.set_pose(d, plan.at([min(f * speedup / fps, plan.makespan_s)])[0])
                mujoco.mjv_updateScene(m, d, opt, None, cam, mujoco.mjtCatBit.mjCAT_ALL, scene)
                mujoco.mjr_render(view, scene, con)
                mujoco.mjr_readPixels(rgb, None, view, con)
                writer.write(np.flipud(rgb))
    finally:
        gl.free()
    return Path(path)
