"""A run folder: everything `rfp-twin plan` writes, written atomically.

Files
-----
trajectories.json          fold -> targets, SDSS-V control-software form (deg, s), MODEL angles
trajectories_to_fold.json  targets -> fold (the same motion played backwards), model angles
trajectories_encoder.json, trajectories_to_fold_encoder.json
                           the same in ENCODER angles (model - alpha_offset_deg / beta_offset_deg
                           of each robot), written when the layout carries angle offsets (a
                           calibrated instrument): what the robots' firmware is sent
layout.csv                 the layout planned on (id, x_mm, y_mm, kind, ...)
targets.csv                per robot: id, target and original target (deg, and fiber mm), status

Model angles are the planners' and checkers' (alpha from the plane's +x, beta from the alpha
arm); an instrument's encoder reads model - offset (its zero sits at the model angle
``offset``, see :mod:`rfp_twin.models.layout.columns`).
robot.toml                 the robot spec used (with the buffer planned at)
summary.json               every parameter, every metric, the 2D check in brief
check2d.json               the independent 2D check in full (per-pair minimum distances)

The folder is assembled under a temporary name beside the destination and renamed into
place only when complete, so an interrupted or failed run leaves no half-written folder.
"""
from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import RfpError, TrajectoryError
from rfp_twin.models.files import atomic_folder
from rfp_twin.models.kinematics import forward, forward_fiber
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import (FIBER_COLUMNS, robot_column, robot_fibers,
                                            robot_joint_limits)
from rfp_twin.models.robot import RobotSpec
from rfp_twin.planners.plan import Plan
from rfp_twin.models.trajectory import AXES, Trajectory

TRAJECTORIES = "trajectories.json"
TRAJECTORIES_TO_FOLD = "trajectories_to_fold.json"
ENCODER_SUFFIX = "_encoder"
LAYOUT = "layout.csv"
TARGETS = "targets.csv"
ROBOT = "robot.toml"
SUMMARY = "summary.json"
CHECK2D = "check2d.json"
#: The per-pair lists of a check report, written to check2d.json only.
_CHECK_ARRAYS = ("pair_ids", "pair_min_distance_mm", "fiducial_pair_ids", "fiducial_min_distance_mm")


def spec_to_toml(spec: RobotSpec) -> str:
    """Serialise a RobotSpec to the preset TOML form (round-trips through load_spec)."""
    def val(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, tuple):
            return "[" + ", ".join(repr(float(x)) for x in v) + "]"
        return repr(float(v))

    robot = ["name", "description", "alpha_length_mm", "beta_length_mm", "pitch_mm",
             "alpha_limits_deg", "beta_limits_deg", "max_speed_deg_s", "max_accel_deg_s2",
             "fold_deg", "angular_error_deg"]
    coll = ["buffer_mm", "segment_start_mm", "segment_end_mm", "fiducial_buffer_mm"]
    lines = ["[robot]"] + [f"{k} = {val(getattr(spec, k))}" for k in robot]
    lines += ["", "[collision]"] + [f"{k} = {val(getattr(spec, k))}" for k in coll]
    return "\n".join(lines) + "\n"


def angle_offsets(layout: Layout) -> np.ndarray | None:
    """(n_robots, 2) encoder zero offsets (alpha, beta) deg of a layout that carries them, else None."""
    if "alpha_offset_deg" not in layout.extra and "beta_offset_deg" not in layout.extra:
        return None
    return np.column_stack([robot_column(layout, "alpha_offset_deg", 0.0),
                            robot_column(layout, "beta_offset_deg", 0.0)])


def to_encoder(traj: Trajectory, offsets: np.ndarray, layout: Layout) -> Trajectory:
    """``traj`` in encoder angles: model - offset of each robot (``offsets`` (n_robots, 2) deg
    in layout order)."""
    k = layout.robot_indices(traj.robot_ids)
    angles = tuple(tuple(a - offsets[k[i], ax] for i, a in enumerate(traj.angles[ax]))
                   for ax in range(2))
    return Trajectory(traj.robot_ids, traj.times, angles)


def fiber_positions(spec: RobotSpec, layout: Layout, angles: np.ndarray) -> np.ndarray:
    """(n_robots, 2) mm: each robot's fiber at ``angles`` (n, 2) deg: its own metrology fiber
    and alpha arm on a layout that carries fibers, else the spec's fiber (beta_length_mm)."""
    angles = np.ascontiguousarray(angles, dtype=np.float64)
    base = np.ascontiguousarray(layout.robot_xy, dtype=np.float64)
    if not any(c in layout.extra for c in FIBER_COLUMNS["metrology"]):
        return forward(base, angles, spec.alpha_length_mm, spec.beta_length_mm)[0]
    la = robot_column(layout, "alpha_len_mm", spec.alpha_length_mm)
    return forward_fiber(base, angles, la, robot_fibers(layout, {})[:, 0])


def write_targets_csv(path: Path, spec: RobotSpec, layout: Layout, plan: Plan) -> None:
    fiber = fiber_positions(spec, layout, plan.targets)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["robot_id", "alpha_deg", "beta_deg", "x_mm", "y_mm", "status",
                    "original_alpha_deg", "original_beta_deg"])
        for i, rid in enumerate(plan.robot_ids):
            w.writerow([int(rid), f"{plan.targets[i, 0]:.6f}", f"{plan.targets[i, 1]:.6f}",
                        f"{fiber[i, 0]:.4f}", f"{fiber[i, 1]:.4f}", plan.status[i],
                        f"{plan.original_targets[i, 0]:.6f}", f"{plan.original_targets[i, 1]:.6f}"])


