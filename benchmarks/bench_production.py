"""The production question: SDSS-V's flow against ours on the same targets, same instrument.

For each instrument and seed, the seeded random targets of ``rfp-twin plan --seed S`` are
sent through

- **twin**: our pipeline (planner + deadlock resolution + post-processing verified at
  buffer - budget), ``rfp-twin plan``;
- **jaeger**: SDSS-V's controller flow as the twin replays it (:mod:`rfp_twin.twin.jaeger_flow`:
  decollide, plan without resolution, 5 retries moving a deadlocked robot's target,
  getPathPair smoothing at 2 RPM, no re-check), ``rfp-twin plan --flow jaeger``,
  with the planner given by ``--jaeger-algorithm``.

Per run: targets kept, the unfold's duration (firmware-ready; production's in its own
2 RPM timing), the smallest 2D clearance under production's rule (every robot with the
spec's segment) at the buffer, whether it breaks the buffer and buffer - 0.08 mm
(collision shrink), and with ``--3d`` the smallest 3D distance of the default geometry
(FCL). Prints a markdown table of medians / counts per instrument and flow; ``--csv``
writes the per-run rows.

    .venv/bin/python benchmarks/bench_production.py --instruments sdss-v-apo sdss-v-lco --seeds 50
"""
from __future__ import annotations

import argparse
import csv
import time

import numpy as np

from bench_common import machine_info, md_table, write_block


def run_twin(rc, seed: int, production_layout) -> dict:
    from rfp_twin.validation.checker2d import check_trajectory

    outcome = rc.run(seed=seed)
    prod = check_trajectory(outcome.trajectory, rc.spec, production_layout, rc.spec.buffer_mm)
    kept = int(np.sum(outcome.plan.status == "reached"))
    return {"kept": kept, "duration_s": outcome.trajectory.duration,
            "clearance_mm": prod.min_clearance_mm, "breaks_buffer": not prod.ok,
            "breaks_shrunk": False, "trajectory": outcome.trajectory, "attempts": 1}


def run_jaeger(rc, seed: int, algorithm: str) -> dict:
    from rfp_twin.twin.jaeger_flow import jaeger_flow

    rng = np.random.default_rng(seed)
    targets = rc.random_targets(rng)
    flow = jaeger_flow(rc.geom, targets, rng, algorithm=algorithm)
    b = rc.spec.buffer_mm
    shrunk = b - flow.settings.collision_shrink_mm
    at_b, at_s = flow.checks[f"production@{b:g}"], flow.checks[f"production@{shrunk:g}"]
    return {"kept": rc.geom.n_robots - flow.n_lost, "duration_s": flow.trajectory.duration,
            "clearance_mm": at_b.min_clearance_mm, "breaks_buffer": not at_b.ok,
            "breaks_shrunk": not at_s.ok, "trajectory": flow.trajectory,
            "attempts": flow.attempts}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instruments", nargs="+", default=["sdss-v-apo", "sdss-v-lco"])
    ap.add_argument("--seeds", type=int, default=50, help="seeds 1..N per instrument")
    ap.add_argument("--buffer", type=float, default=2.0)
    ap.add_argument("--jaeger-algorithm", default="greedy",
                    help="planner of the jaeger flow (production: mdp2 where available)")
    ap.add_argument("--3d", dest="three_d", action="store_true",
                    help="also the smallest 3D distance (default geometry, FCL)")
    ap.add_argument("--csv", default=None, help="write the per-run rows here")
    ap.add_argument("--md-out", default=None)
    args = ap.parse_args()

    from rfp_twin.models.layout.columns import production_body_layout
    from rfp_twin.models.robot import load_spec
    from rfp_twin.twin.pipeline import Reconfiguration

    rows, table = [], []
    spec = load_spec("sdss-v-production").with_overrides(buffer_mm=args.buffer)
    clock = time.perf_counter()
    for name in args.instruments:
        rc = Reconfiguration.from_names(spec, name)
        production = production_body_layout(rc.layout)
        if args.three_d:
            from rfp_twin.models.geometry import geometry_for_spec
            from rfp_twin.validation.mesh3d import LinkModels, validate_trajectory
            links = LinkModels.from_geometry(geometry_for_spec(spec))
        per_flow: dict[str, list[dict]] = {"twin": [], "jaeger": []}
        for seed in range(1, args.seeds + 1):
            for flow in ("twin", "jaeger"):
                try:
                    r = run_twin(rc, seed, production) if flow == "twin" else \
                        run_jaeger(rc, seed, args.jaeger_algorithm)
                except Exception as exc:          # a failed configuration is a result
                    r = {"kept": 0, "duration_s": float("nan"), "clearance_mm": float("nan"),
                         "breaks_buffer": False, "breaks_shrunk": False, "failed": str(exc),
                         "attempts": 0}
                traj = r.pop("trajectory", None)
                if args.three_d and traj is not None:
                    rep = validate_trajectory(traj, spec, rc.layout, links)
                    r["min_3d_mm"] = rep.min_distance_mm
                r.update(instrument=name, seed=seed, flow=flow)
                per_flow[flow].append(r)
                rows.append(r)
        for flow, rs in per_flow.items():
            ok = [r for r in rs if "failed" not in r]
            kept = np.array([r["kept"] for r in rs])
            table.append([name, flow, str(len(rs)), str(len(rs) - len(ok)),
                          f"{np.median(kept):.0f} ({kept.min()}-{kept.max()})",
                          f"{np.nanmedian([r['duration_s'] for r in ok]):.2f}" if ok else "-",
                          f"{np.nanmin([r['clearance_mm'] for r in ok]):.4f}" if ok else "-",
                          str(sum(r["breaks_buffer"] for r in ok)),
                          str(sum(r["breaks_shrunk"] for r in ok)),
                          (f"{np.nanmin([r['min_3d_mm'] for r in ok]):.3f}"
                           if args.three_d and ok else "-")])
    header = ["instrument", "flow", "runs", "failed", "targets kept median (range)",
              "unfold s median", "min 2D clearance, production rule, mm",
              f"runs breaking {args.buffer:g} mm", "runs breaking buffer - 0.08 mm",
              "min 3D distance mm"]
    text = "\n".join([f"`{' '.join(['.venv/bin/python', 'benchmarks/bench_production.py'])} "
                      f"--instruments {' '.join(args.instruments)} --seeds {args.seeds} "
                      f"--jaeger-algorithm {args.jaeger_algorithm}"
                      f"{' --3d' if args.three_d else ''}`", "",
                      md_table(header, table), "",
                      f"{machine_info('numba')}; wall {time.perf_counter() - clock:.0f} s"])
    write_block(text, args.md_out)
    if args.csv:
        keys = sorted({k for r in rows for k in r})
        with open(args.csv, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys)
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
