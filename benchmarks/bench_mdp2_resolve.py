"""MDP2 followed by our deadlock resolution: where MDP2 alone leaves robots stuck.

At the production buffer (2.0 mm) MDP2 brings every robot home in 50 of 50 seeds on the
calibrated APO and LCO instruments, so the resolution after it is never exercised there.
Larger buffers leave robots deadlocked after MDP2's 5 tries (on APO from ~3.6 mm: the
production segment shortens with the buffer, so it converges further than on the paper
grid). Here, per layout, buffer and seed, ``rfp-twin plan --algorithm mdp2`` (production
parameters greed 0.7, phobia 0.6, 5 tries, then ``--resolve search``, the default) runs
through the whole pipeline, and we report:

* ``stuck after MDP2``: robots the first MDP2 run (all its tries) left off the fold;
* ``targets kept``: robots whose delivered path ends on the target asked for (none
  replaced), and ``replaced`` / ``deadlocked`` from the plan's statuses;
* the independent 2D check of the delivered trajectory (at buffer - budget, as the
  pipeline verifies it) and its smallest clearance;
* planning and whole-run seconds (wall).

A run where MDP2 leaves more than half of the array stuck is refused by the pipeline
(PlanningError: resolution handles groups, not most of the array); it is counted as such.

    .venv/bin/python benchmarks/bench_mdp2_resolve.py --layouts sdss-v-apo --buffers 3.6 4.0 --seeds 1-10
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from bench_common import machine_info, md_table, seed_range, write_block


def run_one(layout: str, buffer_mm: float, seed: int) -> dict:
    """One ``rfp-twin plan --algorithm mdp2`` run and what its resolution kept."""
    from rfp_twin.models.errors import PlanningError
    from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
    from rfp_twin.validation.checker2d import check_trajectory

    rc = Reconfiguration.from_names("sdss-v-production", layout, buffer_mm=buffer_mm,
                                    options=PlanOptions(algorithm="mdp2"))
    t0 = time.perf_counter()
    try:
        out = rc.run(seed=seed)
    except PlanningError as exc:       # MDP2 left most of the array stuck: refused, a result
        return {"layout": layout, "buffer_mm": buffer_mm, "seed": seed, "refused": str(exc)}
    wall = time.perf_counter() - t0
    plan = out.plan
    m = plan.metrics
    kept = np.all(np.abs(plan.end() - out.targets) < 1e-6, axis=1)
    verify = out.post.verify_buffer_mm if out.post is not None else buffer_mm
    again = check_trajectory(out.trajectory, rc.spec, rc.layout, verify)
    return {"layout": layout, "buffer_mm": buffer_mm, "seed": seed, "n_robots": plan.n_robots,
            "stuck_after_mdp2": int(round((1.0 - m["convergence"]) * m["n_movable"])),
            "mdp2_tries": int(m.get("mdp2_tries", 0)), "rounds": int(m["rounds"]),
            "kept": int(kept.sum()), "replaced": int(m["n_replaced"]),
            "deadlocked": int(m["n_deadlocked"]), "check_ok": bool(again.ok),
            "verified_at_mm": float(verify), "min_clearance_mm": float(again.min_clearance_mm),
            "planning_s": float(out.seconds["plan"]), "wall_s": wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--layouts", nargs="+", default=["sdss-v-apo"])
    ap.add_argument("--buffers", nargs="+", type=float, default=[3.6, 4.0])
    ap.add_argument("--seeds", default="1-10")
    ap.add_argument("--json", default=None, help="write every run's row here")
    ap.add_argument("--md-out", default=None)
    args = ap.parse_args()
    clock = time.perf_counter()
    rows, table = [], []
    for layout in args.layouts:
        for b in args.buffers:
            rs, refused = [], 0
            for seed in seed_range(args.seeds):
                r = run_one(layout, b, seed)
                print(json.dumps(r), flush=True)
                rows.append(r)
                if "refused" in r:
                    refused += 1
                else:
                    rs.append(r)
            if not rs:
                table.append([layout, f"{b:g}", f"0 ({refused} refused)"] + ["-"] * 8)
                continue
            hit = [r for r in rs if r["stuck_after_mdp2"] > 0]
            table.append([layout, f"{b:g}", f"{len(rs)}" + (f" ({refused} refused)" if refused
                                                            else ""), str(len(hit)),
                          str(sum(r["stuck_after_mdp2"] for r in rs)),
                          f"{sum(r['kept'] for r in hit)} / {sum(r['n_robots'] for r in hit)}",
                          str(sum(r["replaced"] for r in rs)), str(sum(r["deadlocked"] for r in rs)),
                          f"{sum(r['check_ok'] for r in rs)} / {len(rs)}",
                          f"{min(r['min_clearance_mm'] for r in rs):.4f}",
                          f"{np.median([r['wall_s'] for r in rs]):.1f}"])
    header = ["layout", "buffer mm", "seeds", "seeds MDP2 left stuck", "robots stuck after MDP2",
              "targets kept (those seeds)", "replaced", "deadlocked", "2D check clear",
              "min clearance mm", "plan s median (wall)"]
    text = "\n".join([f"`.venv/bin/python benchmarks/bench_mdp2_resolve.py --layouts "
                      f"{' '.join(args.layouts)} --buffers {' '.join(f'{b:g}' for b in args.buffers)}"
                      f" --seeds {args.seeds}`", "", md_table(header, table), "",
                      f"{machine_info('numba')}; wall {time.perf_counter() - clock:.0f} s"])
    write_block(text, args.md_out)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
