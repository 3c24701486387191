"""Shortening a stepwise run where a neighbour holds up the robot that ends it: :func:`shorten_run`.

The robot that moves longest in a stepwise run (typically ~350 deg of alpha travel)
sets the fold; it often loses hundreds of steps to alpha moves that a neighbour's arm
blocks while beta moves alone. With the
beta-first rule (``PlannerSettings.beta_first``: robots with time to spare retract beta
before turning alpha) most of those neighbours are out of the way; where one still is,
switching that neighbour's rule (beta first or not) often frees the robot. This module
finds the robot that ends the run, the neighbour nearest to it at the steps where its
alpha did not move (the blocker), switches the blocker's rule and runs the whole array
again; the new run is kept when robots arrived sooner and no more are stuck. Each run
is a whole run of the planner, so what it delivers is checked as any plan.
:class:`FoldRepairResolver` is the strategy of the chain; it works on the round's run
before its stuck robots are counted.

Units: planner steps; angles in deg.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.geometry2d import pair_distances
from rfp_twin.planners.deadlocks.groups import arrival_steps, last_events, stuck_mask
from rfp_twin.planners.deadlocks.resolver import Round
from rfp_twin.planners.plan import build_paths
from rfp_twin.planners.plan.runs import beta_first_robots, run_once
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.stepwise import StepRun


@dataclass(frozen=True)
class FoldRepairRecord:
    """Whole runs made (``runs``) and their kernel seconds (``seconds``) in one round."""

    runs: int
    seconds: float


class FoldRepairResolver:
    """The round's run with the robot that ends it freed where a beta-first switch of its
    blocker does it (:func:`shorten_run`, at most ``settings.fold_repairs`` runs)."""

    def __init__(self, settings: PlannerSettings) -> None:
        self.settings = settings

    def applies(self, rnd: Round) -> bool:
        return True

    def resolve(self, rnd: Round) -> FoldRepairRecord:
        s = self.settings
        start, goal = rnd.start, rnd.goal
        flags = beta_first_robots(start, goal, rnd.movable, s.beta_first)
        if flags is None:                    # nobody moves
            return FoldRepairRecord(0, 0.0)
        best, _, made, spent = shorten_run(
            rnd.geom, rnd.run, start, goal, rnd.movable, flags,
            lambda f: run_once(rnd.geom, start, goal, rnd.movable, s, rnd.seed, beta_first=f),
            s.step_deg, s.fold_repairs)
        rnd.run = best
        return FoldRepairRecord(made, spent)


def last_robot(run: StepRun, stuck: np.ndarray) -> int:
    """Index of the robot that reached its destination last in ``run`` (-1: none)."""
    last = last_events(run, stuck.size)
    last[stuck] = -1
    return int(np.argmax(last)) if last.max() >= 0 else -1


def alpha_blockers(geom: ArrayGeometry, run: StepRun, start: np.ndarray, goal: np.ndarray,
                   robot: int, step_deg: float) -> list[int]:
    """Neighbours of ``robot`` that were nearest to it, after the step, at the steps where
    its alpha did not move while away from its destination, most often first (the
    clearance of the alpha step it could not take: its alpha one step towards ``goal``,
    its beta and everyone else as they were after the step)."""
    n = geom.n_robots
    ptr, steps, angles = build_paths(n, run.ev_robot, run.ev_step, run.ev_angles, start,
                                     run.final, run.n_steps)
    k = np.arange(run.n_steps + 1, dtype=np.float64)
    mine = angles[ptr[robot]:ptr[robot + 1]]
    st = steps[ptr[robot]:ptr[robot + 1]]
    a = np.interp(k, st, mine[:, 0])
    b = np.interp(k, st, mine[:, 1])
    held = np.flatnonzero((np.abs(np.diff(a)) <= 1e-9) & (np.abs(a[:-1] - goal[robot, 0]) > 1e-9))
    if held.size == 0:
        return []
    pairs = geom.pairs
    rows = pairs[(pairs[:, 0] == robot) | (pairs[:, 1] == robot)]
    other = np.where(rows[:, 0] == robot, rows[:, 1], rows[:, 0])
    after = k[held + 1]
    ang = np.zeros((n, 2))                       # only the robot and its neighbours matter
    count: dict[int, int] = {}
    near = [(int(j), np.interp(after, steps[ptr[j]:ptr[j + 1]], angles[ptr[j]:ptr[j + 1], 0]),
             np.interp(after, steps[ptr[j]:ptr[j + 1]], angles[ptr[j]:ptr[j + 1], 1]))
            for j in other]
    tried_a = a[held] + np.sign(goal[robot, 0] - a[held]) * step_deg
    spare = geom.buffer[rows[:, 0]] + geom.buffer[rows[:, 1]]
    for h in range(held.size):
        for j, ja, jb in near:
            ang[j, 0], ang[j, 1] = ja[h], jb[h]
        ang[robot, 0], ang[robot, 1] = tried_a[h], b[held[h] + 1]
        d = pair_distances(geom.base_xy, ang, rows, geom.alpha_len, geom.seg_start,
                           geom.seg_end) - spare
        j = int(other[np.argmin(d)])
        count[j] = count.get(j, 0) + 1
    return sorted(count, key=lambda j: -count[j])


def shorten_run(geom: ArrayGeometry, run: StepRun, start: np.ndarray, goal: np.ndarray,
                movable: np.ndarray, flags: np.ndarray, rerun: Callable[[np.ndarray], StepRun],
                step_deg: float, tries: int) -> tuple[StepRun, np.ndarray, int, float]:
    """Up to ``tries`` whole runs, each with the beta-first rule of the robot that blocks
    the last robot's alpha switched (``flags`` (n,) bool, the robots that retract beta
    first; ``rerun(flags)`` runs the array). A run is kept when its robots arrived sooner
    (:func:`rfp_twin.planners.deadlocks.groups.arrival_steps`) with no more of them stuck. Returns
    (the run kept, its flags, runs made, their kernel seconds)."""
    best, flags = run, np.asarray(flags, dtype=bool).copy()
    stuck = stuck_mask(best, goal, movable)
    length = arrival_steps(best, stuck)
    tried: set = set()
    made = 0
    spent = 0.0
    while made < tries:
        r = last_robot(best, stuck)
        if r < 0:
            break
        cand = [j for j in alpha_blockers(geom, best, start, goal, r, step_deg)
                if movable[j] and (r, j) not in tried]
        if not cand:
            break
        j = cand[0]
        tried.add((r, j))
        trial = flags.copy()
        trial[j] = not trial[j]
        again = rerun(trial)
        made += 1
        spent += again.seconds
        left = stuck_mask(again, goal, movable)
        if left.sum() <= stuck.sum() and arrival_steps(again, left) < length:
            best, flags, stuck, length = again, trial, left, arrival_steps(again, left)
    return best, flags, made, spent
