#!/usr/bin/env python
"""MuJoCo twin at scale: build, simulation, rendering and recording of dense raft arrays.

Run from the repository root::

    .venv/bin/python benchmarks/bench_mujoco_scale.py [--huge] [--sdss] [--no-record]
        [--sim-s 1.0] [--timestep 0.004] [--frames 5] [--only raft:8 ...]
        [--tile-robots N] [--repeat K]

Each array runs in its own process (so that its peak resident memory is its own):
preset ``raft-6p2`` on ``raft:8`` (504 robots), ``raft:32`` (2,016) and ``raft:204``
(12,852); ``--huge`` adds ``raft:476`` (29,988), ``--sdss`` adds ``hex:12871`` with
``sdss-v``. For each:

- build: the twin as ``rfp-twin simulate`` builds it (``build_with_progress``: one model up
  to 2,000 robots, tiles of <= 512 robots above; ``--one-model`` forces one model), wall
  seconds, and the arena MuJoCo reserves (address space, all tiles);
- simulation: a trajectory where every robot leaves its fold by 20 deg on both axes and
  comes back in ``--sim-s`` s, simulated with ``rfp_twin.twin.sim.simulate`` (settle 0.2 s):
  physics steps per wall second and the real-time factor (simulated s / wall s of the
  stepping loop);
- rendering: the renderer ``rfp-twin render`` picks (``make_renderer``: FrameRenderer, or
  MergedFrameRenderer for large arrays) at 1280x720, top camera, lean settings: set-up
  seconds and frames per wall second over ``--frames`` frames;
- recording: ``rfp_twin.twin.record.record_run`` of that simulation: wall seconds and
  file size (``--no-record`` skips it);
- peak RSS of the process after each step (``resource.getrusage``, MB).

Targets of the issue "Next-generation dense arrays" at 12,852 robots: build <= 10 s,
simulation >= 0.5x real time, 1280x720 render >= 10 frames/s, a recording, peak <= 2 GB.
Ends with a markdown table to paste into benchmarks/RESULTS.md.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_common import command_line, machine_info

RUNS = [("raft-6p2", "raft:8"), ("raft-6p2", "raft:32"), ("raft-6p2", "raft:204")]
HUGE = [("raft-6p2", "raft:476")]
SDSS = [("sdss-v", "hex:12871")]


def peak_mb() -> float:
    """Peak resident memory of this process so far, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def one(preset: str, name: str, args) -> dict:
    """Every measurement of one array (run in a child process)."""
    import rfp_twin.twin.render  # noqa: F401  (first: picks MUJOCO_GL before mujoco)
    import numpy as np

    from rfp_twin.models.errors import SpecError
    from rfp_twin.models.layout import layout_by_name
    from rfp_twin.models.mjcf import ModelOptions
    from rfp_twin.models.mjcf.tiled_twin import TiledTwin, model_tiles
    from rfp_twin.models.robot import load_spec
    from rfp_twin.models.trajectory import Trajectory
    from rfp_twin.twin.cli.run import build_with_progress
    from rfp_twin.twin.record import record_run
    from rfp_twin.twin.render import RenderSettings, make_renderer
    from rfp_twin.twin.sim import SimSettings, simulate

    spec = load_spec(preset)
    lay = layout_by_name(name, spec.pitch_mm)
    out: dict = {"preset": preset, "layout": name, "robots": lay.n_robots}
    t0 = time.perf_counter()
    try:
        twin = build_with_progress(spec, lay, ModelOptions(timestep_s=args.timestep),
                                   0 if args.one_model else args.tile_robots)
    except SpecError as exc:
        out.update(build_s=time.perf_counter() - t0, refused=str(exc), peak_build_mb=peak_mb())
        return out
    out["build_s"] = time.perf_counter() - t0
    models = [t.twin.model for t in model_tiles(twin)]
    out["tiles"] = len(twin.tiles) if isinstance(twin, TiledTwin) else 0
    out["arena_mb"] = sum(m.narena for m in models) / 2**20
    out["peak_build_mb"] = peak_mb()

    n, (fa, fb) = lay.n_robots, spec.fold_deg
    times = [[0.0, args.sim_s / 2.0, args.sim_s]] * n
    traj = Trajectory.from_breakpoints(lay.robot_ids, times, [[fa, fa + 20.0, fa]] * n,
                                       times, [[fb, fb - 20.0, fb]] * n)
    report = simulate(twin, traj, settings=SimSettings(settle_s=0.2))
    out.update(steps_s=report.n_steps / report.wall_s, rtf=report.realtime_factor,
               contacts=len(report.contacts), warnings=report.warnings,
               peak_sim_mb=peak_mb())

    t = time.perf_counter()
    with make_renderer(twin, RenderSettings(width=1280, height=720, camera="top")) as fr:
        out["render_setup_s"] = time.perf_counter() - t
        angles = np.asarray(report.record.angles)
        frame = np.empty((720, 1280, 3), dtype=np.uint8)
        fr.render(angles[0], out=frame)
        k = max(1, args.frames)
        t = time.perf_counter()
        for j in range(k):
            fr.render(angles[(j * 3) % len(angles)], np.full(n, j % 4), out=frame)
        out["render_fps"] = k / (time.perf_counter() - t)
        out["renderer"] = type(fr).__name__
    out["peak_render_mb"] = peak_mb()

    if args.record:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "run.rrd"
            t = time.perf_counter()
            record_run(twin, None, path, sim_report=report)
            out["record_s"] = time.perf_counter() - t
            out["record_mb"] = path.stat().st_size / 1e6
        out["peak_record_mb"] = peak_mb()
    return out


