"""Deadlock resolution by re-running the plan with greedy-first Markov robots around the groups.

When the stepwise planner leaves groups of robots deadlocked, the cheapest thing that can
untangle them is the planner itself, run again from the start with the robots in and
around the groups made *greedy-first Markov* robots
(``greedy_first`` of :func:`rfp_twin.planners.stepwise.kernel.run_stepwise`): each takes
its obvious move (one step towards its destination on each axis) whenever that move
passes the step rule, exactly as a greedy robot does, and draws a Markov move (Sayres
2021 Sect. 4.2: random candidate order, energy with probability ``phobia``, acceptance
with probability ``greed``) only when the obvious move is blocked, or steps aside when it
is at its destination and a neighbour encroaches (Eq. 10). Every other robot keeps its
plan's rules. So the region moves as the plan did wherever it was free to, and jiggles
only where it was locked: the fold is rarely longer than the first run's, while a full
Markov region (random moves at every step) made it 25-70 % longer (medians).

Attempts climb a ladder (:data:`LADDER`): the region is the stuck robots grown by some
hops through the Eq. 4 neighbour graph (plus the robots stuck in earlier attempts), each
attempt with its own kernel seed. The first attempt in which every robot reaches its
destination *without lengthening the first run's fold* is taken at once; otherwise the
shortest complete attempt, once :data:`EXTRA_ATTEMPTS` more have been made after the
first complete one (or the ladder is spent, or :data:`PATIENCE` attempts in a row
made no progress). A re-run is a whole stepwise run, so the step rule holds for every
robot at every step and the plan is collision-free at the planning buffer for the same
reason as any other (the pipeline's independent 2D check looks at it as at any plan).
When no attempt completes, the attempt with the fewest stuck robots is returned for the
next resolver (the state-time search, which the solver then starts from step 0: the
stuck robots' wandering is no lead-in worth keeping).

Measured on the 500-robot SDSS-V layout, 20 seeded deadlocked cases at 2.0-3.5 mm
(benchmarks/RESULTS.md, S10): one attempt 0.05-0.25 s; with a two-hop region and
(greed 0.8, phobia 0.3), 17 of 20 cases resolved with the fold at 0.99-1.05 of the first
run's (the search took 0.6-50 s a case, and its folds were 1.0-3.3 times the first run's).

Units: planner steps; wall time in s.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from rfp_twin.planners.stepwise import ANGLE_EPS, StepRun

#: The attempts, in order: (hops the region grows from the stuck robots, greed, phobia)
#: of the region's greedy-first Markov robots.
LADDER = ((2, 0.8, 0.3), (2, 0.8, 0.3), (3, 0.9, 0.2), (1, 0.8, 0.3), (3, 0.8, 0.3),
          (2, 0.5, 0.5), (0, 0.8, 0.3), (3, 0.5, 0.5))

#: Attempts made after the first complete one, looking for a shorter fold.
EXTRA_ATTEMPTS = 2

#: While no attempt is complete, the ladder stops after this many attempts in a row that
#: leave no fewer robots stuck than the best so far (a group none of them untangles
#: is left to the search; each attempt is a whole run, ~2 s at 12,871 robots).
PATIENCE = 2

#: An attempt stops after this many times the first run's fold (:func:`arrival_steps`):
#: by then it has failed (a complete attempt that late would lengthen the fold by as
#: much), and an attempt handed to the search with robots still stuck ends there. Its
#: robots around the stuck ones go on stepping aside until then, so the cap is also how
#: much such a plan can lengthen the fold: 1.25 made the folds at 3.5 mm a median 25 %
#: longer than the search alone; 1.05 lost complete attempts at 2.5 mm.
STEP_CAP = 1.10

#: One kernel run: (greed (n,), phobia (n,), greedy_first (n,) bool, seed, max_steps) ->
#: StepRun.
RunFn = Callable[[np.ndarray, np.ndarray, np.ndarray, int, int], StepRun]


@dataclass
class Rerun:
    """What :func:`rerun_deadlocks` found.

    Attributes
    ----------
    solved : StepRun or None, the complete attempt taken (every robot at its destination)
    fewest : StepRun, the attempt with the fewest stuck robots (the first run when no
        attempt did better); equal to ``solved`` when one was found
    attempts : int, kernel runs made
    seconds : float, wall time of all of them
    """

    solved: StepRun | None
    fewest: StepRun
    attempts: int
    seconds: float


def grow_region(pairs: np.ndarray, seed_mask: np.ndarray, hops: int) -> np.ndarray:
    """Robots within ``hops`` steps of ``seed_mask`` through the neighbour pairs.

    pairs : (p, 2) int robot index pairs (the Eq. 4 neighbour graph); seed_mask : (n,) bool.
    Returns a new (n,) bool mask.
    """
    region = np.asarray(seed_mask, dtype=bool).copy()
    for _ in range(hops):
        grown = region.copy()
        grown[pairs[region[pairs[:, 0]], 1]] = True
        grown[pairs[region[pairs[:, 1]], 0]] = True
        if np.array_equal(grown, region):
            break
        region = grown
    return region


def stuck_mask(run: StepRun, goal: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """(n,) bool: movable robots that the run left away from ``goal`` (n, 2) deg."""
    return movable & ~np.all(np.abs(run.final - goal) < ANGLE_EPS, axis=1)


def arrival_steps(run: StepRun, stuck: np.ndarray) -> int:
    """Steps until the last robot that reached its destination in ``run`` got there: the
    run's fold without the stuck robots, which may go on moving now and then until the
    run stops (at most ``run.n_steps``). ``stuck`` (n,) bool."""
    last = np.full(stuck.size, -1, dtype=np.int64)
    np.maximum.at(last, run.ev_robot, run.ev_step)
    arrived = last[~stuck]
    if arrived.size == 0 or arrived.max() < 0:
        return int(run.n_steps)
    return int(min(run.n_steps, arrived.max() + 1))


def rerun_deadlocks(first: StepRun, goal: np.ndarray, movable: np.ndarray, pairs: np.ndarray,
                    greed: float, phobia: float, run: RunFn, seed: int,
                    attempts: int = len(LADDER)) -> Rerun:
    """Re-run the plan with greedy-first Markov regions around the robots ``first`` left stuck.

    first : the plan's run (it left some robots stuck); goal : (n, 2) deg, its destinations;
    movable : (n,) bool; pairs : (p, 2) neighbour pairs; greed, phobia : every other
    robot's parameters (1 and 0 for a greedy plan); run : one kernel run (:data:`RunFn`);
    seed : base of the attempts' kernel seeds; attempts : at most that many runs (the
    ladder is cycled with new seeds beyond its length).
    """
    clock = time.perf_counter()
    stuck = stuck_mask(first, goal, movable)
    fold = arrival_steps(first, stuck)
    max_steps = max(1, int(np.ceil(STEP_CAP * fold)))
    seen = stuck.copy()              # robots stuck in the first run or any attempt
    fewest, fewest_stuck = first, int(stuck.sum())
    stale = 0                        # attempts in a row without fewer stuck robots
    solved = None
    made = 0
    first_complete = -1
    for k in range(attempts):
        hops, g, p = LADDER[k % len(LADDER)]
        region = grow_region(pairs, seen, hops) & movable
        attempt = run(np.where(region, g, greed), np.where(region, p, phobia),
                      region.copy(), int(seed) + 7 * k + 1, max_steps)
        made += 1
        left = stuck_mask(attempt, goal, movable)
        n_left = int(left.sum())
        if n_left == 0:
            if solved is None or attempt.n_steps < solved.n_steps:
                solved = attempt
            if first_complete < 0:
                first_complete = k
            if attempt.n_steps <= fold:
                break                # complete, and the fold is no longer than the plan's
        elif n_left < fewest_stuck:
            fewest, fewest_stuck = attempt, n_left
            stale = 0
        else:
            stale += 1
        seen |= left
        if 0 <= first_complete <= k - EXTRA_ATTEMPTS:
            break
        if first_complete < 0 and stale >= PATIENCE:
            break
    return Rerun(solved, solved if solved is not None else fewest, made,
                 time.perf_counter() - clock)