def check_output_folder(out: Path, overwrite: bool = False) -> None:
    """Raise :class:`RfpError` when ``out`` exists and may not be replaced (called before
    any work, so a long plan is not lost at the end)."""
    if Path(out).exists() and not overwrite:
        raise RfpError(f"output folder {out} exists; allowed: a new folder, or --force to replace it")


def write_run(out: Path, *, spec: RobotSpec, layout: Layout, plan: Plan, trajectory: Trajectory,
              summary: dict, check2d: dict, overwrite: bool = False,
              extra: dict[str, str] | None = None) -> Path:
    """Write a complete run folder at ``out`` (atomically). Returns ``out``.

    ``check2d`` is the full report of the independent 2D check; the summary keeps it
    without the per-pair lists. ``extra``: more files {name: text} (an assignment.csv).
    """
    out = Path(out)
    check_output_folder(out, overwrite)
    with atomic_folder(out) as tmp:
        trajectory.to_json(tmp / TRAJECTORIES)
        trajectory.reversed().to_json(tmp / TRAJECTORIES_TO_FOLD)
        offsets = angle_offsets(layout)
        if offsets is not None:
            enc = to_encoder(trajectory, offsets, layout)
            enc.to_json(tmp / TRAJECTORIES.replace(".json", f"{ENCODER_SUFFIX}.json"))
            enc.reversed().to_json(tmp / TRAJECTORIES_TO_FOLD.replace(".json", f"{ENCODER_SUFFIX}.json"))
        layout.to_csv(tmp / LAYOUT)
        write_targets_csv(tmp / TARGETS, spec, layout, plan)
        (tmp / ROBOT).write_text(spec_to_toml(spec), encoding="utf-8")
        brief = {k: v for k, v in check2d.items() if k not in _CHECK_ARRAYS}
        (tmp / SUMMARY).write_text(json.dumps({**summary, "check2d": brief}, indent=2,
                                              default=_json_default), encoding="utf-8")
        (tmp / CHECK2D).write_text(json.dumps(check2d, default=_json_default), encoding="utf-8")
        for name, text in (extra or {}).items():
            (tmp / name).write_text(text, encoding="utf-8")
    return out


def load_run(run: str | Path, to_fold: bool = False) -> tuple[RobotSpec, Layout, Trajectory, dict]:
    """Read a run folder written by :func:`write_run`: spec, layout, trajectory, summary.

    The trajectory is the unfold (``trajectories.json``) or, with ``to_fold``, the fold
    (``trajectories_to_fold.json``).

    ``robot.toml`` holds the spec's own tables only; its other tables (the 3D
    ``[geometry]``, ``[actuators]``) are those of the preset or file the run was planned
    with, which ``summary.json`` names: when that still exists, the spec's ``source`` is set
    to it, so that :func:`rfp_twin.models.geometry.geometry_for_spec` (the MuJoCo twin, the
    3D validation) builds the run's own robot, not the default one.
    """
    from rfp_twin.models.robot import load_spec, source_origin

    run = Path(run)
    if not run.is_dir():
        raise RfpError(f"{run}: run folder not found; allowed: a folder written by `rfp-twin plan`")
    traj_file = TRAJECTORIES_TO_FOLD if to_fold else TRAJECTORIES
    missing = [f for f in (ROBOT, LAYOUT, traj_file) if not (run / f).is_file()]
    if missing:
        raise RfpError(f"{run}: {', '.join(missing)} is missing; allowed: a folder written by "
                       "`rfp-twin plan`")
    spec = load_spec(run / ROBOT)
    layout = Layout.from_csv(run / LAYOUT, min_separation_mm=min(1.0, spec.pitch_mm / 4))
    traj = Trajectory.from_json(run / traj_file)
    check_run_trajectory(traj, spec, layout, run / traj_file)
    summary = json.loads((run / SUMMARY).read_text()) if (run / SUMMARY).is_file() else {}
    planned_with = str(summary.get("spec", ""))
    if source_origin(planned_with) is not None:
        spec = dataclasses.replace(spec, source=planned_with)
    return spec, layout, traj, summary


def check_run_trajectory(traj: Trajectory, spec: RobotSpec, layout: Layout, source: Path) -> None:
    """Raise TrajectoryError unless ``traj`` moves exactly the layout's robots and every
    breakpoint angle lies within its robot's joint limits (model deg: the spec's shifted by
    the robot's encoder offsets, :func:`robot_joint_limits`); the message names the
    file, the robot, the axis, the value and the allowed range."""
    ids = np.asarray(traj.robot_ids)
    robots = layout.robot_ids
    unknown = np.setdiff1d(ids, robots)
    if unknown.size:
        raise TrajectoryError(f"{source}: robot {int(unknown[0])} is not a robot of the run's layout; "
                              f"allowed ids: {int(robots.min())}..{int(robots.max())}")
    missing = np.setdiff1d(robots, ids)
    if missing.size:
        raise TrajectoryError(f"{source}: robot {int(missing[0])} of the layout has no trajectory "
                              f"({missing.size} robot(s) missing)")
    limits = robot_joint_limits(spec, layout)
    row = {int(r): k for k, r in enumerate(robots)}
    for ax in range(2):
        for i, angles in enumerate(traj.angles[ax]):
            lo, hi = (float(v) for v in limits[row[int(ids[i])], 2 * ax:2 * ax + 2])
            bad = np.flatnonzero((angles < lo) | (angles > hi))
            if bad.size:
                raise TrajectoryError(
                    f"{source}: robot {int(ids[i])}: field '{AXES[ax]}' = {float(angles[bad[0]])!r} "
                    f"deg at t = {float(traj.times[ax][i][bad[0]]):g} s; allowed: [{lo:g}, {hi:g}] deg")


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
