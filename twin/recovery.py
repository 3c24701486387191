"""Unwind and explode from the poses the robots stand at: poses in, checked run folder out.

The poses come from a run folder (where its trajectory ends: the configuration the array
was sent to) or from a CSV of current angles (``robot_id,alpha_deg,beta_deg``, every
robot of the layout; ``encoder=True`` for encoder angles, converted with each robot's
``alpha_offset_deg`` / ``beta_offset_deg``). Offline robots stay where they stand.

- :func:`unwind`: to the fold, with the planner and deadlock resolution of every plan
  (the poses as its targets), or as SDSS-V's controller does it, the stepwise planner
  stopping at a deadlock (:func:`rfp_twin.planners.stepwise.recovery.unwind_plan`);
  post-processed into firmware-ready trajectories and verified at buffer - budget like
  every plan. Poses that already collide at the buffer cannot be unwound safely:
  explode first.
- :func:`explode`: every robot (or one) steps to increase its smallest clearance
  (:func:`rfp_twin.planners.stepwise.recovery.explode_plan`); the stepwise motion is
  delivered as it is (it starts from poses that may collide, which post-processing
  would refuse), checked at the buffer. A collision that was not there at the start is
  a failure; one present at the start is what explode is for, and the report says
  whether it ends.

Both write a run folder whose ``trajectories.json`` is the motion (start -> end).
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError, TargetError
from rfp_twin.models.layout.columns import robot_column
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import DEADLOCKED, OFFLINE, REACHED, Plan
from rfp_twin.planners.plan.settings import DEFAULT_GREED_PHOBIA
from rfp_twin.planners.postprocess import DEFAULT_BUDGET_MM, DEFAULT_MAX_POINTS, postprocess
from rfp_twin.planners.stepwise.recovery import (EXPLODE_DEG, explode_plan, min_clearance,
                                                 unwind_plan)
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
from rfp_twin.twin.run_dir import load_run, write_run
from rfp_twin.twin.targets_csv import read_rows, robot_values
from rfp_twin.validation.checker2d import CheckReport, check_trajectory

#: Collisions that start within this time of the motion's start were there before it, s.
AT_START_S = 1e-6


def poses_from_run(run: str | Path) -> tuple:
    """``(spec, layout, poses (n, 2) model deg)``: where a run folder's trajectory ends."""
    spec, layout, traj, _ = load_run(run)
    index = {int(r): k for k, r in enumerate(traj.robot_ids)}
    end = traj.end()
    rows = [index[int(r)] for r in layout.robot_ids]
    return spec, layout, np.ascontiguousarray(end[rows], dtype=np.float64)


def poses_from_csv(path: str | Path, geom: ArrayGeometry, *, encoder: bool = False) -> np.ndarray:
    """(n, 2) model deg in layout order from ``robot_id,alpha_deg,beta_deg`` rows (every
    robot once); ``encoder``: the file's angles are encoder angles."""
    path = Path(path)
    rows = read_rows(path, "pose")
    need = ("robot_id", "alpha_deg", "beta_deg")
    if not rows or any(c not in rows[0] for c in need):
        raise TargetError(f"{path}: columns {sorted(rows[0]) if rows else []}; allowed: "
                          "robot_id,alpha_deg,beta_deg (one row per robot)")
    poses, _ = robot_values(path, rows, geom, need[1:], "angle")
    missing = np.flatnonzero(np.isnan(poses[:, 0]))
    if missing.size:
        raise TargetError(f"{path}: robot {int(geom.robot_ids[missing[0]])} has no row "
                          f"({missing.size} robot(s) missing); allowed: every robot's pose")
    if encoder:
        poses[:, 0] += robot_column(geom.layout, "alpha_offset_deg", 0.0)
        poses[:, 1] += robot_column(geom.layout, "beta_offset_deg", 0.0)
    lim = geom.limits
    outside = np.flatnonzero((poses[:, 0] < lim[:, 0] - 1e-9) | (poses[:, 0] > lim[:, 1] + 1e-9)
                             | (poses[:, 1] < lim[:, 2] - 1e-9) | (poses[:, 1] > lim[:, 3] + 1e-9))
    if outside.size:
        k = int(outside[0])
        raise TargetError(f"{path}: robot {int(geom.robot_ids[k])} pose {tuple(poses[k])} model "
                          f"deg; allowed: alpha in [{lim[k, 0]:g}, {lim[k, 1]:g}], beta in "
                          f"[{lim[k, 2]:g}, {lim[k, 3]:g}]")
    return poses


def movable_mask(geom: ArrayGeometry, offline_ids) -> np.ndarray:
    """(n,) bool: False for the robots of ``offline_ids`` (each must be a robot)."""
    index = {int(r): k for k, r in enumerate(geom.robot_ids)}
    movable = np.ones(geom.n_robots, dtype=bool)
    for rid in offline_ids:
        if int(rid) not in index:
            raise TargetError(f"--offline {rid}: unknown robot id; allowed: the robots of "
                              f"layout {geom.layout.name!r}")
        movable[index[int(rid)]] = False
    return movable


