"""The CLI on probe arms (MIRADAS, Sabater et al. 2018): plan, validate, simulate, render, record.

:func:`plan_probe_cli` (``rfp-twin plan --preset miradas-probe``) runs
:func:`rfp_twin.twin.probe_run.plan_probe_bench`, writes the run folder and prints the
plan in the form of the paper's Tables 1-2 with the independent check's verdict. The
other commands take such a run folder (:func:`rfp_twin.twin.probe_files.is_probe_run`):
``validate`` (2D and FCL 3D checks), ``simulate`` (MuJoCo bench), ``render`` (MP4),
``record`` (rerun). Bad input: one line, exit 2; a contact: exit 4.
"""
from __future__ import annotations

import time
from pathlib import Path

from rfp_twin.twin.cli.console import EXIT_COLLISION, EXIT_INCOMPLETE, console, fail


def plan_probe_cli(preset: str, layout: str | None, algorithm: str, seed: int,
                   n_targets: int | None, out: Path, force: bool,
                   targets: Path | None = None) -> None:
    """Plan, check, write ``out`` and print; a failed plan or check exits non-zero with
    nothing written."""
    from rfp_twin.twin.probe_run import plan_probe_bench, write_probe_run

    t0 = time.perf_counter()
    run = plan_probe_bench(preset, layout, seed=seed, n_targets=n_targets, algorithm=algorithm,
                           targets=targets)
    wall = time.perf_counter() - t0
    console.print(run.plan.tables(), markup=False, highlight=False)
    if not run.plan.success:
        raise fail(f"arm {run.plan.failed_arm} found no trajectory within "
                   f"{run.plan.settings.horizon_s:g} s ({run.plan.passes} prioritized passes); "
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


# -- run folders of probe arms: validate, simulate, render, record ---------------------
def _run(folder: Path):
    from rfp_twin.twin.probe_files import load_probe_run

    return load_probe_run(folder)


def validate_probe_cli(folder: Path, out: Path | None) -> None:
    """The 2D check (every 0.01 s) and the FCL 3D check (every 0.1 s) of a probe run;
    writes ``validation.json``; exit 4 on any contact."""
    import json

    from rfp_twin.models.files import atomic_write_text
    from rfp_twin.validation.probe import check_probe_plan, check_probe_plan_3d

    run = _run(folder)
    spec = run.kind.spec
    c2 = check_probe_plan(spec, run.breakpoints, dt_s=0.01, max_start_stop=1)
    c3 = check_probe_plan_3d(spec, run.breakpoints, dt_s=0.1)
    path = out if out is not None else Path(folder) / "validation.json"
    from dataclasses import asdict

    atomic_write_text(path, json.dumps({"run": str(folder), "check2d": asdict(c2),
                                        "check3d": asdict(c3)}, indent=2, default=str))
    console.print(f"2D check (every {c2.dt_s:g} s): {'clear' if c2.ok else 'FAIL'}, min gap "
                  f"{c2.min_gap_mm:.2f} mm, {len(c2.contacts)} contact(s), {len(c2.zoa)} ZoA "
                  f"sample(s), {len(c2.too_fast)} too fast, most start-stop cycles "
                  f"{max(c2.start_stop.values())}", markup=False, highlight=False)
    console.print(f"3D check (FCL, every {c3.dt_s:g} s): {'clear' if c3.ok else 'FAIL'}, min "
                  f"distance {c3.min_distance_mm:.2f} mm ({c3.n_queries} FCL queries), "
                  f"{len(c3.contacts)} contact(s); wrote {path}", markup=False, highlight=False)
    if not (c2.ok and c3.ok):
        raise fail(f"the probe plan fails the {'2D' if not c2.ok else '3D'} check; see {path}",
                   EXIT_COLLISION)


def simulate_probe_cli(folder: Path, settle_s: float = 1.0) -> None:
    """Run a probe plan in the MuJoCo bench; writes ``sim.json``; exit 4 on any contact."""
    import json
    from dataclasses import asdict

    from rfp_twin.models.files import atomic_write_text
    from rfp_twin.twin.sim.probe import simulate_probe_plan

    run = _run(folder)
    rep = simulate_probe_plan(run, settle_s=settle_s)
    path = Path(folder) / "sim.json"
    atomic_write_text(path, json.dumps({**asdict(rep), "ok": rep.ok}, indent=2, default=str))
    console.print(f"MuJoCo: {rep.duration_s:g} s in {rep.steps} steps ({rep.wall_s:.1f} s wall): "
                  f"{rep.n_contact_steps} contact step(s), tracking <= {rep.max_tracking_deg:.3f} "
                  f"deg, loop gap <= {rep.max_loop_gap_mm:.4f} mm; wrote {path}",
                  markup=False, highlight=False)
    if not rep.ok:
        raise fail(f"{rep.n_contact_steps} step(s) with contacts or {len(rep.warnings)} MuJoCo "
                   f"warning(s) in simulation; see {path}", EXIT_COLLISION)


def render_probe_cli(folder: Path, out: Path, width: int, height: int, fps: float,
                     speedup: float) -> None:
    """Render a probe plan to MP4 (top view of the bench)."""
    from rfp_twin.twin.render.probe import render_probe_plan

    path = render_probe_plan(_run(folder), out, fps=fps, speedup=speedup, width=width,
                             height=height)
    console.print(f"wrote {path}", markup=False, highlight=False)


def record_probe_cli(folder: Path, out: Path, dt: float | None) -> None:
    """Simulate a probe plan and write a rerun recording of it."""
    from rfp_twin.twin.record_probe import record_probe_plan
    from rfp_twin.twin.sim.probe import simulate_probe_plan

    run = _run(folder)
    rep = simulate_probe_plan(run)
    path = record_probe_plan(run, out, dt_s=0.5 if dt is None else dt, sim_report=rep)
    console.print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB); open it with `rerun "
                  f"{path}`", markup=False, highlight=False)
