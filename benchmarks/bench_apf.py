#!/usr/bin/env python
"""APF / CAPF benchmarks: Makarem 2014 (DESI) and Macktoobian 2019 Table 1 (SDSS-V-like).

Run from the repository root::

    .venv/bin/python benchmarks/bench_apf.py [--only makarem|macktoobian|all]
        [--runs 100] [--sizes 37 127 547 1027 2107 4921] [--gains 1 10]
        [--mack-runs 3] [--mack-sizes 52 106 234 449 730 980] [--models tip segment]
        [--seed 0] [--md-out FILE]

Sections
--------
1. ``makarem``: preset ``desi`` (3 + 3 mm arms, 10.4 mm pitch, 30 / 20 rpm), centred hex
   grids of N robots, tip model (d = 2, D = 4 mm), lambda1 = 1, lambda2 = 0.05, dt 10 ms,
   100 um. Per run: random right-armed starts (tips > 2.1 mm apart) and targets (tips
   > 3.0 mm apart, ``--target-sep``: at less than ~2.9 mm the repulsion alone holds two
   tips more than 100 um off their targets), uniform by area in the patrol disk.
   ``--runs`` runs per N (paper: 100). Reported: runs where every robot converged,
   robots within 100 um, smallest tip distance of all runs, guard interventions,
   motion time (all robots in tolerance; mean / sd / max over the converged runs),
   mean per-robot settle time, kernel and whole-call compute time, and linear fits of
   compute time and motion time against N. One row set per ``--gains`` value (the
   paper's weights fix the field's shape, not its time scale: see ApfSettings.gain).
2. ``macktoobian``: preset ``sdss-v`` (7.4 / 15 mm, 22.4 mm pitch, 30 deg/s), the N robots
   of a hex grid nearest its centre for the paper's batch-1 sizes, APF vs CAPF
   (lambda3 0.03, and 0.04 as the paper used for its two largest cases), in the tip
   model (the paper's field: d = 2, D = 4 mm) and the segment model (buffer 2.5 mm,
   d = 2 buffer + margin; targets drawn as the pipeline draws them for ``apf``,
   ``rfp_twin.twin.pipeline.Reconfiguration.random_targets``). ``--mack-runs`` seeds per size
   (paper: one run each); converged counts are means over the runs, next to the
   paper's Table 1.

Both sections plan from random starts (the papers' set-up) with the field kernels
themselves (:func:`rfp_twin.planners.fields.plan_apf`, tip or segment model, no recording), which
the pipeline's planning step (fold -> targets, segment model) does not offer; rfp-twin's
fields on the pipeline's own scenarios are in ``bench_compare.py``.

Timings are single-threaded numba kernels; ``kernel`` excludes compilation (one warm-up
call first) and random-configuration draws. Prints markdown to paste into
benchmarks/RESULTS.md (between ``<!-- bench:begin -->`` and ``<!-- bench:end -->``).
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from bench_common import command_line, cpu_model, load_average, now, python_version, write_block
from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.robot import load_spec
from rfp_twin.planners.fields import (ApfSettings, CapfSettings, apf_target_margin_mm, plan_apf,
                          random_tip_configs)
from rfp_twin.planners.plan.targets import random_targets
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration

#: Macktoobian 2019 Table 1, test batch 1: N -> (APF converged, CAPF converged, lambda3).
PAPER_TABLE1 = {52: (50, 52, 0.03), 106: (90, 106, 0.03), 234: (196, 234, 0.03),
                449: (382, 449, 0.03), 730: (621, 730, 0.04), 980: (844, 980, 0.04)}
#: Makarem 2014 Sect. 6 / Figs. 5-6: motion ~2.5 s for any N, 140 s compute for 5000.
PAPER_MOTION_S = 2.5


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def nearest_layout(n: int, pitch_mm: float) -> Layout:
    """The n positions of a centred hex grid nearest its centre (ties by angle)."""
    rings = 1
    while 1 + 3 * rings * (rings + 1) < n:
        rings += 1
    grid = Layout.hex_grid(rings + 1, pitch_mm)
    r = np.round(np.hypot(*grid.xy.T), 6)
    order = np.lexsort((np.arctan2(grid.xy[:, 1], grid.xy[:, 0]), r))[:n]
    return Layout(np.arange(n), grid.xy[np.sort(order)], ["robot"] * n, f"hex-nearest-{n}")


def fit(x, y):
    """Least-squares line: (slope, intercept, R^2)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    if len(x) < 2:
        return math.nan, math.nan, math.nan
    a, b = np.polyfit(x, y, 1)
    res = y - (a * x + b)
    ss = np.sum((y - y.mean()) ** 2)
    return float(a), float(b), float(1 - np.sum(res ** 2) / ss) if ss > 0 else math.nan


