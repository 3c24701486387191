#!/usr/bin/env python
"""Fiber assignment: exact solvers (CP-SAT vs HiGHS) and the heuristic at scale (issue #31).

Run from the repository root::

    .venv/bin/python benchmarks/bench_assign.py [--only exact|large] [--seeds 1 2 3]
        [--densities 50 100 200 300 1000] [--levels 1 3] [--time-limit 10]
        [--large-layout raft:204] [--large-density 20] [--md-out FILE]

``exact``: the calibrated APO instrument (500 robots, ``sdss-v-production``, 2.0 mm, the
stepwise planners' margin at 0.1 deg), uniform mock catalogues of BOSS targets at each
density (targets/deg^2, APO plate scale 217.7358 mm/deg over the 1.5 deg field) with
priorities 1..LEVELS, assigned with ``--solver cpsat`` and ``--solver highs`` (2 workers /
1 thread, the greedy solution as a start). Per case: targets, assigned robots, objective,
proven bound, gap, status and wall seconds of the whole :func:`assign` call (after one
warm-up call, so numba kernels are loaded, not compiled).

``large``: the heuristic (``--solver greedy``) on ``raft-6p2`` over ``--large-layout`` with
``--large-density`` targets per robot patrol area: objective, its bound (each robot's
best candidate, capped by the reachable targets), gap, seconds and peak RSS.

Prints markdown tables to paste into benchmarks/RESULTS.md by hand.
"""
from __future__ import annotations

import argparse
import resource
import sys
import time

import numpy as np

from bench_common import machine_info

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.catalogue import TELESCOPES, Disc, density_per_mm2, mock_catalogue
from rfp_twin.models.layout import layout_by_name
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.assignment import AssignSettings, assign
from rfp_twin.planners.stepwise import array_max_displacement


def apo_geometry() -> ArrayGeometry:
    spec = load_spec("sdss-v-production")
    return ArrayGeometry(spec, layout_by_name("sdss-v-apo", spec.pitch_mm, ()), 2.0)


def field_catalogue(seed: int, density: float, levels: int, telescope: str = "apo"):
    tel = TELESCOPES[telescope]
    rng = np.random.default_rng(seed)
    dens = density_per_mm2(density, "deg2", plate_scale_mm_per_deg=tel.plate_scale_mm_per_deg)
    return mock_catalogue(rng, Disc((0.0, 0.0), tel.field_radius_mm), dens,
                          priority_levels=levels, fiber="boss")


def run_exact(args) -> list[str]:
    geom = apo_geometry()
    margin = array_max_displacement(geom, 0.1)
    assign(geom, field_catalogue(0, 100, 1), AssignSettings(solver="greedy", margin_mm=margin))
    lines = ["| density /deg^2 | levels | seed | targets | solver | assigned | objective | "
             "bound | gap % | status | components solved (largest) | s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for density in args.densities:
        for levels in args.levels:
            for seed in args.seeds:
                cat = field_catalogue(seed, density, levels)
                for solver in ("cpsat", "highs"):
                    t0 = time.perf_counter()
                    a = assign(geom, cat, AssignSettings(solver=solver, margin_mm=margin,
                                                         time_limit_s=args.time_limit))
                    dt = time.perf_counter() - t0
                    st = a.stats
                    lines.append(
                        f"| {density:g} | {levels} | {seed} | {cat.n_targets} | {solver} | "
                        f"{a.n_assigned} | {a.objective:g} | {a.bound:g} | {100 * a.gap:.2f} | "
                        f"{a.status} | {st.get('n_components_solved', 0)} "
                        f"({st.get('largest_component_robots', 0)}) | {dt:.2f} |")
                    print(lines[-1], file=sys.stderr)
    return lines


def run_large(args) -> list[str]:
    spec = load_spec("raft-6p2")
    geom = ArrayGeometry(spec, layout_by_name(args.large_layout, spec.pitch_mm, ()),
                         spec.buffer_mm)
    margin = array_max_displacement(geom, 0.1)
    lo, hi = spec.patrol_annulus_mm
    patrol = float(np.pi * (hi * hi - lo * lo))
    centre = geom.base_xy.mean(axis=0)
    radius = float(np.hypot(*(geom.base_xy - centre).T).max() + spec.reach_mm)
    lines = ["| layout | robots | targets/patrol | levels | seed | targets | assigned | "
             "objective | bound | gap % | s (assign) | peak RSS GB |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    warm = True
    for levels in args.levels:
        for seed in args.seeds:
            rng = np.random.default_rng(seed)
            cat = mock_catalogue(rng, Disc((float(centre[0]), float(centre[1])), radius),
                                 density_per_mm2(args.large_density, "patrol",
                                                 patrol_area_mm2=patrol),
                                 priority_levels=levels, fiber="any")
            if warm:
                assign(geom, cat.subset(np.arange(min(1000, cat.n_targets))),
                       AssignSettings(solver="greedy", margin_mm=margin))
                warm = False
            t0 = time.perf_counter()
            a = assign(geom, cat, AssignSettings(solver="greedy", margin_mm=margin))
            dt = time.perf_counter() - t0
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
            lines.append(f"| {args.large_layout} | {geom.n_robots} | {args.large_density:g} | "
                         f"{levels} | {seed} | {cat.n_targets} | {a.n_assigned} | "
                         f"{a.objective:g} | {a.bound:g} | {100 * a.gap:.3f} | {dt:.2f} | "
                         f"{rss:.2f} |")
            print(lines[-1], file=sys.stderr)
    return lines


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--only", choices=("exact", "large"), default=None)
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--densities", type=float, nargs="+", default=[50, 100, 200, 300, 1000])
    p.add_argument("--levels", type=int, nargs="+", default=[1, 3])
    p.add_argument("--time-limit", type=float, default=10.0)
    p.add_argument("--large-layout", default="raft:204")
    p.add_argument("--large-density", type=float, default=20.0)
    p.add_argument("--md-out", default=None)
    args = p.parse_args()
    out = [f"`{' '.join(sys.argv)}`", "", machine_info("ortools", "highspy", "numba"), ""]
    if args.only in (None, "exact"):
        out += run_exact(args) + [""]
    if args.only in (None, "large"):
        out += run_large(args) + [""]
    text = "\n".join(out)
    print(text)
    if args.md_out:
        with open(args.md_out, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")


if __name__ == "__main__":
    main()