@dataclass
class RecoveryOutcome:
    """A recovery move delivered: its plan, trajectory and the independent 2D check.

    ``new_collisions`` are the collisions that start after the motion's start (a
    failure); ``start_collisions`` those present at its start (only explode accepts them)."""

    kind: str
    geom: ArrayGeometry
    plan: Plan
    trajectory: Trajectory
    check: CheckReport
    seconds: float
    post: object = None

    @property
    def start_collisions(self) -> list:
        return [c for c in self.check.collisions if c.t_start <= AT_START_S]

    @property
    def new_collisions(self) -> list:
        return [c for c in self.check.collisions if c.t_start > AT_START_S]

    @property
    def n_deadlocked(self) -> int:
        return int(np.sum(self.plan.status == DEADLOCKED))

    def summary(self) -> dict:
        spec, traj = self.geom.spec, self.trajectory
        return {"command": " ".join(["rfp-twin"] + sys.argv[1:]), "kind": self.kind,
                "spec": spec.source, "robot": spec.name, "layout": self.geom.layout.name,
                "n_robots": self.geom.n_robots, "buffer_mm": spec.buffer_mm,
                "step_deg": self.plan.step_deg, "metrics": dict(self.plan.metrics),
                "n_deadlocked": self.n_deadlocked, "duration_s": traj.duration,
                "path_delay_s": spec.path_delay_s,
                "trajectories": "stepwise (raw)" if self.post is None
                else "firmware-ready (postprocessed)",
                "n_start_collisions": len(self.start_collisions),
                "n_new_collisions": len(self.new_collisions),
                "check2d": self.check.to_dict(), "wall_time_s": self.seconds}

    def write(self, out: str | Path, overwrite: bool = False) -> Path:
        summary = self.summary()
        return write_run(Path(out), spec=self.geom.spec, layout=self.geom.layout, plan=self.plan,
                         trajectory=self.trajectory, summary=summary,
                         check2d=summary["check2d"], overwrite=overwrite)


def unwind(geom: ArrayGeometry, poses: np.ndarray, movable: np.ndarray, *, step_deg: float = 0.1,
           algorithm: str = "greedy", greed: float = DEFAULT_GREED_PHOBIA["markov"][0],
           phobia: float = DEFAULT_GREED_PHOBIA["markov"][1],
           resolve: bool = True, seed: int = 0, budget_mm: float = DEFAULT_BUDGET_MM,
           max_points: int = DEFAULT_MAX_POINTS) -> RecoveryOutcome:
    """Unwind ``poses`` to the fold; PlanningError when the poses collide already.

    With ``resolve`` the poses are planned as the targets of a reconfiguration (the
    planner works targets -> fold, so its plan played backwards is the unwind) with the
    deadlock resolution every plan gets; it is used when it keeps every pose, none
    replaced. Otherwise (or without ``resolve``, as SDSS-V's controller unwinds) the
    stepwise planner runs from the poses to the fold and stops at a deadlock."""
    clock = time.perf_counter()
    clear = min_clearance(geom, poses)
    if clear < 0.0:
        raise PlanningError(f"the poses collide at buffer {geom.buffer_mm:g} mm (smallest "
                            f"clearance {clear:.3f} mm); allowed: clear poses; run `rfp-twin "
                            "explode` first")
    greedy = algorithm == "greedy"
    if resolve:
        options = PlanOptions(algorithm=algorithm, step_deg=step_deg, greed=greed, phobia=phobia,
                              budget_mm=budget_mm, max_points=max_points)
        offline = {int(r): tuple(poses[k]) for k, r in enumerate(geom.robot_ids) if not movable[k]}
        rc = Reconfiguration(geom, options, offline=offline)
        try:
            plan, _ = rc.plan(poses, np.random.default_rng(seed))
        except TargetError:
            plan = None     # an offline robot stands on another's fold: no complete unwind
        if plan is not None and np.all((plan.status == REACHED) | (plan.status == OFFLINE)):
            traj, post, check = rc.deliver(plan)
            unwound = replace(plan.reversed(), targets=plan.start(),
                              original_targets=plan.start(),
                              metrics={**plan.metrics, "min_clearance_start_mm": clear,
                                       "unwind": "planned with deadlock resolution"})
            return RecoveryOutcome("unwind", geom, unwound, traj.reversed(), check,
                                   time.perf_counter() - clock, post)
    plan = unwind_plan(geom, poses, movable, step_deg=step_deg, greed=1.0 if greedy else greed,
                       phobia=0.0 if greedy else phobia, seed=seed)
    # post-processing times motions that end at rest at their targets, as a planned
    # fold -> targets; the unwind played backwards is one, and time reversal keeps every
    # speed and acceleration limit and every clearance
    backwards = replace(plan.reversed(), targets=plan.start(), original_targets=plan.start())
    traj, post = postprocess(backwards, geom, budget_mm=budget_mm, max_points=max_points,
                             verifier=check_trajectory)
    return RecoveryOutcome("unwind", geom, plan, traj.reversed(), post.final_check,
                           time.perf_counter() - clock, post)


def explode(geom: ArrayGeometry, poses: np.ndarray, movable: np.ndarray, *,
            degrees: float = EXPLODE_DEG, step_deg: float = 0.1,
            robot_id: int | None = None) -> RecoveryOutcome:
    """Explode from ``poses`` (every movable robot, or robot ``robot_id`` alone)."""
    clock = time.perf_counter()
    robots = None
    if robot_id is not None:
        hit = np.flatnonzero(geom.robot_ids == int(robot_id))
        if hit.size == 0 or not movable[hit[0]]:
            raise TargetError(f"--robot {robot_id}: not a movable robot of layout "
                              f"{geom.layout.name!r}")
        robots = hit
    plan = explode_plan(geom, poses, movable, degrees=degrees, step_deg=step_deg, robots=robots)
    traj = Trajectory.from_plan(plan)
    check = check_trajectory(traj, geom.spec, geom.layout, geom.buffer_mm)
    return RecoveryOutcome("explode", geom, plan, traj, check, time.perf_counter() - clock)
