#!/usr/bin/env python
"""Large-array rendering benchmark: :class:`rfp_twin.twin.render.merged.MergedFrameRenderer`
at 1280x720 on the CPU for growing raft arrays (issue #14: >= 10 frames/s at 12,852 robots).

Run from the repository root::

    .venv/bin/python benchmarks/bench_render_scale.py [--layouts raft:8 raft:32 raft:204]
        [--huge] [--preset raft-6p2] [--frames 30] [--cameras top] [--width 1280 --height 720]
        [--compare [--compare-max 2100]]

``--huge`` adds ``raft:476`` (29,988 robots). Each layout runs in its own process (so that
its peak RSS is its own): renderer construction (render-only model compile, GL context,
background) in seconds, then ``--frames`` frames (after 2 warm-up frames) with every robot's
angles moving (a random walk of a few degrees a frame, seed 1) and a tenth of the robots
changing state each frame; frames per wall second and per CPU second of the process
(llvmpipe rasterises on worker threads). ``--compare`` also times
:class:`rfp_twin.twin.render.FrameRenderer` (which needs the compiled grid model) on the
same frames, for layouts of at most ``--compare-max`` robots (default 2,100: at 12,852 the
grid model alone takes ~25 s to compile). Prints a markdown table (nothing is
written: benchmarks/RESULTS.md is kept by hand).
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import rfp_twin.twin.render as render  # first: picks MUJOCO_GL before mujoco is imported

import numpy as np

from bench_common import ROOT, command_line, load_average, machine_info
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.render import FrameRenderer, RenderSettings
from rfp_twin.twin.render.merged import MergedFrameRenderer

#: Largest array timed with FrameRenderer by ``--compare``.
COMPARE_MAX_ROBOTS = 2100


def frames(n: int, count: int, spec, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(count, n, 2) deg moving angles and (count, n) int8 changing states."""
    rng = np.random.default_rng(seed)
    a0 = np.column_stack([rng.uniform(0, 360, n), rng.uniform(0, 180, n)])
    steps = rng.normal(0.0, 3.0, (count, n, 2)).cumsum(axis=0)
    angles = a0[None] + steps
    angles[..., 1] = np.clip(angles[..., 1], 0.0, 180.0)
    states = np.empty((count, n), np.int8)
    s = rng.integers(0, 4, n).astype(np.int8)
    for j in range(count):
        flip = rng.random(n) < 0.1
        s[flip] = rng.integers(0, 4, int(flip.sum()))
        states[j] = s
    return angles, states


def time_renderer(r, angles, states) -> tuple[float, float]:
    """(frames per wall s, frames per CPU s) over the frames after 2 warm-up frames."""
    out = np.empty((r.settings.height, r.settings.width, 3), np.uint8)
    for j in range(2):
        r.render(angles[j], states[j], out=out)
    w0, c0 = time.perf_counter(), time.process_time()
    for j in range(2, len(angles)):
        r.render(angles[j], states[j], out=out)
    k = len(angles) - 2
    return k / (time.perf_counter() - w0), k / (time.process_time() - c0)


def one(args) -> dict:
    """Measure one layout in this process; returns the row as a dict."""
    spec = load_spec(args.preset)
    layout = layout_by_name(args.one, spec.pitch_mm)
    angles, states = frames(layout.n_robots, args.frames + 2, spec)
    row = {"layout": args.one, "robots": layout.n_robots, "camera": args.camera}
    s = RenderSettings(width=args.width, height=args.height, camera=args.camera)
    t0 = time.perf_counter()
    with MergedFrameRenderer(spec, layout, None, s) as mr:
        row["build_s"] = time.perf_counter() - t0
        row["caps"] = mr.caps
        row["fps"], row["fps_cpu"] = time_renderer(mr, angles, states)
    if args.compare and layout.n_robots <= args.compare_max:
        from rfp_twin.models.mjcf import build_model
        t0 = time.perf_counter()
        twin = build_model(spec, layout)
        with FrameRenderer(twin, s) as fr:
            row["fr_build_s"] = time.perf_counter() - t0
            row["fr_fps"], _ = time_renderer(fr, angles, states)
    row["rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    row["load"] = load_average()
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--layouts", nargs="+", default=["raft:8", "raft:32", "raft:204"])
    ap.add_argument("--huge", action="store_true", help="add raft:476 (29,988 robots)")
    ap.add_argument("--preset", default="raft-6p2")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--cameras", nargs="+", default=["top"])
    ap.add_argument("--width", type=int, default=1280)
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--compare", action="store_true",
                    help=f"also time FrameRenderer (up to {COMPARE_MAX_ROBOTS} robots)")
    ap.add_argument("--compare-max", type=int, default=COMPARE_MAX_ROBOTS,
                    help="largest array --compare times FrameRenderer on")
    ap.add_argument("--one", help=argparse.SUPPRESS)
    ap.add_argument("--camera", default="top", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print(json.dumps(one(args)))
        return 0
    print(f"machine: {machine_info('mujoco')}")
    print(f"command: {command_line()}")
    print(f"OpenGL: MUJOCO_GL={render.require_backend()}, {render.gl_renderer_info()}")
    layouts = args.layouts + (["raft:476"] if args.huge else [])
    rows = []
    for lay in layouts:
        for cam in args.cameras:
            cmd = [sys.executable, __file__, "--one", lay, "--camera", cam, "--preset", args.preset,
                   "--frames", str(args.frames), "--width", str(args.width),
                   "--height", str(args.height), "--compare-max", str(args.compare_max)] \
                + (["--compare"] if args.compare else [])
            res = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
            if res.returncode:
                print(f"{lay} {cam}: failed\n{res.stderr[-2000:]}")
                continue
            row = json.loads(res.stdout.strip().splitlines()[-1])
            rows.append(row)
            print(f"{lay} {cam}: {row}", flush=True)
    print()
    print(f"MergedFrameRenderer, preset {args.preset}, {args.width}x{args.height}, "
          f"{args.frames} frames with moving angles and changing states")
    print()
    head = ("| layout | robots | camera | link shapes | construction s | frames/s (wall) | "
            "frames/s (CPU s) | peak RSS MB | FrameRenderer build s / frames/s | load 1/5/15 |")
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for r in rows:
        fr = (f"{r['fr_build_s']:.1f} / {r['fr_fps']:.1f}" if "fr_fps" in r else "-")
        print(f"| {r['layout']} | {r['robots']:,} | {r['camera']} | "
              f"{'top caps' if r['caps'] else 'lean meshes'} | {r['build_s']:.2f} | "
              f"{r['fps']:.1f} | {r['fps_cpu']:.1f} | {r['rss_mb']:.0f} | {fr} | {r['load']} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
