#!/usr/bin/env python
"""Every planner on the same scenarios: one comparison table (issue #6).

Scenarios: SDSS-V preset (alpha 7.4 mm, beta 15 mm, pitch 22.4 mm), hex grids of N
robots, buffer B, seeded random right-armed targets that every planner can reach (clear
by the potential fields' barrier plus 0.5 mm, which also covers the stepwise step rule).
Planners, all from the folded state to the same targets:

- ``greedy/replace``: Sayres 2021 GC, reverse, one new target per deadlocked group;
- ``greedy/search``: the same with the state-time search that keeps targets;
- ``markov/search``: MC (greed 0.9, phobia 0.3) with the search;
- ``roadmap/search``: Sabater 2018's prioritized state-time planner on every robot
  (:mod:`rfp_twin.planners.roadmap.alpha_beta.array`), robots it leaves stuck re-planned by the group search;
- ``apf`` / ``capf``: Makarem 2014 / Macktoobian 2019 fields on the beta capsules
  (segment model, gain 1, lambda3 0.03), direct fold -> targets, no resolution.

Everything runs through :mod:`rfp_twin.twin.pipeline`: targets from
``Reconfiguration.random_targets`` of the ``apf`` options (the field's margin), each
planner's planning step (``Reconfiguration.plan``) and the raw delivery
(``Reconfiguration.deliver`` with ``raw``: the stepwise / field paths, no
post-processing) with its independent 2D check at the planning buffer.

Per planner: mean efficiency (Eq. 11), convergence of the first run, fold (motion) time,
tau_pg (planner kernel), the whole planning step (``call``: what a user waits for), and
the collisions that the independent checker (validation/checker2d.py) finds.

    .venv/bin/python benchmarks/bench_compare.py                     # N 37, 91; 2.5 mm; 5 seeds
    .venv/bin/python benchmarks/bench_compare.py --robots 37 91 169 --buffer 3.0 --trials 10
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from bench_common import command_line, cpu_model, load_average, now, python_version
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration

PLANNERS = ("greedy/replace", "greedy/search", "markov/search", "roadmap/search", "apf", "capf")
STEP_DEG = 0.1


def plan_options(name: str) -> PlanOptions:
    """The pipeline's options of one planner, delivering its raw (checked) paths."""
    if name in ("apf", "capf"):      # segment model, gain 1, lambda3 0.03
        return PlanOptions(algorithm=name, raw=True)
    alg, resolve = name.split("/")
    return PlanOptions(algorithm=alg, step_deg=STEP_DEG, resolve=resolve, raw=True)


def run_planner(rc: Reconfiguration, targets: np.ndarray, seed: int):
    """(metrics, independent 2D check of the raw paths, wall seconds of the planning step)."""
    t0 = time.perf_counter()
    plan, _ = rc.plan(targets, np.random.default_rng([seed, 9]))
    wall = time.perf_counter() - t0
    _, _, check = rc.deliver(plan)
    return dict(plan.metrics), check, wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", type=int, nargs="+", default=[37, 91], help="hex grid sizes")
    ap.add_argument("--buffer", type=float, default=2.5, help="collision buffer, mm")
    ap.add_argument("--trials", type=int, default=5, help="seeded scenarios per grid size")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--planners", nargs="+", default=list(PLANNERS), choices=PLANNERS)
    args = ap.parse_args()
    planners = tuple(args.planners)

    spec = load_spec("sdss-v")
    print(f"command: {command_line()}")
    print(f"machine: {cpu_model()}, Python {python_version()}; load {load_average()}; {now()}")
    rows = []
    for n in args.robots:
        layout = Layout.hex_grid_positions(n, spec.pitch_mm)
        rcs = {p: Reconfiguration.from_names(spec, layout, buffer_mm=args.buffer,
                                             options=plan_options(p)) for p in planners}
        # targets every planner can reach: clear by the potential field's barrier + 0.5 mm
        drawer = Reconfiguration.from_names(spec, layout, buffer_mm=args.buffer,
                                            options=plan_options("apf"))
        acc = {p: {"eff": [], "conv": [], "fold": [], "pg": [], "call": [], "coll": 0, "bad": 0}
               for p in planners}
        for t in range(args.trials):
            seed = args.seed * 1000 + t
            targets = drawer.random_targets(np.random.default_rng([seed, n]))
            for p in planners:
                m, rep, wall = run_planner(rcs[p], targets, seed)
                a = acc[p]
                a["eff"].append(m["efficiency"])
                a["conv"].append(m["convergence"])
                a["fold"].append(m["fold_time_s"])
                a["pg"].append(m["tau_pg_s"])
                a["call"].append(wall)
                a["coll"] += len(rep.collisions)
                a["bad"] += int(not rep.ok)
                print(f"  N {n} trial {t} {p:15s} eff {m['efficiency']:.4f} conv {m['convergence']:.4f} "
                      f"fold {m['fold_time_s']:.2f} s call {wall:.2f} s collisions {len(rep.collisions)}",
                      flush=True)
        for p in planners:
            a = acc[p]
            rows.append([str(n), p, str(args.trials), f"{np.mean(a['eff']):.4f}",
                         f"{min(a['eff']):.4f}", f"{np.mean(a['conv']):.4f}",
                         f"{np.mean(a['fold']):.2f}", f"{np.median(a['pg']):.3f}",
                         f"{np.median(a['call']):.3f}", f"{a['coll']} ({a['bad']} plans)"])
    header = ["N", "planner", "trials", "efficiency mean", "min", "convergence (1st run)",
              "fold / motion s", "tau_pg s median", "call s median", "checker2d collisions"]
    print()
    print(f"Command: `{command_line()}`\n")
    print(f"Machine: nproc 2, {cpu_model()}; load average at end {load_average()}; {now()}.\n")
    print(f"SDSS-V preset, buffer {args.buffer} mm, step {STEP_DEG} deg (stepwise), "
          f"same targets for every planner.\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for r in rows:
        print("| " + " | ".join(r) + " |")


if __name__ == "__main__":
    main()
