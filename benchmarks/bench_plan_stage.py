#!/usr/bin/env python
"""The planning stage alone, in one process: plan identity and where the time goes (#13).

Run from the repository root::

    .venv/bin/python benchmarks/bench_plan_stage.py [--buffer 3.5] [--seeds 1 2 ... 8]
                                                    [--preset sdss-v] [--md-out FILE]

For each seed: the seeded random targets and ``Reconfiguration.plan`` (greedy + search,
default options, the built-in layout of the preset), as ``rfp-twin plan --seed S`` runs
them. Per seed it prints a fingerprint of the plan (the first 10 hex digits of the MD5 of
its CSR paths: equal fingerprints, byte-identical plans, so two versions of the code can
be compared run for run), the plan stage's wall seconds, the search's, the replaced
targets, the fold, and the single-robot roadmap plans of the search that found no
trajectory: their number, paths tried and seconds (``plan_arm`` timed in this process).
One warm-up plan of the first seed runs first (numba kernels loaded or compiled).

To time older code, put a directory holding ``rfp_twin`` (a link to a worktree of it)
first on ``PYTHONPATH``. Prints a markdown table; ``--md-out`` also writes it to a file.
"""
from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np

from bench_common import load_average, machine_info, md_table, write_block

HEADER = ["seed", "fingerprint", "plan s", "search s", "replaced", "fold s",
          "failed plans", "their paths", "their s"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--buffer", type=float, default=3.5)
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 9)))
    ap.add_argument("--preset", default="sdss-v")
    ap.add_argument("--md-out", default=None)
    a = ap.parse_args()

    import rfp_twin.planners.roadmap.priority as priority
    from rfp_twin.models.robot import load_spec
    from rfp_twin.twin.cli.layout_option import chosen_layout
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration

    failed: list = []
    plan_arm = priority.plan_arm

    def timed(arm, settings, rng, roadmap=None):
        t = time.perf_counter()
        traj, stats = plan_arm(arm, settings, rng, roadmap)
        if traj is None:
            failed.append((stats.paths_tried, time.perf_counter() - t))
        return traj, stats

    priority.plan_arm = timed
    spec = load_spec(a.preset)
    layout = chosen_layout(None, None, spec)

    def plan(seed: int):
        rc = Reconfiguration.from_names(spec, layout, buffer_mm=a.buffer, options=PlanOptions())
        rng = np.random.default_rng(seed)
        targets = rc.random_targets(rng)
        failed.clear()
        t = time.perf_counter()
        result, _ = rc.plan(targets, rng)
        return result, time.perf_counter() - t

    plan(a.seeds[0])                                      # warm-up
    rows, total = [], 0.0
    for seed in a.seeds:
        result, seconds = plan(seed)
        total += seconds
        m = result.metrics
        digest = hashlib.md5(result.path_step.tobytes() + result.path_angles.tobytes()
                             + result.path_ptr.tobytes()).hexdigest()[:10]
        rows.append([str(seed), digest, f"{seconds:.2f}", f"{m['search_s']:.2f}",
                     str(m["n_replaced"]), f"{m['fold_time_s']:.2f}", str(len(failed)),
                     str(sum(p for p, _ in failed)), f"{sum(s for _, s in failed):.2f}"])
        print(" | ".join(rows[-1]), flush=True)
    write_block(f"### Plan stage, {a.preset}, greedy + search, {a.buffer:g} mm\n\n"
                f"{machine_info('numba')}\n\n" + md_table(HEADER, rows)
                + f"\n\nPlan stage over the seeds: {total:.2f} s. Load at the end: "
                f"{load_average()}.", a.md_out)


if __name__ == "__main__":
    main()
