#!/usr/bin/env python
"""3D validation (FCL) and buffer-calibration benchmarks (issue #4).

Run from the repository root::

    .venv/bin/python benchmarks/bench_validate.py [--seeds 1 2 3] [--repeat 3]
                                                  [--layout sdss-v-547|sdss-v-fps]
                                                  [--only validate|calibrate|all]
                                                  [--calib-out DIR]
                                                  [--append-results FILE]

Sections
--------
1. ``validate``: a full fold, made by the pipeline as ``rfp-twin plan --layout
   sdss-v-547 --resolve replace --seed S`` makes it (:meth:`rfp_twin.twin.pipeline.Reconfiguration.run`:
   preset ``sdss-v``, the paper's 547-robot grid, buffer 2.5 mm, greedy reverse plan at
   0.1 deg with target replacement, then firmware-ready trajectories, checked in 2D),
   played targets -> fold. Each fold is
   checked with :func:`rfp_twin.validation.mesh3d.validate_trajectory` against the preset's
   collision meshes: the first call of the process is printed as *cold* (numba cache
   load, or compilation after a source change), then ``--repeat`` warm calls, of which
   the median is reported, split into *broadphase* (candidate pairs + lower bounds in
   numba) and *exact* (FCL distances and their bookkeeping), with the number of lower
   bounds, exact link distances and FCL calls. Target: <= 10 s.
2. ``calibrate``: :func:`rfp_twin.validation.buffer.calibrate_buffer` with its defaults for the
   ``sdss-v`` preset (the command ``rfp-twin calibrate-buffer --preset sdss-v``): run
   time per stage, sample counts, and the results. Target: < 5 minutes.

Prints progress, then a markdown block to paste into benchmarks/RESULTS.md (a table of
current figures kept by hand); ``--append-results FILE`` only adds a line saying to paste
it into FILE: nothing is written.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_common import command_line, load_average, machine_info, paste_note
from rfp_twin.models.errors import LayoutError, PlanningError
from rfp_twin.models.geometry import geometry_for_spec
from rfp_twin.models.robot import load_spec
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
from rfp_twin.validation.buffer import calibrate_buffer, write_report
from rfp_twin.validation.mesh3d import LinkModels, validate_trajectory

TARGET_VALIDATE_S = 10.0
TARGET_CALIBRATE_S = 300.0


def make_fold(layout_name: str, seed: int, step_deg: float = 0.1):
    """The fold (targets -> folded) as `rfp-twin plan --resolve replace` writes it:
    (spec, layout, trajectory, seconds of planning + post-processing)."""
    try:
        rc = Reconfiguration.from_names("sdss-v", layout_name,
                                        options=PlanOptions(step_deg=step_deg, resolve="replace"))
    except LayoutError as exc:
        raise SystemExit(f"--layout: {exc}") from None
    out = rc.run(seed=seed)
    return rc.spec, rc.layout, out.trajectory.reversed(), out.seconds["plan"] + out.seconds["deliver"]


def bench_validate(layout_name: str, seeds, repeat: int) -> list[str]:
    print(f"== validate: {layout_name}, seeds {list(seeds)}, {repeat} warm repeats", flush=True)
    rows = []
    cold = None
    models = None
    skipped = []
    for seed in seeds:
        try:
            spec, lay, fold, t_plan = make_fold(layout_name, seed)
        except PlanningError as exc:       # the planner, not the validator, gave up
            print(f"  seed {seed}: no fold ({exc})", flush=True)
            skipped.append(seed)
            continue
        if models is None:
            t0 = time.perf_counter()
            models = LinkModels.from_geometry(geometry_for_spec(spec))
            t_models = time.perf_counter() - t0
            t0 = time.perf_counter()
            rep = validate_trajectory(fold, spec, lay, models)
            cold = (time.perf_counter() - t0, rep)
            print(f"  cold call (seed {seed}): {cold[0]:.2f} s (broadphase "
                  f"{rep.seconds_broadphase:.2f}, exact {rep.seconds_exact:.2f}); FCL models "
                  f"built in {t_models:.3f} s", flush=True)
        runs = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            rep = validate_trajectory(fold, spec, lay, models)
            runs.append((time.perf_counter() - t0, rep))
        walls = [r[0] for r in runs]
        k = int(np.argsort(walls)[len(walls) // 2])
        wall, rep = runs[k]
        rows.append((seed, t_plan, fold, wall, rep, walls))
        print(f"  seed {seed}: plan {t_plan:.1f} s, fold {fold.duration:.2f} s; validate median "
              f"{wall:.2f} s [{min(walls):.2f}-{max(walls):.2f}] = broadphase "
              f"{rep.seconds_broadphase:.2f} + exact {rep.seconds_exact:.2f}; {rep.n_pairs} pairs "
              f"({rep.n_link_pairs} link pairs), {rep.n_capsule_evals} bounds, "
              f"{rep.n_exact_evals} exact ({rep.n_fcl_calls} FCL calls, {rep.n_gjk_calls} GJK); min distance "
              f"{rep.min_distance_mm:.4f} mm; {len(rep.collisions)} collisions", flush=True)
    md = [f"### 3D validation of a full fold ({layout_name}, preset sdss-v, buffer 2.5 mm)", "",
          f"Fold as `rfp-twin plan --layout {layout_name} --resolve replace --seed S` writes it "
          "(the pipeline: greedy reverse, 0.1 deg, target replacement, firmware-ready "
          "trajectories), played targets -> fold; "
          f"median of {repeat} warm calls of `validate_trajectory` (the process's first call, "
          "cold, is listed separately).", "",
          "| seed | robots | fold s | pairs (link pairs) | validate s | broadphase s | exact s | "
          "lower bounds | exact distances | FCL calls (GJK) | min 3D distance mm | 3D collisions |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for seed, t_plan, fold, wall, rep, walls in rows:
        md.append(f"| {seed} | {rep.n_robots} | {fold.duration:.2f} | {rep.n_pairs} "
                  f"({rep.n_link_pairs}) | **{wall:.2f}** [{min(walls):.2f}-{max(walls):.2f}] | "
                  f"{rep.seconds_broadphase:.2f} | {rep.seconds_exact:.2f} | "
                  f"{rep.n_capsule_evals} | {rep.n_exact_evals} | {rep.n_fcl_calls} ({rep.n_gjk_calls}) | "
                  f"{rep.min_distance_mm:.4f} | {len(rep.collisions)} |")
    if skipped:
        md += ["", f"Seeds without a fold (post-processing raised PlanningError): {skipped}."]
    md += ["", f"Cold first call (seed {rows[0][0]}): {cold[0]:.2f} s (broadphase "
           f"{cold[1].seconds_broadphase:.2f} s, exact {cold[1].seconds_exact:.2f} s). "
           f"Target <= {TARGET_VALIDATE_S:g} s: "
           f"{'met' if max(r[3] for r in rows) <= TARGET_VALIDATE_S else 'NOT met'}.", ""]
    return md


def bench_calibrate(out_dir: Path | None) -> list[str]:
    print("== calibrate: sdss-v defaults", flush=True)
    spec = load_spec("sdss-v")
    t0 = time.perf_counter()
    last = [0.0]

    def prog(stage, frac):
        now = time.perf_counter()
        if now - last[0] > 10:
            last[0] = now
            print(f"  {stage} {100 * frac:.0f}% ({now - t0:.0f} s)", flush=True)

    cal = calibrate_buffer(spec, progress=prog)
    wall = time.perf_counter() - t0
    out = out_dir or Path(tempfile.mkdtemp(prefix="rfp-calib-"))
    paths = write_report(cal, out, command="rfp-twin calibrate-buffer --preset sdss-v")
    print(cal.table(), flush=True)
    print(f"  wall {wall:.1f} s; report {paths['markdown']}", flush=True)
    w = cal.worst
    st = cal.seconds
    md = ["### Buffer calibration, preset sdss-v (defaults of `rfp-twin calibrate-buffer`)", "",
          f"{cal.n_samples} uniform (Sobol) configurations over 3 neighbour directions at "
          f"{cal.pitch_mm:g} mm, {cal.n_boundary} boundary configurations, {cal.n_draws} Monte "
          f"Carlo draws (errors uniform in +-{cal.angular_error_deg[0]:g} / "
          f"+-{cal.angular_error_deg[1]:g} deg), seed {cal.seed}; {cal.n_fcl_calls} FCL calls.", "",
          "| quantity | value |", "|---|---|",
          f"| (a) smallest buffer with 2D-safe => 3D-safe, b* | **{cal.safe_buffer_mm:.4f} mm** "
          f"(uniform samples alone {cal.safe_buffer_uniform_mm:.4f}; mesh envelope "
          f"{cal.envelope_mm:.4f}) |",
          f"| worst configuration | A ({w['alpha_a']:.3f}, {w['beta_a']:.3f}) deg, B "
          f"({w['alpha_b']:.3f}, {w['beta_b']:.3f}) deg, direction {w['direction_deg']:g} deg, "
          f"D2 {w['d2_mm']:.4f} mm, {w['links']} contact |",
          f"| (b) 2D-forbidden space that is 3D-safe, at 1.5 / 2.0 / 2.5 / 3.5 mm | "
          f"{cal.wasted_at(1.5):.3f} / {cal.wasted_at(2.0):.3f} / {cal.wasted_at(2.5):.3f} / "
          f"{cal.wasted_at(3.5):.3f} |",
          f"| (c) buffer keeping 3D safety with p = {cal.probability:g}, b_p | "
          f"**{cal.mc_buffer_mm:.4f} mm** (angular-error share {cal.mc_share_mm:.4f} mm) |",
          f"| worst corner error share | {cal.corner_share_mm:.4f} mm |",
          f"| paper's analytic sigma_eps (Eq. 12) | {cal.paper_sigma_eps_mm:.4f} mm |",
          f"| run time | **{wall:.1f} s** (uniform 3D {st['uniform_3d']:.1f}, boundary "
          f"{st['boundary']:.1f}, Monte Carlo {st['monte_carlo']:.1f}, scatter "
          f"{st['scatter']:.1f}) |", "",
          f"Target < {TARGET_CALIBRATE_S:g} s: {'met' if wall < TARGET_CALIBRATE_S else 'NOT met'}.",
          ""]
    return md


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--layout", default="sdss-v-547", help="sdss-v-547 | sdss-v-fps (or hex:N)")
    ap.add_argument("--only", choices=("validate", "calibrate", "all"), default="all")
    ap.add_argument("--calib-out", type=Path, default=None)
    ap.add_argument("--append-results", type=Path, default=None, metavar="FILE",
                    help="say to paste the markdown block into FILE (nothing is written)")
    args = ap.parse_args()

    machine = machine_info("numba", "fcl")
    print(f"machine: {machine}")
    print(f"command: {command_line()}", flush=True)
    t0 = time.perf_counter()
    md = ["## 3D validation (FCL) and buffer calibration (issue #4)", "",
          f"Command: `{command_line()}`", "", f"Machine: {machine}.", ""]
    if args.only in ("validate", "all"):
        md += bench_validate(args.layout, args.seeds, args.repeat)
    if args.only in ("calibrate", "all"):
        md += bench_calibrate(args.calib_out)
    md += [f"Wall time {time.perf_counter() - t0:.0f} s, load {load_average()} (at end).", ""]
    text = "\n".join(md)
    print("\n" + text)
    paste_note(args.append_results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
