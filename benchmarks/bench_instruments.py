#!/usr/bin/env python
"""The calibrated SDSS-V instruments against the design layout (issue #12).

Run from the repository root::

    .venv/bin/python benchmarks/bench_instruments.py [--part speed|checks|all]
        [--seeds 1-20] [--speed-seeds 1-5] [--buffers 1.5 2.0 2.5 3.0 3.5] [--no-3d]
        [--layouts sdss-v-fps sdss-v-apo sdss-v-lco sdss-v-curved] [--md-out FILE]

1. ``speed``: path generation (the planner kernel's tau_pg, and the whole planning call
   with its target checks) of greedy and Markov (greed 0.7 / phobia 0.6, SDSS-V's
   production MDP) at step 0.1 deg, 2.0 mm, on ``sdss-v-fps`` (the design layout),
   ``sdss-v-apo`` and ``sdss-v-lco`` (per-robot geometry, 3 mm fiducials, GFA segments),
   preset ``sdss-v-production``; median over ``--speed-seeds`` after a warm-up.
   Targets: instruments within 20 % of the design layout, greedy <= 0.1 s, Markov <= 0.3 s.
2. ``checks``: for each instrument and buffer, ``--seeds`` runs of the whole pipeline
   (``rfp-twin plan --preset sdss-v-production --layout L --buffer B --seed S``: greedy,
   deadlock search, post-processing, the independent 2D check with per-robot geometry)
   and, at 2.0 mm, the 3D validation (FCL meshes with each robot's own arm) of the
   firmware-ready trajectory: collisions (must be 0) and efficiency (Eq. 11) next to the
   design layout's on the same seeds.

Prints a markdown block to paste into benchmarks/RESULTS.md.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from bench_common import command_line, machine_info, md_table, write_block
from bench_fold_duration import seeds_arg
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration

LAYOUTS = ("sdss-v-fps", "sdss-v-apo", "sdss-v-lco")
PRESET = "sdss-v-production"
MARKOV = {"greed": 0.9, "phobia": 0.3}


def planner_seconds(layout: str, algorithm: str, seeds: list[int]) -> tuple[float, float, float]:
    """Median tau_pg, median whole planning call (s), mean efficiency over ``seeds``."""
    extra = MARKOV if algorithm == "markov" else {}
    rc = Reconfiguration.from_names(PRESET, layout, buffer_mm=2.0, options=PlanOptions(
        algorithm=algorithm, step_deg=0.1, resolve="none", raw=True, **extra))
    rng = np.random.default_rng(seeds[0])
    rc.plan(rc.random_targets(rng), rng)                   # warm-up: numba caches loaded
    tau, call, eff = [], [], []
    for s in seeds:
        rng = np.random.default_rng(s)
        targets = rc.random_targets(rng)
        t0 = time.perf_counter()
        plan, _ = rc.plan(targets, rng)
        call.append(time.perf_counter() - t0)
        tau.append(plan.metrics["tau_pg_s"])
        eff.append(plan.metrics["efficiency"])
    return statistics.median(tau), statistics.median(call), float(np.mean(eff))


def part_speed(seeds: list[int]) -> str:
    rows, base = [], {}
    for alg in ("greedy", "markov"):
        for lay in LAYOUTS:
            tau, call, eff = planner_seconds(lay, alg, seeds)
            if lay == "sdss-v-fps":
                base[alg] = tau
            rel = f"{tau / base[alg]:.2f}" if lay != "sdss-v-fps" else "1"
            rows.append([alg, lay, f"{tau:.3f}", rel, f"{call:.3f}", f"{eff:.4f}"])
            print(rows[-1], flush=True)
    head = ["algorithm", "layout", "tau_pg s (median)", "vs design", "planning call s",
            "efficiency (no resolution)"]
    return md_table(head, rows)


def part_checks(seeds: list[int], buffers: list[float], with_3d: bool,
                layouts: tuple[str, ...] = LAYOUTS) -> str:
    rows = []
    for buf in buffers:
        for lay in layouts:
            rc = Reconfiguration.from_names(PRESET, lay, buffer_mm=buf,
                                            options=PlanOptions(algorithm="greedy"))
            eff, bad2d, bad3d, n3d, wall, min3d, sec3d = [], 0, 0, 0, [], np.inf, []
            for s in seeds:
                t0 = time.perf_counter()
                out = rc.run(seed=s)
                wall.append(time.perf_counter() - t0)
                eff.append(out.plan.metrics["efficiency"])
                bad2d += len(out.check.collisions)
                if with_3d and buf == 2.0 and lay != "sdss-v-fps":
                    from rfp_twin.validation.mesh3d import validate_trajectory
                    from rfp_twin.models.geometry import load_geometry
                    t0 = time.perf_counter()
                    rep = validate_trajectory(out.trajectory, rc.spec, rc.layout,
                                              load_geometry(PRESET))
                    sec3d.append(time.perf_counter() - t0)
                    bad3d += len(rep.collisions)
                    min3d = min(min3d, rep.min_distance_mm)
                    n3d += 1
            rows.append([f"{buf:.1f}", lay, str(len(seeds)), f"{np.mean(eff):.4f}",
                         f"{np.min(eff):.4f}", str(bad2d),
                         f"{bad3d} ({n3d} runs, min {min3d:.2f} mm, "
                         f"{statistics.median(sec3d):.0f} s each)" if n3d else "-",
                         f"{statistics.median(wall):.1f}"])
            print(rows[-1], flush=True)
    head = ["buffer mm", "layout", "seeds", "efficiency mean", "min", "2D collisions",
            "3D collisions", "pipeline s (median)"]
    return md_table(head, rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--part", choices=("speed", "checks", "all"), default="all")
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("1-20"))
    ap.add_argument("--speed-seeds", type=seeds_arg, default=seeds_arg("1-5"))
    ap.add_argument("--buffers", type=float, nargs="+", default=[1.5, 2.0, 2.5, 3.0, 3.5])
    ap.add_argument("--no-3d", action="store_true")
    ap.add_argument("--layouts", nargs="+", default=list(LAYOUTS),
                    help="layouts of the checks part (sdss-v-curved too)")
    ap.add_argument("--md-out")
    args = ap.parse_args()
    parts = [f"Machine: {machine_info('numba')}", f"Command: `{command_line()}`", ""]
    if args.part in ("speed", "all"):
        parts += ["Path generation, 500 robots, step 0.1 deg, 2.0 mm:", "", part_speed(args.speed_seeds), ""]
    if args.part in ("checks", "all"):
        parts += ["Whole pipeline per buffer (greedy + search):", "",
                  part_checks(args.seeds, args.buffers, not args.no_3d,
                              tuple(args.layouts)), ""]
    write_block("\n".join(parts), args.md_out)


if __name__ == "__main__":
    main()
