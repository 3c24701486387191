"""``rfp-twin plan --flow jaeger``: SDSS-V's configuration flow instead of ours.

Runs :func:`rfp_twin.twin.jaeger_flow.jaeger_flow` on the targets (seeded random or a
CSV), writes the run folder of what SDSS-V's controller would send (``trajectories.json``:
the production-smoothed unfold) with the flow's record in ``summary.json`` (``flow``), and
prints the targets lost, the retries and the 2D checks under our rule and production's.
Exit 4 when the trajectory fails the check under production's own rule at buffer -
collision shrink: the folder is still written, it is the measurement.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from rfp_twin.twin.cli.console import EXIT_COLLISION, fail, print_rows, progress_bar


def run_jaeger_flow(rc, seed: int, targets, out: Path, force: bool, *, algorithm: str,
                    greed: float, phobia: float, step: float) -> None:
    """The flow on Reconfiguration ``rc``'s array (its offline robots kept)."""
    from rfp_twin.twin.jaeger_flow import jaeger_flow
    from rfp_twin.twin.run_dir import write_run

    rng = np.random.default_rng(seed)
    tg = rc.random_targets(rng) if targets is None else targets
    with progress_bar("jaeger flow") as progress:
        progress.add_task(f"{rc.geom.n_robots} robots, {algorithm}", total=None)
        flow = jaeger_flow(rc.geom, tg, rng, offline=rc.offline, algorithm=algorithm,
                           greed=greed, phobia=phobia, step_deg=step)
    shrunk = rc.geom.buffer_mm - flow.settings.collision_shrink_mm
    verdict = flow.checks[f"production@{shrunk:g}"]
    summary = {"command": None, "spec": rc.spec.source, "robot": rc.spec.name,
               "layout": rc.layout.name, "n_robots": rc.geom.n_robots,
               "buffer_mm": rc.geom.buffer_mm, "algorithm": algorithm, "seed": seed,
               "offline": sorted(rc.offline), "metrics": dict(flow.plan.metrics),
               "duration_s": flow.trajectory.duration,
               "trajectories": "SDSS-V production (getPathPair)", **flow.summary()}
    summary["command"] = "rfp-twin " + " ".join(__import__("sys").argv[1:])
    write_run(out, spec=rc.spec, layout=rc.layout, plan=flow.plan, trajectory=flow.trajectory,
              summary=summary, check2d=verdict.to_dict(), overwrite=force)
    rows = [("robots (offline)", f"{rc.geom.n_robots} ({len(rc.offline)})"),
            ("planner / plans made", f"{algorithm} / {flow.attempts}"),
            ("targets lost (decollided + unlocked)",
             f"{flow.n_lost} ({len(flow.decollided)} + {len(flow.unlocked)})"),
            ("unfold (production timing)", f"{flow.trajectory.duration:.2f} s + "
                                           f"{flow.settings.path_delay_s:g} s delay")]
    for name, c in flow.checks.items():
        rule, buf = name.split("@")
        rows.append((f"2D check, {'our' if rule == 'twin' else rule} rule at {buf} mm",
                     ("clear" if c.ok else f"{len(c.collisions)} collision(s)")
                     + f", min clearance {c.min_clearance_mm:.4f} mm"))
    rows.append(("wall time", f"{flow.seconds['total']:.2f} s"))
    print_rows(f"rfp-twin plan --flow jaeger -> {out}", rows)
    if not verdict.ok:
        raise fail(f"the production trajectory collides under production's own rule at "
                   f"{shrunk:g} mm ({len(verdict.collisions)} collision(s)); written to {out}",
                   EXIT_COLLISION)
