"""``rfp-twin unwind`` and ``rfp-twin explode``: recovery moves from the robots' current poses.

POSES is a run folder (its trajectory's end: where that run left the robots) or a CSV of
current angles (``robot_id,alpha_deg,beta_deg``; ``--encoder`` for encoder angles) with
``--preset`` and ``--layout`` / ``--calibration``. The motion is written as a run folder
(``trajectories.json``: start -> end) that ``validate``, ``simulate``, ``render`` and
``record`` read like any other. Exit codes: 0 done, 2 bad input, 3 robots left short of
the fold (unwind; the folder is written), 4 a collision in the motion (nothing written).
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from rfp_twin.twin.cli.console import (EXIT_COLLISION, EXIT_INCOMPLETE, console, fail,
                                       one_line_errors, progress_bar)
from rfp_twin.twin.cli.layout_option import CALIBRATION_HELP, LAYOUT_HELP, chosen_layout

POSES_HELP = ("Run folder (its trajectory's end) or CSV of current angles "
              "(robot_id,alpha_deg,beta_deg).")
OFFLINE_HELP = "Offline robot ids (comma-separated or repeated): they stay where they stand."


def _array(poses: Path, preset: Optional[str], layout: Optional[str],
           calibration: Optional[Path], buffer: Optional[float], encoder: bool):
    """``(ArrayGeometry, poses (n, 2) model deg)`` from a run folder or a CSV."""
    from rfp_twin.models.array import ArrayGeometry
    from rfp_twin.models.errors import TargetError
    from rfp_twin.models.layout import layout_by_name
    from rfp_twin.models.robot import load_spec
    from rfp_twin.twin.recovery import poses_from_csv, poses_from_run

    if poses.is_dir():
        if layout is not None or calibration is not None or encoder:
            raise TargetError(f"{poses}: a run folder carries its own layout and model angles; "
                              "allowed: --layout, --calibration and --encoder with a CSV only")
        spec, lay, angles = poses_from_run(poses)
        if preset is not None:
            spec = load_spec(preset)
    else:
        spec = load_spec(preset or "sdss-v-production")
        lay = layout_by_name(chosen_layout(layout, calibration, spec), spec.pitch_mm)
        angles = None
    if buffer is not None:
        spec = spec.with_overrides(buffer_mm=buffer)
    geom = ArrayGeometry(spec, lay, spec.buffer_mm)
    if angles is None:
        angles = poses_from_csv(poses, geom, encoder=encoder)
    return geom, angles


def _offline_ids(items: list[str]) -> list[int]:
    from rfp_twin.twin.cli.plan import parse_ids

    return [i for item in items for i in parse_ids(item, "--offline")]


def _report(title: str, outcome, out: Path) -> None:
    m = outcome.plan.metrics
    t = Table(title=f"{title} -> {out}")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    rows = [("robots (offline)", f"{outcome.geom.n_robots} "
                                 f"({int((outcome.plan.status == 'offline').sum())})"),
            ("buffer", f"{outcome.geom.buffer_mm:g} mm"),
            ("smallest clearance at start", f"{m['min_clearance_start_mm']:.3f} mm")]
    if "min_clearance_end_mm" in m:
        rows += [("smallest clearance at end", f"{m['min_clearance_end_mm']:.3f} mm"),
                 ("robots moved", str(m["n_moved"])),
                 ("collisions at start / new", f"{len(outcome.start_collisions)} / "
                                               f"{len(outcome.new_collisions)}")]
    else:
        rows += [("deadlocked", str(outcome.n_deadlocked)),
                 ("stepwise / firmware-ready", f"{outcome.plan.n_steps * outcome.plan.step_s:.2f}"
                                               f" / {outcome.trajectory.duration:.2f} s")]
    rows += [("2D check", f"min clearance {outcome.check.min_clearance_mm:.4f} mm"),
             ("wall time", f"{outcome.seconds:.2f} s")]
    for r in rows:
        t.add_row(*r)
    console.print(t)


@one_line_errors
def unwind(
    poses: Path = typer.Argument(..., help=POSES_HELP),
    preset: Optional[str] = typer.Option(None, help="Robot preset or TOML [default: the run's, "
                                         "else sdss-v-production]."),
    layout: Optional[str] = typer.Option(None, help=LAYOUT_HELP),
    calibration: Optional[Path] = typer.Option(None, help=CALIBRATION_HELP),
    buffer: Optional[float] = typer.Option(None, help="Collision buffer, mm [default: preset]."),
    encoder: bool = typer.Option(False, help="The CSV holds encoder angles."),
    offline: list[str] = typer.Option([], help=OFFLINE_HELP),
    algorithm: str = typer.Option("greedy", help="greedy | markov (stepwise planner)."),
    resolve: bool = typer.Option(True, help="Resolve deadlocks as every plan does (the poses "
                                 "kept as targets); --no-resolve stops at the first deadlock, "
                                 "as SDSS-V's controller unwinds."),
    greed: float = typer.Option(0.9, help="Markov greed, [0, 1]."),
    phobia: float = typer.Option(0.3, help="Markov phobia, [0, 1]."),
    seed: int = typer.Option(0, help="Seed of the Markov moves."),
    step: float = typer.Option(0.1, help="Angular step, deg."),
    out: Path = typer.Option(Path("out/unwind"), help="Output run folder."),
    force: bool = typer.Option(False, help="Replace an existing output folder."),
) -> None:
    """Fold every robot from where it stands; robots left deadlocked stop short (exit 3)."""
    from rfp_twin.models.errors import RfpError
    from rfp_twin.twin.recovery import movable_mask, unwind as run_unwind
    from rfp_twin.twin.run_dir import check_output_folder

    check_output_folder(out, force)
    if algorithm not in ("greedy", "markov"):
        raise RfpError(f"--algorithm {algorithm!r}; allowed: greedy, markov")
    geom, angles = _array(poses, preset, layout, calibration, buffer, encoder)
    with progress_bar("unwind") as progress:
        progress.add_task(f"{geom.n_robots} robots", total=None)
        outcome = run_unwind(geom, angles, movable_mask(geom, _offline_ids(offline)),
                             step_deg=step, algorithm=algorithm, greed=greed, phobia=phobia,
                             resolve=resolve, seed=seed)
    if outcome.new_collisions or outcome.start_collisions:
        raise fail(f"the unwind fails the 2D check: {len(outcome.check.collisions)} "
                   "collision(s); nothing written", EXIT_COLLISION)
    outcome.write(out, overwrite=force)
    _report("rfp-twin unwind", outcome, out)
    if outcome.n_deadlocked:
        raise fail(f"{outcome.n_deadlocked} robot(s) deadlocked short of the fold; the motion "
                   f"up to the deadlock is in {out}", EXIT_INCOMPLETE)


@one_line_errors
def explode(
    poses: Path = typer.Argument(..., help=POSES_HELP),
    preset: Optional[str] = typer.Option(None, help="Robot preset or TOML [default: the run's, "
                                         "else sdss-v-production]."),
    layout: Optional[str] = typer.Option(None, help=LAYOUT_HELP),
    calibration: Optional[Path] = typer.Option(None, help=CALIBRATION_HELP),
    buffer: Optional[float] = typer.Option(None, help="Collision buffer, mm [default: preset]."),
    encoder: bool = typer.Option(False, help="The CSV holds encoder angles."),
    offline: list[str] = typer.Option([], help=OFFLINE_HELP),
    degrees: float = typer.Option(20.0, help="Travel of the explosion, deg (> 0)."),
    robot: Optional[int] = typer.Option(None, help="Explode this robot alone [default: all]."),
    step: float = typer.Option(0.1, help="Angular step, deg."),
    out: Path = typer.Option(Path("out/explode"), help="Output run folder."),
    force: bool = typer.Option(False, help="Replace an existing output folder."),
) -> None:
    """Move robots apart: each steps to increase its smallest clearance."""
    from rfp_twin.twin.recovery import explode as run_explode
    from rfp_twin.twin.recovery import movable_mask
    from rfp_twin.twin.run_dir import check_output_folder

    check_output_folder(out, force)
    geom, angles = _array(poses, preset, layout, calibration, buffer, encoder)
    with progress_bar("explode") as progress:
        progress.add_task(f"{geom.n_robots} robots, {degrees:g} deg", total=None)
        outcome = run_explode(geom, angles, movable_mask(geom, _offline_ids(offline)),
                              degrees=degrees, step_deg=step, robot_id=robot)
    if outcome.new_collisions:
        c = outcome.new_collisions[0]
        raise fail(f"the explosion brings robot {c.robot_a} and {c.kind} {c.other} to "
                   f"{c.min_distance_mm:.3f} mm (keep-out {c.threshold_mm:.3f} mm) at "
                   f"t = {c.t_min:.2f} s; nothing written", EXIT_COLLISION)
    outcome.write(out, overwrite=force)
    _report("rfp-twin explode", outcome, out)


__all__ = ["explode", "unwind"]
