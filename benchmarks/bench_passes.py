#!/usr/bin/env python
"""Yield per pass: one field observed K times (issue #31, point 4 and comparison 6c).

Run from the repository root::

    .venv/bin/python benchmarks/bench_passes.py [--preset desi] [--layout hex:547]
        [--kinds uniform clustered] [--density 5] [--levels 1] [--passes 5]
        [--seeds 1 2 3] [--arms right|both] [--direct-stuck 0.1] [--md-out FILE]

Each field is ``rfp-twin plan --preset P --layout L --telescope none --catalogue
mock:KIND:DENSITY/robot[,levels=N] --passes K --seed S [--arms both]`` run in-process
(:func:`rfp_twin.twin.passes.observe_passes`): every pass assigns the science targets not
yet observed (HiGHS, collision-aware, the planner's margin), plans them through the
plannable loop (greedy planner, deadlock search, post-processing, 2D check: every
assigned target kept) and moves from the previous pass's poses (direct, or the fold of
the previous poses then the unfold of the new ones). The density is in targets per robot
(per hexagonal cell of the pitch): 5 per robot over 5 passes is the "matched fiber and
target densities" of Saunders et al. (every fiber has one target per pass on average).

Per pass, over the seeds: targets assigned, the pass's yield and the cumulative
completeness of the science targets within reach of a robot (the assigner's candidates)
and of all of them, how each motion was made, its firmware-ready time against the fold +
unfold, assigned targets lost (0 expected) and the 2D check. Per field: the final
completeness, by priority, and a bound no assigner reaches in K passes of the same
pointing (collisions ignored, each robot one target per pass: a maximum flow). Prints markdown tables to
paste into benchmarks/RESULTS.md by hand.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from bench_common import add_row, machine_info, write_block

from rfp_twin.planners.assignment import AssignSettings
from rfp_twin.twin.catalogue_source import load_catalogue
from rfp_twin.twin.passes import DIRECT, VIA_FOLD, observe_passes, passes_summary, within_reach
from rfp_twin.twin.pass_options import DIRECT_STUCK_SHARE
from rfp_twin.twin.pipeline import Reconfiguration


def catalogue_text(kind: str, density: float, levels: int) -> str:
    return f"mock:{kind}:{density:g}/robot" + (f",levels={levels}" if levels > 1 else "")


def passes_bound(rc, cat, settings, passes: int) -> int:
    """Most science targets ``passes`` passes can observe when collisions are ignored: a
    maximum flow in which each robot takes at most one target per pass (``passes`` in
    all) and each target within its reach (the assigner's candidates) once."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import maximum_flow

    from rfp_twin.planners.assignment import build_candidates

    cands = build_candidates(rc.geom, cat, margin_mm=rc.target_margin_mm(), arms=settings.arms)
    on = (cands.target >= 0)
    pairs = np.unique(np.column_stack([cands.robot[on], cands.target[on]]), axis=0)
    pairs = pairs[cat.kind[pairs[:, 1]] == 0]
    n, t = rc.geom.n_robots, cat.n_targets
    src, sink = 0, 1 + n + t
    rows = np.concatenate([np.zeros(n, dtype=np.int64), 1 + pairs[:, 0], 1 + n + np.arange(t)])
    cols = np.concatenate([1 + np.arange(n), 1 + n + pairs[:, 1], np.full(t, sink)])
    cap = np.concatenate([np.full(n, passes), np.ones(len(pairs) + t)]).astype(np.int32)
    graph = csr_matrix((cap, (rows, cols)), shape=(sink + 1, sink + 1))
    return int(maximum_flow(graph, src, sink).flow_value)


def run_fields(args) -> tuple[list[str], list[str]]:
    """(per-pass table lines, per-field summary lines)."""
    rc = Reconfiguration.from_names(args.preset, args.layout)
    settings = AssignSettings(arms=("right", "left") if args.arms == "both" else ("right",))
    per_pass = ["| catalogue | pass | assigned (mean) | pass yield % in reach | cumulative % in "
                "reach (mean, min-max) | cumulative % all | motions direct / via fold | "
                "motion s median (max) | fold + unfold s median | lost | 2D clear |",
                "|---|---|---|---|---|---|---|---|---|---|---|"]
    fields = ["| catalogue | seeds | targets (mean) | within reach (mean) | after "
              f"{args.passes} passes: % in reach (min-max) | % all | by priority % in reach "
              "| bound: no collisions, <= 1 per robot per pass, % in reach | s per field (median) |",
              "|---|---|---|---|---|---|---|---|---|"]
    for kind in args.kinds:
        text = catalogue_text(kind, args.density, args.levels)
        rows, sums, walls, bounds = [], [], [], []
        for seed in args.seeds:
            cat = load_catalogue(text, rc.geom, telescope=None, field_centre=None, seed=seed)
            t0 = time.perf_counter()
            done = observe_passes(rc, cat, settings, args.passes, seed=seed,
                                  direct_stuck=args.direct_stuck)
            walls.append(time.perf_counter() - t0)
            near = within_reach(rc, cat, settings)
            s = passes_summary(cat, done, near)
            sums.append((cat, near, s, done))
            bounds.append(passes_bound(rc, cat, settings, args.passes)
                          / np.count_nonzero(near & (cat.kind == 0)))
            rows.append(s["passes"])
        for k in range(args.passes):
            got = [r[k] for r in rows if len(r) > k]
            prev = [r[k - 1]["cumulative_within_reach"] if k else 0.0 for r in rows if len(r) > k]
            cum = np.array([g["cumulative_within_reach"] for g in got])
            motion = [g["reconfiguration_s"] for g in got]
            via = [g["via_fold_s"] for g in got if g["via_fold_s"] is not None]
            n_direct = sum(g["motion"] == DIRECT for g in got)
            n_via = sum(g["motion"] == VIA_FOLD for g in got)
            add_row(per_pass, text, k + 1, f"{np.mean([g['assigned'] for g in got]):.1f}",
                    f"{100 * np.mean(cum - np.array(prev)):.1f}",
                    f"{100 * cum.mean():.1f} ({100 * cum.min():.1f}-{100 * cum.max():.1f})",
                    f"{100 * np.mean([g['cumulative'] for g in got]):.1f}",
                    f"{n_direct} / {n_via}" if k else "from fold",
                    f"{np.median(motion):.2f} ({max(motion):.2f})",
                    f"{np.median(via):.2f}" if via else "-",
                    sum(g["lost"] for g in got),
                    f"{sum(g['check2d_ok'] for g in got)}/{len(got)}")
        final = np.array([s["completeness"]["within_reach"] for _, _, s, _ in sums])
        prio = {}
        for cat, near, s, done in sums:
            seen = np.isin(cat.ids, np.concatenate([p.observed for p in done]))
            sci = (cat.kind == 0) & near
            for p in np.unique(cat.priority[sci])[::-1]:
                at = sci & (cat.priority == p)
                prio.setdefault(f"{p:g}", []).append(seen[at].sum() / at.sum())
        add_row(fields, text, len(args.seeds),
                f"{np.mean([c.n_targets for c, _, _, _ in sums]):.0f}",
                f"{np.mean([n.sum() for _, n, _, _ in sums]):.0f}",
                f"{100 * final.mean():.1f} ({100 * final.min():.1f}-{100 * final.max():.1f})",
                f"{100 * np.mean([s['completeness']['science'] for _, _, s, _ in sums]):.1f}",
                ", ".join(f"{p}: {100 * np.mean(v):.1f}" for p, v in prio.items()),
                f"{100 * np.mean(bounds):.1f} ({100 * min(bounds):.1f}-{100 * max(bounds):.1f})",
                f"{np.median(walls):.1f}")
    return per_pass, fields


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--preset", default="desi")
    p.add_argument("--layout", default="hex:547")
    p.add_argument("--kinds", nargs="+", default=["uniform", "clustered"],
                   choices=("uniform", "clustered"))
    p.add_argument("--density", type=float, default=5.0, help="targets per robot")
    p.add_argument("--levels", type=int, default=1)
    p.add_argument("--passes", type=int, default=5)
    p.add_argument("--direct-stuck", type=float, default=DIRECT_STUCK_SHARE,
                   help="rfp-twin plan --direct-stuck")
    p.add_argument("--arms", default="right", choices=("right", "both"),
                   help="arm solutions assigned (rfp-twin plan --arms)")
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    p.add_argument("--md-out", default=None)
    args = p.parse_args()
    import sys

    head = [f"`{' '.join(sys.argv)}`", "", machine_info("highspy", "numba"), "",
            f"preset {args.preset}, layout {args.layout}, {args.passes} passes, arms "
            f"{args.arms}, direct-stuck {args.direct_stuck:g}", ""]
    per_pass, fields = run_fields(args)
    write_block("\n".join(head + per_pass + [""] + fields), args.md_out)


if __name__ == "__main__":
    main()