def cell(row: dict, key: str, fmt: str = "{:.2f}") -> str:
    return fmt.format(row[key]) if key in row else "-"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--huge", action="store_true", help="add raft:476 (29,988 robots)")
    ap.add_argument("--sdss", action="store_true", help="add hex:12871 with sdss-v")
    ap.add_argument("--no-record", dest="record", action="store_false")
    ap.add_argument("--sim-s", type=float, default=1.0, help="trajectory duration, s")
    ap.add_argument("--timestep", type=float, default=0.004, help="MuJoCo timestep, s")
    ap.add_argument("--frames", type=int, default=5, help="frames timed per array")
    ap.add_argument("--only", nargs="*", help="layouts to run (names as in the table)")
    ap.add_argument("--one-model", action="store_true",
                    help="one MuJoCo model of the whole array (no tiles)")
    ap.add_argument("--tile-robots", type=int, default=None,
                    help="robots a tile owns at most (default: the CLI's, TILE_ROBOTS)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs of each array (fresh processes); the table shows each")
    ap.add_argument("--one", nargs=2, metavar=("PRESET", "LAYOUT"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        print("RESULT " + json.dumps(one(*args.one, args)))
        return 0

    runs = RUNS + (HUGE if args.huge else []) + (SDSS if args.sdss else [])
    if args.only:
        runs = [r for r in runs if r[1] in args.only]
    print(f"machine: {machine_info('mujoco', 'rerun')}")
    print(f"command: {command_line()}")
    rows = []
    for preset, name in [r for r in runs for _ in range(max(1, args.repeat))]:
        cmd = [sys.executable, __file__, "--one", preset, name, "--sim-s", str(args.sim_s),
               "--timestep", str(args.timestep), "--frames", str(args.frames)]
        if not args.record:
            cmd.append("--no-record")
        if args.one_model:
            cmd.append("--one-model")
        if args.tile_robots is not None:
            cmd += ["--tile-robots", str(args.tile_robots)]
        t = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
        lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
        if r.returncode != 0 or not lines:
            tail = (r.stderr or r.stdout).strip().splitlines()[-3:]
            print(f"{preset} {name}: failed after {time.perf_counter() - t:.0f} s: {' | '.join(tail)}")
            continue
        row = json.loads(lines[-1][len("RESULT "):])
        rows.append(row)
        print(f"{preset} {name}: {json.dumps(row)}", flush=True)

    print("\n<!-- bench-mujoco-scale:begin -->")
    print(f"- machine: {machine_info('mujoco', 'rerun')}")
    print(f"- command: `{command_line()}`; timestep {args.timestep * 1e3:g} ms, every robot "
          f"moves 20 deg out and back in {args.sim_s:g} s")
    print()
    print("| preset | layout | robots | build s (tiles) | arena MB (reserved) | "
          "peak MB build / sim / render / record | steps/s | real-time x | render fps 1280x720 "
          "(renderer) | render setup s | record s (MB) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "refused" in r:
            print(f"| {r['preset']} | {r['layout']} | {r['robots']} | refused in "
                  f"{r['build_s']:.2f} s: {r['refused'][:90]}... | - | {r['peak_build_mb']:.0f} "
                  "| - | - | - | - | - |")
            continue
        peaks = " / ".join(cell(r, k, "{:.0f}") for k in
                           ("peak_build_mb", "peak_sim_mb", "peak_render_mb", "peak_record_mb"))
        rec = f"{r['record_s']:.1f} ({r['record_mb']:.0f})" if "record_s" in r else "-"
        tiles = f"{r['tiles']} tiles" if r["tiles"] else "one model"
        print(f"| {r['preset']} | {r['layout']} | {r['robots']} | {r['build_s']:.1f} "
              f"({tiles}) | {r['arena_mb']:.0f} | {peaks} | "
              f"{r['steps_s']:.0f} | {r['rtf']:.2f} | {r['render_fps']:.1f} "
              f"({r['renderer']}) | {r['render_setup_s']:.1f} | {rec} |")
    print("<!-- bench-mujoco-scale:end -->")
    return 0


if __name__ == "__main__":
    sys.exit(main())
