#!/usr/bin/env python
"""Physics-twin benchmark: the 547-robot fold simulated in MuJoCo.

Run from the repository root::

    .venv/bin/python benchmarks/bench_sim.py [--seed S] [--buffer 2.5] [--step 0.1]
                                             [--timestep 0.004 ...] [--direction fold|unfold]
                                             [--n 547]

The plan comes from the pipeline (:func:`rfp_twin.twin.pipeline.plan_random` through
``bench_common.hex_fold``: preset ``sdss-v`` on a centred hex grid of ``--n`` positions at
``--buffer``, seeded random targets, greedy reverse planning at ``--step`` with target
replacement), turned into a Trajectory (``Trajectory.from_plan``) and, for ``fold``,
played backwards (targets -> folded state). The model (preset ``sdss-v``, its ``[geometry]``
table) is built with ``rfp_twin.models.mjcf.build_model`` and simulated with ``rfp_twin.twin.sim.simulate``
(contacts recorded every step, angles every 20 ms).

Prints: machine and command, plan time, model build time (MjSpec + compile), model
size, steps/s and the real-time factor (simulated seconds / wall seconds of the stepping
loop, and of build + simulation), contacts and tracking errors, for each timestep given.
Target of issue #3: real-time factor >= 2. Ends with a markdown block for RESULTS.md.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from bench_common import command_line, hex_fold, machine_info
from rfp_twin.models.mjcf import ModelOptions, build_model
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.twin.sim import SimSettings, simulate


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=547, help="grid positions (centred hex count)")
    ap.add_argument("--buffer", type=float, default=2.5)
    ap.add_argument("--step", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timestep", type=float, nargs="+", default=[0.004])
    ap.add_argument("--direction", choices=("fold", "unfold"), default="fold")
    args = ap.parse_args()

    print(f"machine: {machine_info('mujoco')}")
    print(f"command: {command_line()}")
    rc, plan, t_plan = hex_fold(args.n, args.buffer, args.seed, args.step)
    geom = rc.geom
    traj = Trajectory.from_plan(plan)
    if args.direction == "fold":
        traj = traj.reversed()
    print(f"plan: {plan.n_robots} robots, buffer {args.buffer} mm, step {args.step} deg, "
          f"complete={plan.complete}, {t_plan:.2f} s (incl. numba cache load); "
          f"trajectory {traj.duration:.2f} s ({args.direction})")

    rows = []
    for dt in args.timestep:
        t0 = time.perf_counter()
        twin = build_model(geom.spec, geom.layout, options=ModelOptions(timestep_s=dt))
        t_build = time.perf_counter() - t0
        m = twin.model
        report = simulate(twin, traj, settings=SimSettings(settle_s=0.5))
        steps_s = report.n_steps / report.wall_s
        rtf_total = report.sim_s / (report.wall_s + t_build)
        err = float(np.abs(report.max_error_deg).max())
        print(f"\ntimestep {dt * 1e3:g} ms: model {m.nbody} bodies, {m.ngeom} geoms, {m.nu} "
              f"actuators, {m.nmesh} mesh assets")
        print(f"  build (MjSpec + compile): {t_build:.3f} s")
        print(f"  simulated {report.sim_s:.2f} s in {report.wall_s:.2f} s: {steps_s:.0f} steps/s, "
              f"real-time factor {report.realtime_factor:.2f}x ({rtf_total:.2f}x with the build)")
        print(f"  robot-robot contact rows {report.robot_contacts}, fiducial {report.fiducial_contacts}, "
              f"MuJoCo warnings {report.warnings or 'none'}; max tracking error {err:.3f} deg; "
              f"all reached {bool(report.reached.all())}")
        rows.append((dt, t_build, report, steps_s, rtf_total, err))

    print("\n<!-- bench-sim:begin -->")
    print(f"- machine: {machine_info('mujoco')}")
    print(f"- command: `{command_line()}`")
    print(f"- plan: {plan.n_robots} robots, hex:{args.n} at {args.buffer} mm, "
          f"rfp_twin.twin.pipeline.plan_random seed {args.seed}, step {args.step} deg, complete={plan.complete}; {args.direction} "
          f"trajectory {traj.duration:.2f} s")
    print()
    print("| timestep ms | build s | simulated s | wall s | steps/s | real-time x | "
          "x incl. build | contacts | max track err deg |")
    print("|---|---|---|---|---|---|---|---|---|")
    for dt, t_build, r, steps_s, rtf_total, err in rows:
        print(f"| {dt * 1e3:g} | {t_build:.2f} | {r.sim_s:.2f} | {r.wall_s:.2f} | {steps_s:.0f} | "
              f"{r.realtime_factor:.2f} | {rtf_total:.2f} | {len(r.contacts)} | {err:.3f} |")
    print("<!-- bench-sim:end -->")
    return 0


if __name__ == "__main__":
    sys.exit(main())