# =====================================================================================
# Makarem 2014
# =====================================================================================
def run_makarem(sizes, runs, gains, seed, start_sep, target_sep):
    spec = load_spec("desi")
    rows = []
    for gain in gains:
        settings = ApfSettings(gain=gain)
        for n_pos in sizes:
            geom = ArrayGeometry(spec, Layout.hex_grid_positions(n_pos, spec.pitch_mm),
                                 spec.buffer_mm)
            n = geom.n_robots
            rec = []
            t_wall = time.perf_counter()
            for k in range(runs):
                rng = np.random.default_rng([seed, n, k])
                start = random_tip_configs(geom, rng, start_sep)
                targets = random_tip_configs(geom, rng, target_sep)
                if k == 0:
                    plan_apf(geom, start, targets, settings, record=False)   # warm-up
                r = plan_apf(geom, start, targets, settings, record=False)
                rec.append((r.complete, r.n_converged, r.min_tip_distance_mm, r.n_guard,
                            r.motion_time_s, float(np.nanmean(r.settle_time_s)),
                            r.compute_time_s, r.total_time_s, r.steps, r.stop_reason))
            a = np.array([x[:9] for x in rec], dtype=float)
            ok = a[:, 0] == 1
            mt = a[ok, 4]
            rows.append(dict(
                gain=gain, n=n, runs=runs, complete=int(ok.sum()),
                conv_frac=float(a[:, 1].sum() / (n * runs)), min_tip=float(a[:, 2].min()),
                guard=int(a[:, 3].sum()), guard_runs=int((a[:, 3] > 0).sum()),
                motion_mean=float(mt.mean()) if mt.size else math.nan,
                motion_sd=float(mt.std()) if mt.size else math.nan,
                motion_max=float(mt.max()) if mt.size else math.nan,
                settle_mean=float(a[:, 5].mean()), kernel=float(a[:, 6].mean()),
                total=float(a[:, 7].mean()),
                us_robot_step=float(np.mean(a[:, 6] / (n * np.maximum(a[:, 8], 1))) * 1e6),
                stops={s: sum(1 for x in rec if x[9] == s) for s in ("converged", "stalled", "max_time")},
                wall=time.perf_counter() - t_wall))
            row = rows[-1]
            log(f"makarem gain {gain:g} N {n}: {row['complete']}/{runs} complete, conv "
                f"{row['conv_frac']:.5f}, min tip {row['min_tip']:.4f}, motion "
                f"{row['motion_mean']:.2f}+-{row['motion_sd']:.2f} s (max {row['motion_max']:.2f}), "
                f"kernel {row['kernel']:.3f} s, wall {row['wall']:.0f} s")
    return rows


