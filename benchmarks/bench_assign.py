#!/usr/bin/env python
"""Fiber assignment: exact solvers (CP-SAT vs HiGHS) and the heuristic at scale (issue #31).

Run from the repository root::

    .venv/bin/python benchmarks/bench_assign.py [--only exact|large] [--seeds 1 2 3]
        [--densities 50 100 200 300 1000] [--levels 1 3] [--time-limit 10]
        [--solvers cpsat highs] [--parking fold|clear]
        [--large-layout raft:204] [--large-density 20] [--large-preset raft-6p2]
        [--large-solver greedy] [--loop-seeds 1 2 ...]
        [--loop-densities 100] [--loop-unit deg2|robot] [--loop-parking fold clear]
        [--md-out FILE]

``exact``: the calibrated APO instrument (500 robots, ``sdss-v-production``, 2.0 mm, the
stepwise planners' margin at 0.1 deg), uniform mock catalogues of BOSS targets at each
density (targets/deg^2, APO plate scale 217.7358 mm/deg over the 1.5 deg field) with
priorities 1..LEVELS, assigned with ``--solver cpsat`` and ``--solver highs`` (2 workers /
1 thread, the greedy solution as a start). Per case: targets, assigned robots, objective,
proven bound, gap, status and wall seconds of the whole :func:`assign` call (after one
warm-up call, so numba kernels are loaded, not compiled), and the greedy + local
improvement heuristic's objective on the same candidates with its gap to the proven
optimum and its seconds (candidates + heuristic).

``large``: ``--large-solver`` (default the heuristic, ``greedy``) on ``--large-preset``
(default ``raft-6p2``, its own buffer) over ``--large-layout`` with ``--large-density``
targets per robot patrol area: objective, bound (the solver's, or for the heuristic each
robot's best candidate, capped by the reachable targets), gap, seconds and peak RSS.

``loop``: ``rfp-twin plan --catalogue`` in-process (:func:`rfp_twin.twin.plannable.plan_catalogue`,
greedy planner with the deadlock search, post-processing, 2D check) on the calibrated APO
and LCO instruments (``sdss-v-production``, 2.0 mm), one uniform BOSS mock per seed at
each ``--loop-densities`` (targets/deg^2 with each telescope's plate scale and field; with
``--loop-unit robot`` targets per robot, the yield study's mock of any fiber), per
``--loop-parking`` mode: rounds and targets lost per round, assigned and kept targets,
robots parked off the fold (and those of them the plan did not bring there), the
firmware-ready fold, the 2D check and the wall seconds.

``compare``: on the same catalogues (``--loop-seeds``, ``--loop-densities``), the rule of the
field systems (assignment checking final poses only, at the collision rule without the
planner's margin, then our planner with target replacement) against the loop: assigned
targets, and those lost between assignment and motion.

Prints markdown tables to paste into benchmarks/RESULTS.md by hand.
"""
from __future__ import annotations

import argparse
import resource
import sys
import time

import numpy as np

from bench_common import add_row, machine_info, timed, write_block

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
             "bound | gap % | status | components solved (largest) | s | heuristic (gap to "
             "optimum %, s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for density in args.densities:
        for levels in args.levels:
            for seed in args.seeds:
                cat = field_catalogue(seed, density, levels)
                for solver in args.solvers:
                    a, dt = timed(assign, geom, cat,
                                  AssignSettings(solver=solver, margin_mm=margin,
                                                 time_limit_s=args.time_limit,
                                                 parking=args.parking))
                    st = a.stats
                    g = st["greedy_objective"]
                    heur = (f"{g:g} ({100 * (a.objective - g) / a.objective:.2f}, "
                            f"{st['seconds']['candidates'] + st['seconds']['greedy']:.2f})"
                            if a.status == "optimal" and a.objective > 0 else "-")
                    add_row(lines, f"{density:g}", levels, seed, cat.n_targets, solver,
                            a.n_assigned, f"{a.objective:g}", f"{a.bound:g}",
                            f"{100 * a.gap:.2f}", a.status,
                            f"{st.get('n_components_solved', 0)} "
                            f"({st.get('largest_component_robots', 0)})", f"{dt:.2f}", heur)
    return lines


