#!/usr/bin/env python
"""Cost of every step of the pipeline against the number of robots, with the fitted
exponent (issue "Next-generation dense arrays").

Run from the repository root::

    .venv/bin/python benchmarks/bench_scale.py [--rafts 8 32 80 204 476] [--preset raft-6p2]
        [--seed 1] [--no-3d] [--no-mujoco] [--sim-s 0.5] [--md-out FILE] [--fig FILE]

For each raft layout ``raft:K`` (63 K robots), in its own process (so that its peak
resident memory is its own), after a warm-up plan on ``raft:2`` in that process (numba
kernels loaded): wall seconds of random targets + planning (greedy, search resolution),
post-processing (smooth, time, simplify, re-verify), the independent 2D check of the
delivered trajectory, the 3D validation (FCL) and the peak RSS. The exponent of each
step is the least-squares slope of log(seconds) on log(robots) over the sizes run
(target <= 1.1). Then the MuJoCo twin as ``rfp-twin simulate`` / ``render`` build it (tiles
above 2,000 robots): its build, ``--sim-s`` simulated seconds of the delivered trajectory
(wall seconds per simulated second) and one 1280x720 frame of the top camera (the renderer
``render`` picks; the mean of 10 frames after a first one). ``--fig`` draws seconds against
robots, log-log, one line per step. Build, simulation and rendering in more detail:
``bench_mujoco_scale.py``.
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np

from bench_common import command_line, machine_info, md_table, write_block

STEPS = ("plan", "postprocess", "check2d", "validate3d", "build", "simulate", "frame")


def mujoco_steps(rc, traj, sim_s: float, row: dict) -> None:
    """Build the twin as the CLI does, simulate ``sim_s`` s of ``traj`` and draw frames:
    adds build, simulate (wall s per simulated s), frame (s) and the tile count to ``row``."""
    import rfp_twin.twin.render  # noqa: F401  (first: picks MUJOCO_GL before mujoco)
    from rfp_twin.models.mjcf.tiled_twin import model_tiles
    from rfp_twin.twin.cli.run import build_with_progress
    from rfp_twin.twin.render import RenderSettings
    from rfp_twin.twin.render.run import make_renderer
    from rfp_twin.twin.sim import SimSettings, simulate

    t0 = time.perf_counter()
    twin = build_with_progress(rc.spec, rc.layout)
    row["build"] = time.perf_counter() - t0
    row["tiles"] = len(model_tiles(twin))
    report = simulate(twin, traj, settings=SimSettings(duration_s=sim_s))
    row["simulate"] = report.wall_s / report.sim_s
    angles = report.record.angles
    with make_renderer(twin, RenderSettings(width=1280, height=720, camera="top")) as fr:
        fr.render(angles[0])
        t0 = time.perf_counter()
        for j in range(10):
            fr.render(angles[(5 * j) % len(angles)], np.full(rc.layout.n_robots, j % 4))
        row["frame"] = (time.perf_counter() - t0) / 10


def one(preset: str, rafts: int, seed: int, with_3d: bool, with_mujoco: bool = True,
        sim_s: float = 0.5) -> dict:
    """Time the steps on ``raft:rafts`` in this process; returns a row dict."""
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
    from rfp_twin.validation.checker2d import check_trajectory

    warm = Reconfiguration.from_names(preset, "raft:2", options=PlanOptions())
    warm.run(seed=seed)
    rc = Reconfiguration.from_names(preset, f"raft:{rafts}", options=PlanOptions())
    row = {"robots": rc.layout.n_robots}
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    plan, _ = rc.plan(rc.random_targets(rng), rng)
    row["plan"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    traj, post, _ = rc.deliver(plan)
    row["postprocess"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    check = check_trajectory(traj, rc.spec, rc.layout, post.verify_buffer_mm)
    row["check2d"] = time.perf_counter() - t0
    row["collisions2d"] = len(check.collisions)
    row["efficiency"] = plan.metrics["efficiency"]
    if with_3d:
        from rfp_twin.models.geometry import load_geometry
        from rfp_twin.validation.mesh3d import validate_trajectory
        t0 = time.perf_counter()
        rep = validate_trajectory(traj, rc.spec, rc.layout, load_geometry(preset))
        row["validate3d"] = time.perf_counter() - t0
        row["collisions3d"] = len(rep.collisions)
    if with_mujoco:
        mujoco_steps(rc, traj, sim_s, row)
    row["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return row


def exponent(n: np.ndarray, s: np.ndarray) -> float:
    """Least-squares slope of log(s) on log(n)."""
    ok = s > 0
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(n[ok]), np.log(s[ok]), 1)[0])


def figure(n: np.ndarray, rows: list[dict], steps: list[str], path: str) -> None:
    """Seconds of each step against robots, log-log, with the fitted exponents."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=120)
    for s in steps:
        secs = np.array([r[s] for r in rows])
        ax.loglog(n, secs, "o-", label=f"{s} (exponent {exponent(n, secs):.2f})")
    ax.loglog(n, n / n[0] * 0.05, "k:", label="slope 1 (linear)")
    ax.set_xlabel("robots")
    ax.set_ylabel("wall seconds (simulate: per simulated s)")
    ax.set_title("rfp-twin: cost of each step against the array size")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rafts", type=int, nargs="+", default=[8, 32, 80, 204, 476])
    ap.add_argument("--preset", default="raft-6p2")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-3d", action="store_true")
    ap.add_argument("--no-mujoco", action="store_true")
    ap.add_argument("--sim-s", type=float, default=0.5, help="simulated seconds timed")
    ap.add_argument("--fig", help="PNG of seconds against robots (log-log)")
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--md-out")
    args = ap.parse_args()
    if args.one is not None:
        print(json.dumps(one(args.preset, args.one, args.seed, not args.no_3d,
                             not args.no_mujoco, args.sim_s)))
        return 0
    rows = []
    for k in args.rafts:
        cmd = [sys.executable, __file__, "--one", str(k), "--preset", args.preset,
               "--seed", str(args.seed), "--sim-s", str(args.sim_s)] \
            + (["--no-3d"] if args.no_3d else []) + (["--no-mujoco"] if args.no_mujoco else [])
        out = subprocess.run(cmd, capture_output=True, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(rows[-1], flush=True)
    n = np.array([r["robots"] for r in rows], dtype=float)
    steps = [s for s in STEPS if all(s in r for r in rows)]
    table = [[f"{int(r['robots']):,}"] + [f"{r[s]:.2f}" for s in steps]
             + [f"{r['peak_mb'] / 1024:.2f}", str(r["collisions2d"]),
                str(r.get("collisions3d", "-")), f"{r['efficiency']:.4f}"] for r in rows]
    table.append(["exponent"] + [f"{exponent(n, np.array([r[s] for r in rows])):.2f}"
                                 for s in steps] + ["", "", "", ""])
    if args.fig:
        figure(n, rows, steps, args.fig)
    head = ["robots"] + [f"{s} s" for s in steps] + ["peak GB", "2D collisions",
                                                      "3D collisions", "efficiency"]
    write_block("\n".join([f"Machine: {machine_info('numba')}", f"Command: `{command_line()}`",
                           "", md_table(head, table)]), args.md_out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
