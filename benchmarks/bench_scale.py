#!/usr/bin/env python
"""Cost of the pipeline's 2D steps and the 3D validation against the number of robots,
with the fitted exponent (issue "Next-generation dense arrays").

Run from the repository root::

    .venv/bin/python benchmarks/bench_scale.py [--rafts 8 32 80 204] [--preset raft-6p2]
        [--seed 1] [--no-3d] [--md-out FILE]

For each raft layout ``raft:K`` (63 K robots), in its own process (so that its peak
resident memory is its own), after a warm-up plan on ``raft:2`` in that process (numba
kernels loaded): wall seconds of random targets + planning (greedy, search resolution),
post-processing (smooth, time, simplify, re-verify), the independent 2D check of the
delivered trajectory, the 3D validation (FCL) and the peak RSS. The exponent of each
step is the least-squares slope of log(seconds) on log(robots) over the sizes run
(target <= 1.1). MuJoCo build, simulation and rendering at scale:
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

STEPS = ("plan", "postprocess", "check2d", "validate3d")


def one(preset: str, rafts: int, seed: int, with_3d: bool) -> dict:
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
    row["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return row


def exponent(n: np.ndarray, s: np.ndarray) -> float:
    """Least-squares slope of log(s) on log(n)."""
    ok = s > 0
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(n[ok]), np.log(s[ok]), 1)[0])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rafts", type=int, nargs="+", default=[8, 32, 80, 204])
    ap.add_argument("--preset", default="raft-6p2")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-3d", action="store_true")
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--md-out")
    args = ap.parse_args()
    if args.one is not None:
        print(json.dumps(one(args.preset, args.one, args.seed, not args.no_3d)))
        return 0
    rows = []
    for k in args.rafts:
        cmd = [sys.executable, __file__, "--one", str(k), "--preset", args.preset,
               "--seed", str(args.seed)] + (["--no-3d"] if args.no_3d else [])
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
    head = ["robots"] + [f"{s} s" for s in steps] + ["peak GB", "2D collisions",
                                                      "3D collisions", "efficiency"]
    write_block("\n".join([f"Machine: {machine_info('numba')}", f"Command: `{command_line()}`",
                           "", md_table(head, table)]), args.md_out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
