"""Sabater's prioritized roadmap planner over a whole alpha/beta array.

:mod:`rfp_twin.planners.roadmap` plans arms one at a time in a priority order (Sabater 2018
Algorithm 1); :class:`rfp_twin.planners.deadlocks.search.AlphaBetaWorld` gives it the black boxes
of an alpha/beta robot in an array. This module runs that planner on *every* robot, in
the planner's frame (reverse: each robot goes from its target at step 0 to the folded
state), as a first planner run in place of the stepwise GC/MC kernel
(``PlannerSettings(algorithm="roadmap")``):

* priority: Sabater 2018 Sect. 7, the longest estimated direct travel time first
  (``max_k |goal_k - start_k| / vmax_k``, ties by robot index);
* a robot is planned against the trajectories of the robots planned before it (moving
  obstacles, holding their last configuration after their end) and against the robots
  not planned yet, which sit at their starts (static obstacles until they are planned:
  every robot planned later must then avoid everything planned earlier, so the plan
  stays consistent); fiducials, offline robots and joint limits are static too;
* goal conflicts: a robot parks only where it stays clear until its neighbours have
  stopped (``Arm.hold_until``, set by ``AlphaBetaWorld.arm``);
* a robot that finds no trajectory is **deferred** (beyond the paper, whose Sect. 2.1
  moves a failing arm to the front and starts again): it stays at its start and is
  tried again after a full pass, when more of its neighbours have left their starts;
  passes repeat while some robot gets planned. A robot still without a trajectory stays
  at its start and is reported stuck: the caller resolves it like a deadlock of the
  stepwise planner (search, then replacement; :mod:`rfp_twin.planners.plan.reconfigure`).

Collisions are checked at every planner step with the stepwise planner's step rule
(buffer_i + buffer_j + MD), and a robot moves at most ``step_deg`` per axis per step, so
the result passes :func:`rfp_twin.validation.checker2d.check_trajectory` at the planning buffer
exactly like the stepwise plans do (see :mod:`rfp_twin.planners.deadlocks.search`).

Units: mm and degrees; times on the planner's step clock (one unit = one step).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.planners.roadmap import edge_time, plan_arm
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings
from rfp_twin.planners.roadmap.alpha_beta.world import AlphaBetaWorld


@dataclass
class RoadmapPass:
    """Outcome of :func:`roadmap_pass` (planning frame).

    Attributes
    ----------
    paths : PathSet, every robot's breakpoints on the step clock (a stuck robot holds
        its start)
    final : (n, 2) deg, where each robot ends (its destination, or its start if stuck)
    planned : (n,) bool, robots that got a trajectory (offline robots: False)
    n_steps : int, length of the plan in steps (the latest arrival)
    passes : int, passes over the robots still to plan
    order : (m,) int64, the priority order of the first pass (robot indices)
    seconds : float, wall time
    """

    paths: PathSet
    final: np.ndarray
    planned: np.ndarray
    n_steps: int
    passes: int
    order: np.ndarray
    seconds: float

    def events(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Breakpoints as (robot (m,) int64, step (m,) int64, angles (m, 2) deg), in step
        order per robot: the form of the stepwise kernel's events
        (:func:`rfp_twin.planners.plan.build_paths`)."""
        rob, stp, ang = [], [], []
        for i, (s, a) in enumerate(zip(self.paths.steps, self.paths.angles)):
            k = np.rint(s).astype(np.int64)
            if np.any(np.abs(s - k) > 1e-6):
                raise field_error(SpecError, "trajectory times", s[np.abs(s - k) > 1e-6][:3],
                                  "whole planner steps", f"roadmap robot index {i}")
            rob.append(np.full(k.size, i, dtype=np.int64))
            stp.append(k)
            ang.append(a)
        if not rob:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2))
        return np.concatenate(rob), np.concatenate(stp), np.vstack(ang)


def travel_priority(start: np.ndarray, dest: np.ndarray, robots: np.ndarray,
                    vmax: float) -> np.ndarray:
    """Sabater 2018 Sect. 7: robots with the longest direct travel time first (Eq. 5,
    :func:`rfp_twin.planners.roadmap.edge_time`).

    start, dest : (n, 2) deg; robots : (m,) indices to order; vmax : deg per step.
    Returns (m,) robot indices (stable: ties keep index order).
    """
    v = np.full(2, float(vmax))
    est = np.array([edge_time(start[i], dest[i], v) for i in robots])
    return robots[np.argsort(-est, kind="stable")]


def roadmap_pass(geom: ArrayGeometry, start: np.ndarray, dest: np.ndarray, movable: np.ndarray,
                 md: float, step_deg: float, settings: SearchResolveSettings,
                 rng: np.random.Generator, max_passes: int = 4,
                 quick_nodes: int = 20000, quick_paths: int = 40) -> RoadmapPass:
    """Plan every movable robot from ``start`` to ``dest`` with Sabater's prioritized planner.

    Parameters
    ----------
    geom : ArrayGeometry
    start, dest : (n, 2) deg, mutually clear configurations (planner's frame)
    movable : (n,) bool, False for offline robots (static at ``start``)
    md : float, step-rule margin MD, mm (:func:`rfp_twin.planners.stepwise.max_displacement`)
    step_deg : float, planner step, deg (the top speed: one step per axis per step)
    settings : SearchResolveSettings (roadmap grid, search budgets, action length)
    rng : numpy Generator (roadmap random edges, tie order)
    max_passes : passes over the deferred robots at most
    quick_nodes, quick_paths : search budget of one robot's try (capped by those of
        ``settings``): most robots need a few thousand nodes; one blocked by a neighbour
        that has not left its start yet would spend any budget, so it is deferred early
        and what stays stuck goes to the group search of the caller, which moves the
        blocking robots together

    Returns
    -------
    RoadmapPass
    """
    clock = time.perf_counter()
    n = geom.n_robots
    start = np.asarray(start, dtype=np.float64)
    dest = np.asarray(dest, dtype=np.float64)
    movable = np.asarray(movable, dtype=bool)
    if max_passes < 1:
        raise field_error(SpecError, "max_passes", max_passes, ">= 1", "roadmap_pass")
    paths = PathSet([np.zeros(1) for _ in range(n)], [start[i:i + 1].copy() for i in range(n)])
    world = AlphaBetaWorld(geom, paths, movable, md, step_deg)
    full = settings.roadmap_settings(step_deg)
    rs = replace(full, max_nodes=min(quick_nodes, full.max_nodes or quick_nodes),
                 max_paths=min(quick_paths, full.max_paths or quick_paths))
    order = travel_priority(start, dest, np.flatnonzero(movable), step_deg)
    planned = np.zeros(n, dtype=bool)
    todo = [int(i) for i in order]
    passes = 0
    while todo and passes < max_passes:
        passes += 1
        deferred = []
        for i in todo:
            if np.all(np.abs(dest[i] - start[i]) < 1e-12):
                planned[i] = True
                continue
            tr, _ = plan_arm(world.arm(i, start[i], dest[i]), rs, rng)
            if tr is None:
                deferred.append(i)
                continue
            paths.steps[i] = np.asarray(tr.times, dtype=np.float64)
            paths.angles[i] = np.asarray(tr.configs, dtype=np.float64)
            planned[i] = True
        if len(deferred) == len(todo):
            break
        todo = deferred
    final = start.copy()
    final[planned] = dest[planned]
    n_steps = int(np.ceil(max((float(s[-1]) for s in paths.steps), default=0.0)))
    return RoadmapPass(paths, final, planned, n_steps, passes, order,
                       time.perf_counter() - clock)