def run_large(args) -> list[str]:
    spec = load_spec(args.large_preset)
    geom = ArrayGeometry(spec, layout_by_name(args.large_layout, spec.pitch_mm, ()),
                         spec.buffer_mm)
    margin = array_max_displacement(geom, 0.1)
    lo, hi = spec.patrol_annulus_mm
    patrol = float(np.pi * (hi * hi - lo * lo))
    centre = geom.base_xy.mean(axis=0)
    radius = float(np.hypot(*(geom.base_xy - centre).T).max() + spec.reach_mm)
    lines = ["| preset | layout | robots | targets/patrol | levels | seed | solver | targets | "
             "assigned | objective | bound | gap % | status | s (assign) | peak RSS GB |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
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
                       AssignSettings(solver=args.large_solver, margin_mm=margin))
                warm = False
            a, dt = timed(assign, geom, cat,
                          AssignSettings(solver=args.large_solver, margin_mm=margin,
                                         time_limit_s=args.time_limit, parking=args.parking))
            rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
            add_row(lines, spec.name, args.large_layout, geom.n_robots,
                    f"{args.large_density:g}", levels, seed, args.large_solver, cat.n_targets,
                    a.n_assigned, f"{a.objective:g}", f"{a.bound:g}", f"{100 * a.gap:.3f}",
                    a.status, f"{dt:.2f}", f"{rss:.2f}")
    return lines