def md_makarem(rows, args) -> list[str]:
    out = [f"### Makarem 2014 reproduction (DESI preset, tip model, {args.runs} random runs per N)", "",
           f"Starts: tips > {args.start_sep} mm apart; targets: tips > {args.target_sep} mm apart "
           "(uniform by area, right-armed). d = 2, D = 4 mm, lambda1 = 1, lambda2 = 0.05, "
           "dt 10 ms, tol 100 um, 30 / 20 rpm, max 60 s. `complete`: runs in which every robot "
           "ended within 100 um. Motion time: until every robot is within 100 um (converged "
           "runs). Settle: per-robot time after which it stays within 100 um. `guard`: steps "
           "the step guard had to hold back (0 = the field alone kept every tip > d).", "",
           "| gain | N | complete | robots within 100 um | min tip mm | guard (runs) | motion s mean +- sd | motion max s | settle mean s | kernel s | call s | us / robot-step | stops c/s/m |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        st = r["stops"]
        out.append(f"| {r['gain']:g} | {r['n']} | {r['complete']}/{r['runs']} | {r['conv_frac']:.5f} | "
                   f"{r['min_tip']:.4f} | {r['guard']} ({r['guard_runs']}) | "
                   f"{r['motion_mean']:.2f} +- {r['motion_sd']:.2f} | {r['motion_max']:.2f} | "
                   f"{r['settle_mean']:.2f} | {r['kernel']:.4f} | {r['total']:.4f} | "
                   f"{r['us_robot_step']:.2f} | {st['converged']}/{st['stalled']}/{st['max_time']} |")
    out.append("")
    for gain in sorted({r["gain"] for r in rows}):
        rs = [r for r in rows if r["gain"] == gain]
        ns = [r["n"] for r in rs]
        a, b, r2 = fit(ns, [r["kernel"] for r in rs])
        am, bm, r2m = fit(ns, [r["motion_mean"] for r in rs])
        out.append(f"- gain {gain:g}: kernel time = {a * 1e3:.3f} ms per robot x N + {b * 1e3:.1f} ms "
                   f"(R^2 {r2:.3f}); at N = 5000: {(a * 5000 + b):.2f} s (paper: 140 s on a "
                   f"2014 Xeon). Motion time vs N: {am * 1000:+.3f} s per 1000 robots "
                   f"(R^2 {r2m:.2f}), {min(r['motion_mean'] for r in rs):.2f}-"
                   f"{max(r['motion_mean'] for r in rs):.2f} s (paper: ~{PAPER_MOTION_S} s, flat).")
    out.append("")
    return out


# =====================================================================================
# Macktoobian 2019
# =====================================================================================
def run_macktoobian(sizes, runs, models, seed):
    spec = load_spec("sdss-v")
    rows = []
    for model in models:
        for n in sizes:
            buffer = 2.5
            geom = ArrayGeometry(spec, nearest_layout(n, spec.pitch_mm), buffer)
            drawer = Reconfiguration(geom, PlanOptions(algorithm="apf"))  # segment, gain 1
            algs = [("APF", ApfSettings(model=model)),
                    ("CAPF 0.03", CapfSettings(model=model, lambda3=0.03)),
                    ("CAPF 0.04", CapfSettings(model=model, lambda3=0.04))]
            res = {name: [] for name, _ in algs}
            for k in range(runs):
                rng = np.random.default_rng([seed, n, k])
                if model == "tip":
                    start = random_tip_configs(geom, rng, 2.1)
                    targets = random_tip_configs(geom, rng, 3.0)
                else:    # targets: the field's margin + 0.5 mm; starts a little closer
                    m = apf_target_margin_mm(geom, algs[0][1])
                    start = random_targets(geom, rng, margin_mm=m + 0.05)
                    targets = drawer.random_targets(rng)
                for name, s in algs:
                    r = plan_apf(geom, start, targets, s, record=False,
                                 algorithm="apf" if name == "APF" else "capf")
                    res[name].append((r.n_converged, r.motion_time_s, r.compute_time_s,
                                      r.min_distance_mm - r.d_mm, r.n_guard, r.stop_reason))
            row = dict(model=model, n=n, runs=runs)
            for name, vals in res.items():
                v = np.array([x[:5] for x in vals], dtype=float)
                row[name] = dict(conv=float(v[:, 0].mean()), conv_all=[int(x) for x in v[:, 0]],
                                 motion=float(v[:, 1].mean()), kernel=float(v[:, 2].mean()),
                                 min_excess=float(v[:, 3].min()), guard=int(v[:, 4].sum()))
            rows.append(row)
            log(f"macktoobian {model} N {n}: " + ", ".join(
                f"{name} {row[name]['conv']:.1f} ({row[name]['kernel']:.2f} s)" for name, _ in algs))
    return rows


def md_macktoobian(rows, args) -> list[str]:
    out = [f"### Macktoobian 2019 Table 1 (batch 1) next to ours (SDSS-V preset, {args.mack_runs} run(s) per N)", "",
           "Ours: the N positions of a 22.4 mm hex grid nearest its centre, random right-armed "
           "starts and targets (tip model: tips > 2.1 / 3.0 mm apart; segment model: capsules "
           "clear by margin + 0.05 / + 0.5 mm at buffer 2.5 mm), lambda1 = 1, lambda2 = 0.05, "
           "dt 10 ms, tol 100 um, 30 deg/s, max 60 s. Counts are means over the runs "
           "(individual runs in brackets). Paper: one run per N, lambda3 0.03 (0.04 for "
           "730 and 980). `excess`: smallest model distance minus d over all runs (>= 0: "
           "never closer than d). Kernel: mean seconds per run.", "",
           "| model | N | paper APF | paper CAPF | APF | CAPF 0.03 | CAPF 0.04 | APF kernel s | CAPF kernel s | motion s APF / CAPF | excess mm | guard APF / CAPF |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p = PAPER_TABLE1.get(r["n"], ("-", "-", None))
        a, c3, c4 = r["APF"], r["CAPF 0.03"], r["CAPF 0.04"]

        def cnt(x):
            runs = "" if len(x["conv_all"]) == 1 else f" [{', '.join(map(str, x['conv_all']))}]"
            return f"{x['conv']:.1f}{runs}"

        out.append(f"| {r['model']} | {r['n']} | {p[0]} | {p[1]} (l3 {p[2]}) | {cnt(a)} | {cnt(c3)} | "
                   f"{cnt(c4)} | {a['kernel']:.2f} | {c3['kernel']:.2f} | {a['motion']:.1f} / "
                   f"{c3['motion']:.1f} | {min(a['min_excess'], c3['min_excess'], c4['min_excess']):.4f} | "
                   f"{a['guard']} / {c3['guard']} |")
    out.append("")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", choices=("makarem", "macktoobian", "all"), default="all")
    ap.add_argument("--runs", type=int, default=100, help="Makarem runs per N (paper: 100)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[37, 127, 547, 1027, 2107, 4921],
                    help="Makarem grid sizes (centred hex counts)")
    ap.add_argument("--gains", type=float, nargs="+", default=[1.0, 10.0])
    ap.add_argument("--start-sep", type=float, default=2.1)
    ap.add_argument("--target-sep", type=float, default=3.0)
    ap.add_argument("--mack-runs", type=int, default=3, help="Macktoobian runs per N (paper: 1)")
    ap.add_argument("--mack-sizes", type=int, nargs="+", default=sorted(PAPER_TABLE1))
    ap.add_argument("--models", nargs="+", choices=("tip", "segment"), default=["tip", "segment"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--md-out", default=None, help="also write the markdown block to this file")
    args = ap.parse_args(argv)

    lines = ["<!-- bench:begin -->", "",
             f"Command: `{command_line()}`", "",
             f"Machine: {cpu_model()}, Python {python_version()}, load {load_average()} "
             f"(at start), {now()}", ""]
    t0 = time.perf_counter()
    if args.only in ("makarem", "all"):
        lines += md_makarem(run_makarem(args.sizes, args.runs, args.gains, args.seed,
                                        args.start_sep, args.target_sep), args)
    if args.only in ("macktoobian", "all"):
        lines += md_macktoobian(run_macktoobian(args.mack_sizes, args.mack_runs, args.models,
                                                args.seed), args)
    lines += [f"Wall time {time.perf_counter() - t0:.0f} s, load {load_average()} (at end).", "",
              "<!-- bench:end -->"]
    write_block("\n".join(lines), args.md_out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
