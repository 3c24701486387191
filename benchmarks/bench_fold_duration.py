#!/usr/bin/env python
"""How much longer the firmware-ready fold is than the stepwise plan (issue #13).

Run from the repository root::

    .venv/bin/python benchmarks/bench_fold_duration.py [--seeds 1-20] [--buffers 2.0 2.5]
        [--algorithms greedy markov] [--planners greedy/search ... | --no-planners]
        [--planner-seeds 1-5] [--md-out FILE]

1. ``ratio``: for every algorithm and buffer, the 500-robot SDSS-V layout (``sdss-v``,
   ``sdss-v-fps``, step 0.1 deg, 30 deg/s, 45 deg/s^2) and seeds, the whole pipeline
   the way ``rfp-twin plan --preset sdss-v --algorithm A --buffer B --seed S`` runs it
   (:class:`rfp_twin.twin.pipeline.Reconfiguration`, search resolution, post-processing
   with its default backend and the independent 2D check): stepwise fold, firmware-ready
   duration, their ratio (median, p95, max; target median <= 1.10, p95 <= 1.20), plan and
   post-processing seconds, the longest group.
2. ``planners``: the same ratio per planner / resolver (``greedy/search``,
   ``markov/replace``, ...) on the same targets (``--planner-seeds``, 2.5 mm);
   ``roadmap/search`` can be added, at ~25 s a plan on 500 robots.

Every run is checked: a post-processed trajectory exists only after the 2D checker
passed it at buffer - 0.03 mm. Prints a markdown block to paste into
benchmarks/RESULTS.md.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from bench_common import command_line, machine_info, md_table, write_block
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration


def seeds_arg(text: str) -> list[int]:
    """``1-20`` or ``1,2,5``."""
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(x) for x in text.split(",")]


def one_run(rc: Reconfiguration, seed: int) -> dict:
    """The pipeline on one seed: figures of the run."""
    t0 = time.perf_counter()
    out = rc.run(seed=seed)
    wall = time.perf_counter() - t0
    plan, post = out.plan, out.post
    assert out.check.ok, f"seed {seed}: the 2D check failed"
    stepwise = plan.n_steps * plan.step_s
    slow = post.slowest_groups[0] if post.slowest_groups else {"robots": [], "stepwise_s": 0.0}
    return {"seed": seed, "stepwise_s": stepwise, "duration_s": post.duration_s,
            "ratio": post.duration_s / stepwise, "plan_s": out.seconds["plan"],
            "post_s": post.stage_seconds["total"], "wall_s": wall,
            "efficiency": plan.metrics["efficiency"], "rounds": post.check_rounds,
            "longest": slow}


def summary_row(label: str, rows: list[dict]) -> list[str]:
    r = np.array([x["ratio"] for x in rows])
    worst = max(rows, key=lambda x: x["ratio"])
    return [label, str(len(rows)), f"{np.median(r):.3f}", f"{np.percentile(r, 95):.3f}",
            f"{r.max():.3f} (seed {worst['seed']})",
            f"{np.median([x['stepwise_s'] for x in rows]):.2f}",
            f"{np.median([x['duration_s'] for x in rows]):.2f}",
            f"{np.median([x['post_s'] for x in rows]):.2f}",
            f"{np.median([x['wall_s'] for x in rows]):.2f}",
            f"{min(x['efficiency'] for x in rows):.4f}"]


HEADER = ["setting", "seeds", "ratio median", "ratio p95", "ratio max", "stepwise fold s (median)",
          "firmware-ready s (median)", "post-processing s (median)", "whole run s (median)",
          "min efficiency"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("1-20"))
    ap.add_argument("--buffers", type=float, nargs="+", default=[2.0, 2.5])
    ap.add_argument("--algorithms", nargs="+", default=["greedy", "markov"])
    ap.add_argument("--planners", nargs="+",
                    default=["greedy/search", "greedy/replace", "markov/search", "markov/replace"])
    ap.add_argument("--no-planners", action="store_true")
    ap.add_argument("--planner-seeds", type=seeds_arg, default=seeds_arg("1-5"))
    ap.add_argument("--md-out", default=None)
    args = ap.parse_args()

    md = ["### Firmware-ready fold / stepwise fold (`bench_fold_duration.py`)", "",
          f"`{command_line()}`: {machine_info('numba')}.", ""]
    rows, detail = [], []
    for alg in args.algorithms:
        for buf in args.buffers:
            rc = Reconfiguration.from_names("sdss-v", buffer_mm=buf,
                                            options=PlanOptions(algorithm=alg))
            runs = []
            for seed in args.seeds:
                r = one_run(rc, seed)
                runs.append(r)
                print(f"{alg} {buf} mm seed {seed}: stepwise {r['stepwise_s']:.2f} s, "
                      f"firmware-ready {r['duration_s']:.2f} s (x {r['ratio']:.3f}), post "
                      f"{r['post_s']:.2f} s, whole {r['wall_s']:.2f} s, longest group "
                      f"{r['longest']['robots']}", flush=True)
            rows.append(summary_row(f"{alg} + search, {buf} mm", runs))
            worst = sorted(runs, key=lambda x: -x["ratio"])[:2]
            detail += [f"- {alg} {buf} mm, seed {w['seed']}: x {w['ratio']:.3f}, the end set by "
                       f"robots {w['longest']['robots']} (stepwise {w['longest']['stepwise_s']:.2f}"
                       f" s)" for w in worst]
    md += [md_table(HEADER, rows), "", *detail, ""]
    if not args.no_planners:
        prow = []
        for name in args.planners:
            alg, res = name.split("/")
            rc = Reconfiguration.from_names("sdss-v", buffer_mm=2.5,
                                            options=PlanOptions(algorithm=alg, resolve=res))
            runs = [one_run(rc, s) for s in args.planner_seeds]
            print(f"{name}: " + ", ".join(f"{r['ratio']:.3f}" for r in runs), flush=True)
            prow.append(summary_row(f"{name}, 2.5 mm", runs))
        md += ["Per planner / resolver, the same targets:", "", md_table(HEADER, prow), ""]
    write_block("\n".join(md), args.md_out)


if __name__ == "__main__":
    main()
