#!/usr/bin/env python
"""The planning stage alone, in one process: plan identity and where the time goes (#13).

Run from the repository root::

    .venv/bin/python benchmarks/bench_plan_stage.py [--buffer 3.5] [--seeds 1 2 ... 8]
                                                    [--preset sdss-v] [--algorithm greedy]
                                                    [--whole-attempts N] [--md-out FILE]

For each seed: the seeded random targets and ``Reconfiguration.plan`` (greedy + search,
default options, the built-in layout of the preset), as ``rfp-twin plan --seed S`` runs
them. Per seed it prints a fingerprint of the plan (the first 10 hex digits of the MD5 of
its CSR paths: equal fingerprints, byte-identical plans, so two versions of the code can
be compared run for run), the plan stage's wall seconds, its rounds, the wall seconds of
the re-runs, the search, the continuation (``metrics``) and of the searches'
``trim_tails`` calls (timed in this process), the replaced targets, the fold, and the
single-robot roadmap plans of the search that found no trajectory: their number, paths
tried and seconds (``plan_arm`` timed in this process). One warm-up plan of the first
seed runs first (numba kernels loaded or compiled). ``--whole-attempts N`` sets
``rfp_twin.planners.deadlocks.rerun.WHOLE_ATTEMPTS`` (the whole-array re-run ladder's cap) for the
whole run, to measure another cap.

To time older code, put a directory holding ``rfp_twin`` (a link to a worktree of it)
first on ``PYTHONPATH``. Prints a markdown table; ``--md-out`` also writes it to a file.
"""
from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np

from bench_common import load_average, machine_info, md_table, write_block

HEADER = ["seed", "fingerprint", "plan s", "rounds", "re-run s", "search s", "continuation s",
          "trim s", "replaced", "fold s", "failed plans", "their paths", "their s"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--buffer", type=float, default=3.5)
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(1, 9)))
    ap.add_argument("--preset", default="sdss-v")
    ap.add_argument("--algorithm", default="greedy")
    ap.add_argument("--whole-attempts", type=int, default=None)
    ap.add_argument("--md-out", default=None)
    a = ap.parse_args()

    import rfp_twin.planners.deadlocks.search.resolve as resolve
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
    trims: list = []
    trim_tails = resolve.trim_tails

    def timed_trim(*args):
        t = time.perf_counter()
        out = trim_tails(*args)
        trims.append(time.perf_counter() - t)
        return out

    resolve.trim_tails = timed_trim
    if a.whole_attempts is not None:
        import rfp_twin.planners.deadlocks.rerun as rerun
        rerun.WHOLE_ATTEMPTS = a.whole_attempts
    spec = load_spec(a.preset)
    layout = chosen_layout(None, None, spec)

    def plan(seed: int):
        rc = Reconfiguration.from_names(spec, layout, buffer_mm=a.buffer,
                                        options=PlanOptions(algorithm=a.algorithm))
        rng = np.random.default_rng(seed)
        targets = rc.random_targets(rng)
        failed.clear()
        trims.clear()
        t = time.perf_counter()
        result, _ = rc.plan(targets, rng)
        return result, time.perf_counter() - t

    plan(a.seeds[0])                                      # warm-up
    rows, total, replaced = [], 0.0, 0
    for seed in a.seeds:
        result, seconds = plan(seed)
        total += seconds
        m = result.metrics
        replaced += m["n_replaced"]
        digest = hashlib.md5(result.path_step.tobytes() + result.path_angles.tobytes()
                             + result.path_ptr.tobytes()).hexdigest()[:10]
        rows.append([str(seed), digest, f"{seconds:.2f}", str(m["rounds"]),
                     f"{m['rerun_s']:.2f}", f"{m['search_s']:.2f}",
                     f"{m['continuation_s']:.2f}", f"{sum(trims):.3f}",
                     str(m["n_replaced"]), f"{m['fold_time_s']:.2f}", str(len(failed)),
                     str(sum(p for p, _ in failed)), f"{sum(s for _, s in failed):.2f}"])
        print(" | ".join(rows[-1]), flush=True)
    cap = "" if a.whole_attempts is None else f", WHOLE_ATTEMPTS {a.whole_attempts}"
    write_block(f"### Plan stage, {a.preset}, {a.algorithm} + search, {a.buffer:g} mm{cap}\n\n"
                f"{machine_info('numba')}\n\n" + md_table(HEADER, rows)
                + f"\n\nPlan stage over the seeds: {total:.2f} s, median "
                f"{np.median([float(r[2]) for r in rows]):.2f} s; targets replaced: {replaced}. "
                f"Load at the end: {load_average()}.", a.md_out)


if __name__ == "__main__":
    main()
