"""``rfp-twin unwind`` and ``rfp-twin explode``: recovery moves from the robots' current poses.

POSES is a run folder (its trajectory's end: where that run left the robots) or a CSV of
current angles (``robot_id,alpha_deg,beta_deg``; ``--encoder`` for encoder angles) with
``--preset`` and ``--layout`` / ``--calibration``. The motion is written as a run folder
(``trajectories.json``: start -> end) that ``validate``, ``simulate``, ``render`` and
``record`` read like any other. Exit codes: 0 done, 2 bad input, 3 robots left short of
the fold (unwind; the folder is written), 4 a collision in the motion (nothing written).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import typer

from rfp_twin.models.options import option, same_option
from rfp_twin.planners.plan import PlannerSettings
from rfp_twin.planners.plan.settings import DEFAULT_GREED_PHOBIA
from rfp_twin.twin.cli.console import (EXIT_COLLISION, EXIT_INCOMPLETE, fail, one_line_errors,
                                       print_rows, progress_bar)
from rfp_twin.twin.cli.layout_option import chosen_layout
from rfp_twin.twin.cli.options import options_from, with_options
from rfp_twin.twin.cli.shared_options import (ArrayOptions, force_option, out_option,
                                              parse_ids)

POSES_HELP = ("Run folder (its trajectory's end) or CSV of current angles "
              "(robot_id,alpha_deg,beta_deg).")
RUN_OUT_HELP = "Output run folder."
MARKOV_GREED, MARKOV_PHOBIA = DEFAULT_GREED_PHOBIA["markov"]
#: CLI spellings of fields whose names carry their unit.
RENAME = {"step_deg": "step"}


@dataclass(frozen=True)
class RecoveryInputs:
    """Where the robots stand and how they may move: the options ``unwind`` and ``explode``
    share."""

    preset: str | None = option(None, "Robot preset or TOML [default: the run's, else "
                                "sdss-v-production]")
    layout: str | None = same_option(ArrayOptions, "layout")
    calibration: Path | None = same_option(ArrayOptions, "calibration")
    buffer: float | None = same_option(ArrayOptions, "buffer")
    encoder: bool = option(False, "The CSV holds encoder angles")
    offline: tuple[str, ...] = option((), "Offline robot ids (comma-separated or repeated): "
                                      "they stay where they stand")
    step_deg: float = same_option(PlannerSettings, "step_deg")

    def offline_ids(self) -> list[int]:
        return [i for item in self.offline for i in parse_ids(item, "--offline")]


@dataclass(frozen=True)
class UnwindOptions:
    """How ``unwind`` plans: the stepwise planner's options it takes (declared by
    PlannerSettings) and whether it resolves deadlocks."""

    algorithm: str = same_option(PlannerSettings, "algorithm", choices=("greedy", "markov"),
                                 help="greedy | markov (stepwise planner)")
    resolve: bool = option(True, "Resolve deadlocks as every plan does (the poses kept as "
                           "targets); --no-resolve stops at the first deadlock, as SDSS-V's "
                           "controller unwinds")
    greed: float = same_option(PlannerSettings, "greed", default=MARKOV_GREED, help="Markov greed")
    phobia: float = same_option(PlannerSettings, "phobia", default=MARKOV_PHOBIA,
                                help="Markov phobia")
    seed: int = option(0, "Seed of the Markov moves")


def _array(poses: Path, inputs: RecoveryInputs):
    """``(ArrayGeometry, poses (n, 2) model deg)`` from a run folder or a CSV."""
    from rfp_twin.models.array import ArrayGeometry
    from rfp_twin.models.errors import TargetError
    from rfp_twin.models.layout import layout_by_name
    from rfp_twin.models.robot import load_spec
    from rfp_twin.twin.recovery import poses_from_csv, poses_from_run

    preset, layout, calibration = inputs.preset, inputs.layout, inputs.calibration
    if poses.is_dir():
        if layout is not None or calibration is not None or inputs.encoder:
            raise TargetError(f"{poses}: a run folder carries its own layout and model angles; "
                              "allowed: --layout, --calibration and --encoder with a CSV only")
        spec, lay, angles = poses_from_run(poses)
        if preset is not None:
            spec = load_spec(preset)
    else:
        spec = load_spec(preset or "sdss-v-production")
        lay = layout_by_name(chosen_layout(layout, calibration, spec), spec.pitch_mm)
        angles = None
    if inputs.buffer is not None:
        spec = spec.with_overrides(buffer_mm=inputs.buffer)
    geom = ArrayGeometry(spec, lay, spec.buffer_mm)
    if angles is None:
        angles = poses_from_csv(poses, geom, encoder=inputs.encoder)
    return geom, angles


def _report(title: str, outcome, out: Path) -> None:
    m = outcome.plan.metrics
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
    print_rows(f"{title} -> {out}", rows)


@one_line_errors
@with_options(RecoveryInputs, RENAME)
@with_options(UnwindOptions)
def unwind(
    poses: Path = typer.Argument(..., help=POSES_HELP),
    out: Path = out_option(Path("out/unwind"), RUN_OUT_HELP),
    force: bool = force_option(),
    **option_values,
) -> None:
    """Fold every robot from where it stands; robots left deadlocked stop short (exit 3)."""
    from dataclasses import asdict

    from rfp_twin.models.errors import RfpError
    from rfp_twin.models.options import option_info
    from rfp_twin.twin.recovery import movable_mask, unwind as run_unwind
    from rfp_twin.twin.run_dir import check_output_folder

    check_output_folder(out, force)
    inputs = options_from(RecoveryInputs, option_values, RENAME)
    how = options_from(UnwindOptions, option_values)
    allowed = option_info(UnwindOptions, "algorithm").choices
    if how.algorithm not in allowed:
        raise RfpError(f"--algorithm {how.algorithm!r}; allowed: {', '.join(allowed)}")
    geom, angles = _array(poses, inputs)
    with progress_bar("unwind") as progress:
        progress.add_task(f"{geom.n_robots} robots", total=None)
        outcome = run_unwind(geom, angles, movable_mask(geom, inputs.offline_ids()),
                             step_deg=inputs.step_deg, **asdict(how))
    if outcome.new_collisions or outcome.start_collisions:
        raise fail(f"the unwind fails the 2D check: {len(outcome.check.collisions)} "
                   "collision(s); nothing written", EXIT_COLLISION)
    outcome.write(out, overwrite=force)
    _report("rfp-twin unwind", outcome, out)
    if outcome.n_deadlocked:
        raise fail(f"{outcome.n_deadlocked} robot(s) deadlocked short of the fold; the motion "
                   f"up to the deadlock is in {out}", EXIT_INCOMPLETE)


@one_line_errors
@with_options(RecoveryInputs, RENAME)
def explode(
    poses: Path = typer.Argument(..., help=POSES_HELP),
    degrees: float = typer.Option(20.0, help="Travel of the explosion, deg (> 0)."),
    robot: Optional[int] = typer.Option(None, help="Explode this robot alone [default: all]."),
    out: Path = out_option(Path("out/explode"), RUN_OUT_HELP),
    force: bool = force_option(),
    **option_values,
) -> None:
    """Move robots apart: each steps to increase its smallest clearance."""
    from rfp_twin.twin.recovery import explode as run_explode
    from rfp_twin.twin.recovery import movable_mask
    from rfp_twin.twin.run_dir import check_output_folder

    check_output_folder(out, force)
    inputs = options_from(RecoveryInputs, option_values, RENAME)
    geom, angles = _array(poses, inputs)
    with progress_bar("explode") as progress:
        progress.add_task(f"{geom.n_robots} robots, {degrees:g} deg", total=None)
        outcome = run_explode(geom, angles, movable_mask(geom, inputs.offline_ids()),
                              degrees=degrees, step_deg=inputs.step_deg, robot_id=robot)
    if outcome.new_collisions:
        c = outcome.new_collisions[0]
        raise fail(f"the explosion brings robot {c.robot_a} and {c.kind} {c.other} to "
                   f"{c.min_distance_mm:.3f} mm (keep-out {c.threshold_mm:.3f} mm) at "
                   f"t = {c.t_min:.2f} s; nothing written", EXIT_COLLISION)
    outcome.write(out, overwrite=force)
    _report("rfp-twin explode", outcome, out)


__all__ = ["explode", "unwind"]
