#!/usr/bin/env python
"""Offscreen rendering benchmark: 1280x720 frames of the 547-robot fold on the CPU.

Run from the repository root::

    .venv/bin/python benchmarks/bench_render.py [--n 547] [--frames 60]
        [--width 1280 --height 720] [--cameras top oblique] [--no-video] [--no-full]
        [--frames-dir benchmarks/frames] [--append FILE]

The fold is made as ``benchmarks/bench_sim.py`` makes it (``bench_common.hex_fold``:
:func:`rfp_twin.twin.pipeline.plan_random` on a hex grid of ``--n`` positions at ``--buffer``,
greedy reverse plan, seed 1, ``Trajectory.from_plan(plan).reversed()``: targets -> fold) and simulated once (``rfp_twin.twin.sim.simulate``, angles every
20 ms). For each camera, ``--frames`` consecutive frames around mid-fold (30 frames/s of
video, speed-up 1) are drawn with :class:`rfp_twin.twin.render.FrameRenderer` and the lean
settings; the figure is frames per wall second of drawing (scene update, GL render,
read-back), and, because the 2 cores are shared with other jobs, also per CPU second of
this process (all its threads: llvmpipe rasterises on worker threads). ``--no-full``
skips the 3-frame comparison with MuJoCo's default render settings. The video step
renders the whole fold with the top camera at speed-up 2 into an MP4 (encoding
included) and counts its frames back. Also times a .rrd recording of the same run.

Writes ``top.png`` and ``oblique.png`` (640x360, mid-fold) to ``--frames-dir``.
Target of issue #3: 1280x720 at >= 25 frames/s. Ends with a markdown block to paste into
benchmarks/RESULTS.md (a table of current figures kept by hand); ``--append FILE`` only
adds a line saying to paste it into FILE: nothing is written.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import rfp_twin.twin.render as render  # first: picks MUJOCO_GL before mujoco is imported

import imageio.v2 as iio2
import numpy as np

from bench_common import ROOT, command_line, hex_fold, load_average, machine_info, paste_note
from rfp_twin.models.mjcf import build_model
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.record import record_run
from rfp_twin.twin.render import FrameRenderer, RenderSettings, frame_timeline, render_run, save_png
from rfp_twin.twin.sim import SimSettings, simulate


def time_frames(fr: FrameRenderer, angles: np.ndarray, states: np.ndarray) -> tuple[float, float]:
    """(wall s, CPU s) per frame over the given frames (after 2 warm-up frames)."""
    out = np.empty((fr.settings.height, fr.settings.width, 3), dtype=np.uint8)
    for j in range(min(2, len(angles))):
        fr.render(angles[j], states[j], out=out)
    w0, c0 = time.perf_counter(), time.process_time()
    for j in range(len(angles)):
        fr.render(angles[j], states[j], out=out)
    n = len(angles)
    return (time.perf_counter() - w0) / n, (time.process_time() - c0) / n


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=547, help="grid positions (centred hex count)")
    ap.add_argument("--buffer", type=float, default=2.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--frames", type=int, default=60, help="frames timed per camera")
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--cameras", nargs="+", default=["top", "oblique"])
    ap.add_argument("--no-video", action="store_true", help="skip the whole-fold MP4")
    ap.add_argument("--no-full", action="store_true", help="skip the default-settings comparison")
    ap.add_argument("--frames-dir", type=Path, default=ROOT / "benchmarks" / "frames")
    ap.add_argument("--append", type=Path, default=None, metavar="FILE",
                    help="say to paste the markdown block into FILE (nothing is written: "
                         "benchmarks/RESULTS.md is a table kept by hand)")
    args = ap.parse_args()

    print(f"machine: {machine_info('mujoco')}")
    print(f"command: {command_line()}")
    print(f"OpenGL: MUJOCO_GL={render.require_backend()}, {render.gl_renderer_info()}")
    rc, plan, t_plan = hex_fold(args.n, args.buffer, args.seed)
    geom = rc.geom
    traj = Trajectory.from_plan(plan).reversed()
    print(f"plan: {plan.n_robots} robots, complete={plan.complete}, {t_plan:.1f} s; "
          f"fold trajectory {traj.duration:.2f} s")
    twin = build_model(geom.spec, geom.layout)
    t0 = time.perf_counter()
    report = simulate(twin, traj, settings=SimSettings(settle_s=0.5))
    t_sim = time.perf_counter() - t0
    print(f"simulation: {report.sim_s:.2f} s simulated in {t_sim:.2f} s, "
          f"contacts {len(report.contacts)}")
    timeline = frame_timeline(twin, report, RenderSettings(fps=30.0))
    mid = timeline.n_frames // 2
    lo = max(0, mid - args.frames // 2)
    sel = slice(lo, min(timeline.n_frames, lo + args.frames))
    angles, states = timeline.angles[sel], timeline.states[sel]
    print(f"timed frames: {len(angles)} consecutive frames at 30 frames/s around t = "
          f"{timeline.times[mid]:.2f} s (robot-frames per state: "
          f"{dict(zip(render.STATE_NAMES, np.bincount(states.ravel(), minlength=4).tolist()))})")

    rows, sections = [], []
    for cam in args.cameras:
        s = RenderSettings(width=args.width, height=args.height, camera=cam, lean=True)
        t0 = time.perf_counter()
        with FrameRenderer(twin, s) as fr:
            t_setup = time.perf_counter() - t0
            wall, cpu = time_frames(fr, angles, states)
            nsc = fr.scene.ngeom
            sections.append(fr.twin.geometry.params.circle_sections)
        full = None
        if not args.no_full:
            with FrameRenderer(twin, RenderSettings(width=args.width, height=args.height,
                                                    camera=cam, lean=False)) as fr:
                full = time_frames(fr, angles[:3], states[:3])
        rows.append((cam, t_setup, wall, cpu, nsc, full))
        extra = (f"; MuJoCo defaults: {full[0] * 1e3:.0f} ms wall ({1 / full[0]:.1f} frames/s), "
                 f"{full[1] * 1e3:.0f} ms CPU") if full else ""
        print(f"{cam} {args.width}x{args.height} lean: {1 / wall:.1f} frames/s wall "
              f"({wall * 1e3:.1f} ms/frame), {cpu * 1e3:.1f} ms CPU/frame ({1 / cpu:.1f} frames/s "
              f"per CPU second); {nsc} scene geoms, {sections[-1]} facets per circle; "
              f"setup {t_setup:.2f} s{extra}; load {load_average()}")

    # frames to look at
    args.frames_dir.mkdir(parents=True, exist_ok=True)
    for cam in ("top", "oblique"):
        img = render.render_frame(twin, timeline.angles[mid],
                                  RenderSettings(width=640, height=360, camera=cam),
                                  timeline.states[mid])
        print(f"wrote {save_png(img, args.frames_dir / f'{cam}.png')} (std {img.std():.1f})")

    video = None
    if not args.no_video:
        s = RenderSettings(width=args.width, height=args.height, camera="top", fps=30.0, speedup=2.0)
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "fold.mp4"
            r = render_run(twin, traj, out, s, sim_report=report)
            reader = iio2.get_reader(out)
            counted = reader.count_frames()
            reader.close()
            video = (r, counted, out.stat().st_size)
        print(f"video: {r.frames} frames ({counted} decoded), {r.video_s:.1f} s of video for "
              f"{r.sim_s:.2f} s simulated at x{s.speedup:g}; drawing {r.fps_rendered:.1f} frames/s, "
              f"with H.264 encoding {r.fps_achieved:.1f} frames/s; {video[2] / 1e6:.1f} MB")

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        rrd = record_run(twin, traj, Path(tmp) / "fold.rrd", sim_report=report)
        t_rec = time.perf_counter() - t0
        rrd_mb = rrd.stat().st_size / 1e6
    print(f"recording: {t_rec:.2f} s, {rrd_mb:.1f} MB .rrd ({report.record.times.size} samples)")

    lines = ["", f"## Offscreen rendering: the {plan.n_robots}-robot fold at "
             f"{args.width}x{args.height} (`benchmarks/bench_render.py`)", "",
             f"- machine: {machine_info('mujoco')}",
             f"- command: `{command_line()}`",
             f"- OpenGL: `MUJOCO_GL={render.require_backend()}`, {render.gl_renderer_info()} "
             "(software rasteriser, no GPU)",
             f"- scene: `rfp_twin.twin.pipeline.plan_random` on hex:{args.n} at {args.buffer} mm, seed "
             f"{args.seed}, fold "
             f"{traj.duration:.2f} s simulated; {len(angles)} consecutive frames around mid-fold, "
             "robots coloured by state; lean settings (no MSAA, shadows, reflections, skybox, "
             "haze, fog or post-processing; fiber sites hidden; round parts re-meshed at "
             f"{'/'.join(str(x) for x in sections)} facets per circle for "
             f"{'/'.join(args.cameras)} instead of 32)", "",
             "| camera | frames/s (wall) | ms/frame (wall) | CPU ms/frame | frames/s per CPU s | "
             "MuJoCo defaults ms/frame (wall) |",
             "|---|---|---|---|---|---|"]
    for cam, _, wall, cpu, _, full in rows:
        lines.append(f"| {cam} | **{1 / wall:.1f}** | {wall * 1e3:.1f} | {cpu * 1e3:.1f} | "
                     f"{1 / cpu:.1f} | {f'{full[0] * 1e3:.0f}' if full else 'n/a'} |")
    lines.append("")
    if video:
        r, counted, size = video
        lines.append(f"- whole fold to MP4 (top camera, 30 frames/s, speed-up 2): {r.frames} frames "
                     f"({counted} decoded back), drawing {r.fps_rendered:.1f} frames/s, "
                     f"{r.fps_achieved:.1f} frames/s with H.264 encoding (libx264 veryfast, CRF 23, "
                     f"in its own ffmpeg process), {size / 1e6:.1f} MB")
    lines.append(f"- .rrd recording of the same run: {t_rec:.2f} s, {rrd_mb:.1f} MB")
    lines.append(f"- frames: `benchmarks/frames/top.png`, `benchmarks/frames/oblique.png` "
                 "(640x360, mid-fold)")
    lines.append(f"- load average after the run: {load_average()} on {os.cpu_count()} cores (shared)")
    block = "\n".join(lines) + "\n"
    print("\n<!-- bench-render:begin -->" + block + "<!-- bench-render:end -->")
    paste_note(args.append)
    return 0


if __name__ == "__main__":
    sys.exit(main())