def run_loop(args) -> list[str]:
    """``rfp-twin plan --catalogue`` in-process: assign -> plan -> forbid -> again, per
    instrument, seed and parking mode; what the plan kept, the rounds, the parking poses
    off the fold, the fold and the 2D check."""
    from rfp_twin.planners.assignment import AssignSettings as Settings
    from rfp_twin.twin.catalogue_source import load_catalogue
    from rfp_twin.twin.pipeline import Reconfiguration
    from rfp_twin.twin.plannable import REACHED, plan_catalogue

    lines = ["| instrument | density | seed | parking | targets | rounds (lost per round) | "
             "assigned | kept | lost | science completeness % | parked off the fold (not "
             "reached) | fold s (firmware-ready) | 2D check | s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for inst, tel in (("sdss-v-apo", "apo"), ("sdss-v-lco", "lco")):
        rc = Reconfiguration.from_names("sdss-v-production", inst, buffer_mm=2.0)
        fold = np.asarray(rc.spec.fold_deg)
        for density in args.loop_densities:
            for seed in args.loop_seeds:
                if args.loop_unit == "robot":
                    cat = load_catalogue(f"mock:uniform:{density:g}/robot", rc.geom,
                                         telescope=TELESCOPES[tel], field_centre=None, seed=seed)
                else:
                    cat = field_catalogue(seed, density, 1, tel)
                for parking in args.loop_parking:
                    run, dt = timed(plan_catalogue, rc, cat, Settings(parking=parking),
                                    seed=seed)
                    s = run.summary(cat)
                    a = run.assignment
                    off = (a.target < 0) & np.any(np.abs(a.angles - fold) > 1e-6, axis=1)
                    missed = off & (np.asarray(run.outcome.plan.status) != REACHED)
                    lost = ", ".join(str(r["lost"]) for r in run.rounds)
                    add_row(lines, inst, f"{density:g}/{args.loop_unit}", seed, parking,
                            cat.n_targets, f"{len(run.rounds)} ({lost})", s["assigned"],
                            s["kept"], s["lost"], f"{100 * s['science_completeness']:.1f}",
                            f"{int(off.sum())} ({int(missed.sum())})",
                            f"{run.outcome.trajectory.duration:.2f}",
                            "clear" if run.outcome.check.ok else "COLLISION", f"{dt:.2f}")
    return lines


def run_compare(args) -> list[str]:
    """The production rule against the loop: assign checking final poses only (the
    collision rule, no planner margin: as robostrategy / fiberassign do), then plan with
    target replacement (``--resolve replace``), and count the assigned targets the plan
    did not keep; the loop (:func:`plan_catalogue`) on the same catalogue."""
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
    from rfp_twin.twin.plannable import plan_catalogue

    lines = ["| instrument | density /deg^2 | seeds | final-poses-only: assigned | lost in "
             "motion (per field) | loop: assigned and kept | lost | s per field (final-poses "
             "/ loop) |", "|---|---|---|---|---|---|---|---|"]
    for inst, tel in (("sdss-v-apo", "apo"), ("sdss-v-lco", "lco")):
        rep = Reconfiguration.from_names("sdss-v-production", inst, buffer_mm=2.0,
                                         options=PlanOptions(resolve="replace"))
        rc = Reconfiguration.from_names("sdss-v-production", inst, buffer_mm=2.0)
        for density in args.loop_densities:
            got = {"a0": [], "lost0": [], "a1": [], "lost1": [], "t0": [], "t1": []}
            for seed in args.loop_seeds:
                cat = field_catalogue(seed, density, 1, tel)
                t0 = time.perf_counter()
                a = assign(rep.geom, cat, AssignSettings(margin_mm=0.0))
                out = rep.run(seed=seed, targets=a.angles)
                got["t0"].append(time.perf_counter() - t0)
                got["a0"].append(a.n_assigned)
                got["lost0"].append(int(np.sum((a.target >= 0)
                                               & (out.plan.status != "reached"))))
                run, dt = timed(plan_catalogue, rc, cat, AssignSettings(), seed=seed)
                got["t1"].append(dt)
                got["a1"].append(run.summary(cat)["kept"])
                got["lost1"].append(run.n_lost)
            lost = got["lost0"]
            add_row(lines, inst, f"{density:g}", len(args.loop_seeds), sum(got["a0"]),
                    f"{sum(lost)} ({min(lost)}-{max(lost)})", sum(got["a1"]), sum(got["lost1"]),
                    f"{np.median(got['t0']):.2f} / {np.median(got['t1']):.2f}")
    return lines


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--only", choices=("exact", "large", "loop", "compare"), default=None)
    p.add_argument("--loop-seeds", type=int, nargs="+", default=list(range(1, 21)))
    p.add_argument("--loop-densities", type=float, nargs="+", default=[100.0])
    p.add_argument("--parking", choices=("fold", "clear"), default="fold",
                   help="parking mode of the exact and large runs")
    p.add_argument("--loop-unit", choices=("deg2", "robot"), default="deg2")
    p.add_argument("--loop-parking", nargs="+", choices=("fold", "clear"), default=["fold"])
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--densities", type=float, nargs="+", default=[50, 100, 200, 300, 1000])
    p.add_argument("--levels", type=int, nargs="+", default=[1, 3])
    p.add_argument("--time-limit", type=float, default=10.0)
    p.add_argument("--solvers", nargs="+", default=["cpsat", "highs"],
                   choices=("cpsat", "highs"))
    p.add_argument("--large-layout", default="raft:204")
    p.add_argument("--large-preset", default="raft-6p2")
    p.add_argument("--large-solver", default="greedy")
    p.add_argument("--large-density", type=float, default=20.0)
    p.add_argument("--md-out", default=None)
    args = p.parse_args()
    out = [f"`{' '.join(sys.argv)}`", "", machine_info("ortools", "highspy", "numba"), ""]
    if args.only in (None, "exact"):
        out += run_exact(args) + [""]
    if args.only in (None, "large"):
        out += run_large(args) + [""]
    if args.only in (None, "loop"):
        out += run_loop(args) + [""]
    if args.only in (None, "compare"):
        out += run_compare(args) + [""]
    write_block("\n".join(out), args.md_out)


if __name__ == "__main__":
    main()
