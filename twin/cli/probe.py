"""``rfp-twin plan`` on a probe-arm preset (MIRADAS, Sabater et al. 2018).

:func:`plan_probe_cli` runs :func:`rfp_twin.twin.probe_run.plan_probe_bench`, writes the
run folder and prints the plan in the form of the paper's Tables 1-2 with the
independent check's verdict.
"""
from __future__ import annotations

import time
from pathlib import Path

from rfp_twin.twin.cli.console import EXIT_COLLISION, EXIT_INCOMPLETE, console, fail


def plan_probe_cli(preset: str, layout: str | None, algorithm: str, seed: int,
                   n_targets: int | None, out: Path, force: bool) -> None:
    """Plan, check, write ``out`` and print; a failed plan or check exits non-zero with
    nothing written."""
    from rfp_twin.twin.probe_run import plan_probe_bench, write_probe_run

    t0 = time.perf_counter()
    run = plan_probe_bench(preset, layout, seed=seed, n_targets=n_targets, algorithm=algorithm)
    wall = time.perf_counter() - t0
    console.print(run.plan.tables(), markup=False, highlight=False)
    if not run.plan.success:
        raise fail(f"arm {run.plan.failed_arm} found no trajectory within "
                   f"{run.plan.settings.horizon_s:g} s (prioritized planning, one pass); "
                   "nothing written", EXIT_INCOMPLETE)
    c = run.check
    if not c.ok:
        raise fail(f"the plan fails the probe-arm 2D check: {len(c.contacts)} contact(s), "
                   f"{len(c.zoa)} ZoA sample(s), {len(c.too_fast)} too fast; nothing written",
                   EXIT_COLLISION)
    write_probe_run(run, out, overwrite=force)
    console.print(f"planning {run.plan.seconds:.3f} s ({wall:.2f} s with targets and check); "
                  f"2D check clear at {c.dt_s:g} s, min gap {c.min_gap_mm:.2f} mm; -> {out}",
                  markup=False, highlight=False)
