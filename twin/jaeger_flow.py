"""SDSS-V's configuration flow (its controller, jaeger): the trajectory production would send.

Given the targets of a configuration, jaeger (``target/configuration.py`` ``get_paths``):

1. **decollides**: each robot whose target collides is moved, robot by robot, to a
   random pose in its patrol annulus clear of the others (kaiju ``decollideRobot``: up
   to 1000 draws), the robots without a science target first, then the others; a robot
   that cannot be cleared is put back and the next one tried;
2. **plans** targets -> fold with the production generator (kaiju MDP2; any of our
   stepwise planners here), without resolving deadlocks;
3. **retries** a deadlocked plan up to 5 times: one deadlocked robot, drawn at random,
   gets a new random pose (decollided if needed) and the whole array is planned again;
   after the last retry the configuration fails;
4. **smooths** with kaiju's ``getPathPair`` (:mod:`rfp_twin.planners.postprocess.production`)
   and sends the reverse path (fold -> targets) without re-checking it.

Offline robots stay where they are in every step. :func:`jaeger_flow` runs that flow and
then checks what it would send with the independent 2D checker, under our rule and under
production's (every robot with the spec's segment), at the buffer and at buffer -
``collision_shrink``. Every robot moved away from its target (decollided or unlocked) is a
target lost, the cost of the flow beside our planner, which keeps them.

Units: deg, mm, s. Configurations (n_robots, 2) in layout order.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import PlanningError, TargetError
from rfp_twin.models.layout.columns import production_body_layout
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.planners.plan import DEADLOCKED, Plan
from rfp_twin.planners.postprocess.production import ProductionSettings, production_trajectories
from rfp_twin.planners.stepwise import array_max_displacement
from rfp_twin.planners.stepwise.recovery import min_clearance
from rfp_twin.planners.plan.targets import random_targets
from rfp_twin.twin.pipeline import PlanOptions, Reconfiguration
from rfp_twin.validation.checker2d import CheckReport, check_trajectory

#: Plans after the first that jaeger tries on a deadlock (``n_deadlock_retries``).
DEADLOCK_RETRIES = 5


@dataclass
class FlowOutcome:
    """What jaeger's flow did and what it would send.

    targets : (n, 2) deg, asked; poses : (n, 2) deg, the ones planned (after decollision
        and unlocking); decollided, unlocked : robot ids moved off their targets
    attempts : plans made (1 + retries); plan : the last plan, executed direction (fold ->
        poses); trajectory : what jaeger sends to unfold (fold -> poses), t = 0 at its
        first point (the path delay apart)
    checks : 2D checks of ``trajectory``, keyed ``"twin@B"`` and ``"production@B"`` for
        the buffer and the buffer minus the collision shrink
    """

    targets: np.ndarray
    poses: np.ndarray
    decollided: list[int]
    unlocked: list[int]
    attempts: int
    plan: Plan
    trajectory: Trajectory
    settings: ProductionSettings
    checks: dict[str, CheckReport] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def n_lost(self) -> int:
        """Targets not observed: robots moved off their targets."""
        return len(set(self.decollided) | set(self.unlocked))

    def summary(self) -> dict:
        return {"flow": "jaeger", "attempts": self.attempts, "decollided": self.decollided,
                "unlocked": self.unlocked, "n_targets_lost": self.n_lost,
                "duration_s": self.trajectory.duration,
                "path_delay_s": self.settings.path_delay_s,
                "production": {k: v for k, v in vars(self.settings).items()},
                "checks": {k: {"ok": c.ok, "n_collisions": len(c.collisions),
                               "min_clearance_mm": c.min_clearance_mm}
                           for k, c in self.checks.items()},
                "seconds": dict(self.seconds)}


def decollide(geom: ArrayGeometry, poses: np.ndarray, movable: np.ndarray, rng: np.random.Generator,
              *, order_first: np.ndarray | None = None, margin_mm: float = 0.0) -> list[int]:
    """Move colliding robots, one by one, to random clear poses (in place). Robots of
    ``order_first`` (bool (n,), e.g. those without a science target) go first. Returns the
    ids of the robots moved."""
    moved: list[int] = []
    first = np.zeros(geom.n_robots, bool) if order_first is None else order_first
    near = _near_robots(geom, poses, margin_mm)
    for group in (first, ~first):
        for i in np.flatnonzero(group & movable & near):
            if _robot_clearance(geom, poses, i) > margin_mm:
                continue
            try:
                fresh = random_targets(geom, rng, fixed=np.ones(geom.n_robots, bool),
                                       initial=poses, margin_mm=margin_mm, robots=np.array([i]),
                                       attempts=1)
            except TargetError:
                continue                      # no room: leave it, a neighbour may move
            poses[i] = fresh[i]
            moved.append(int(geom.robot_ids[i]))
    return moved


def _near_robots(geom: ArrayGeometry, poses: np.ndarray, margin_mm: float) -> np.ndarray:
    """(n,) bool: robots with a clearance at or below ``margin_mm`` at ``poses``."""
    near = np.zeros(geom.n_robots, bool)
    bad = geom.pair_clearance(poses) <= margin_mm
    near[geom.pairs[bad].ravel()] = True
    if geom.robot_fid_pairs.size:
        near[geom.robot_fid_pairs[geom.fiducial_clearance(poses) <= margin_mm, 0]] = True
    return near


def _robot_clearance(geom: ArrayGeometry, poses: np.ndarray, i: int) -> float:
    """Smallest clearance of robot ``i`` at ``poses``, mm."""
    pairs = geom.pairs
    rows = np.flatnonzero((pairs[:, 0] == i) | (pairs[:, 1] == i))
    values = [geom.pair_clearance(poses)[rows].min()] if rows.size else []
    fid = geom.robot_fid_pairs
    frows = np.flatnonzero(fid[:, 0] == i) if fid.size else np.zeros(0, np.int64)
    if frows.size:
        values.append(geom.fiducial_clearance(poses)[frows].min())
    return float(min(values)) if values else float("inf")


def jaeger_flow(geom: ArrayGeometry, targets: np.ndarray, rng: np.random.Generator, *,
                offline: dict[int, tuple[float, float]] | None = None,
                algorithm: str = "greedy", greed: float = 0.7, phobia: float = 0.6,
                step_deg: float = 0.1, retries: int = DEADLOCK_RETRIES,
                settings: ProductionSettings | None = None,
                science: np.ndarray | None = None) -> FlowOutcome:
    """Run jaeger's flow on ``targets`` ((n, 2) deg) and check what it sends (module
    docstring). ``science``: (n,) bool, robots with a science target (default: all).
    PlanningError when deadlocks remain after ``retries`` retries."""
    settings = settings or ProductionSettings()
    clock = time.perf_counter()
    seconds: dict[str, float] = {}
    poses = np.array(targets, dtype=np.float64)
    offline = dict(offline or {})
    movable = ~np.isin(geom.robot_ids, list(offline))
    md = array_max_displacement(geom, step_deg)
    first = None if science is None else ~np.asarray(science, dtype=bool)
    decollided = decollide(geom, poses, movable, rng, order_first=first, margin_mm=md)
    if min_clearance(geom, poses) <= 0.0:
        raise PlanningError("jaeger flow: the targets still collide after decollision "
                            f"(smallest clearance {min_clearance(geom, poses):.3f} mm)")
    seconds["decollide"] = time.perf_counter() - clock
    options = PlanOptions(algorithm=algorithm, step_deg=step_deg, greed=greed, phobia=phobia,
                          resolve="none")
    rc = Reconfiguration(geom, options, offline=offline)
    unlocked: list[int] = []
    attempts = 0
    t0 = time.perf_counter()
    while True:
        attempts += 1
        plan, _ = rc.plan(poses, rng)
        stuck = np.flatnonzero(plan.status == DEADLOCKED)
        if stuck.size == 0:
            break
        if attempts > retries:
            raise PlanningError(f"jaeger flow: {stuck.size} robot(s) still deadlocked after "
                                f"{retries} retries (ids {geom.robot_ids[stuck][:8].tolist()})")
        i = int(rng.choice(stuck))
        rid = int(geom.robot_ids[i])
        poses[i] = random_targets(geom, rng, fixed=np.ones(geom.n_robots, bool), initial=poses,
                                  margin_mm=md, robots=np.array([i]))[i]
        if rid not in unlocked:
            unlocked.append(rid)
    seconds["plan"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    # kaiju plans targets -> fold; jaeger unfolds along that path reversed
    _, unfold = production_trajectories(plan.reversed(), settings)
    seconds["smooth"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    production = production_body_layout(geom.layout)
    checks = {}
    for b in (geom.buffer_mm, geom.buffer_mm - settings.collision_shrink_mm):
        checks[f"twin@{b:g}"] = check_trajectory(unfold, geom.spec, geom.layout, b)
        checks[f"production@{b:g}"] = check_trajectory(unfold, geom.spec, production, b)
    seconds["check"] = time.perf_counter() - t0
    seconds["total"] = time.perf_counter() - clock
    return FlowOutcome(np.array(targets, dtype=np.float64), poses, decollided, unlocked,
                       attempts, plan, unfold, settings, checks, seconds)
