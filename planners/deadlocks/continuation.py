"""Deadlock resolution by continuation: the stuck groups go on alone, with Markov moves.

When the reverse planner stops, every robot that is not deadlocked has reached its
destination and stands still there. A deadlocked group is then boxed in only by its own
members and by neighbours that are folded (compact) and static. Running the stepwise
kernel again from that state, with only the group's robots movable and the Markov
chain's random moves (Sayres 2021 Sect. 4.2: greed < 1, phobia > 0), often untangles
arms that the greedy descent had locked together, since all members move at once
(a coordinated motion that prioritized planning cannot express).

The continuation is appended to the plan after its last step, so its motion happens
while every other robot stands still; the stepwise kernel's step rule holds throughout,
so the plan stays collision-free at the planning buffer. Played backwards (reverse
planning) the group unfolds first, alone, and the rest of the plan follows.

Groups are connected components of stuck robots through the Eq. 4 neighbour graph, so
no robot of one group can touch a robot of another: each group's continuation is
independent of the others' and a group's result can be taken from any attempt.

:class:`ContinuationResolver` is the strategy of the chain: it takes the groups the
search left and appends their continuation to the searched paths.

Units: degrees, planner steps.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from rfp_twin.models.second_thread import second_thread
from rfp_twin.planners.deadlocks.resolver import Round
from rfp_twin.planners.plan import build_paths
from rfp_twin.planners.plan.runs import run_once
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.stepwise import ANGLE_EPS

#: (greed, phobia) of the successive attempts: greedy first, then more and more random.
ATTEMPTS = ((0.9, 0.3), (0.8, 0.3), (0.7, 0.4), (0.6, 0.5), (0.9, 0.3), (0.7, 0.4),
            (0.5, 0.5), (0.6, 0.6))


@dataclass
class Continuation:
    """What :func:`continue_groups` found.

    Attributes
    ----------
    paths : {robot index: (steps (k,) float64 from 0, angles (k, 2) deg)} of every robot
        of every group that reached its destination (steps counted from the start of
        the continuation)
    solved : list of int, indices (into the groups given) of the groups that made it
    attempts : int, kernel runs made
    seconds : float, wall time
    """

    paths: dict = field(default_factory=dict)
    solved: list = field(default_factory=list)
    attempts: int = 0
    seconds: float = 0.0


@dataclass(frozen=True)
class ContinuationRecord:
    """What the continuation did in one round: ``groups`` / ``robots`` it resolved and
    its wall time (``seconds``)."""

    groups: int
    robots: int
    seconds: float


class ContinuationResolver:
    """The groups the search left go on alone after the plan's end
    (:func:`continue_groups`, at most ``settings.continuation`` Markov runs); their
    motion is appended to the searched paths."""

    def __init__(self, settings: PlannerSettings) -> None:
        self.settings = settings

    def applies(self, rnd: Round) -> bool:
        return rnd.search is not None          # it continues the searched paths

    def resolve(self, rnd: Round) -> ContinuationRecord:
        s, geom, outcome = self.settings, rnd.geom, rnd.search
        paths = outcome.paths
        now = np.array([a[-1] for a in paths.angles])

        def run(start, dest, movable, greed, phobia, seed):
            return run_once(geom, start, dest, movable,
                            replace(s, algorithm="markov", greed=greed, phobia=phobia), seed)

        cont = continue_groups(geom.n_robots, now, rnd.goal, rnd.groups, run, rnd.seed + 7919,
                               s.continuation)
        offset = float(outcome.n_steps)
        for i, (st, an) in cont.paths.items():
            keep = paths.steps[i] < offset          # i stands still from its last motion on
            paths.steps[i] = np.concatenate([paths.steps[i][keep], offset + st])
            paths.angles[i] = np.vstack([paths.angles[i][keep], an])
            outcome.n_steps = max(outcome.n_steps, int(np.ceil(offset + st[-1])))
        rnd.stuck[list(cont.paths)] = False
        rnd.groups = [g for k, g in enumerate(rnd.groups) if k not in cont.solved]
        rnd.hardest = [h for k, h in enumerate(rnd.hardest) if k not in cont.solved]
        return ContinuationRecord(len(cont.solved), len(cont.paths), cont.seconds)


def continue_groups(n: int, final: np.ndarray, dest: np.ndarray, groups: list[np.ndarray],
                    run: Callable[[np.ndarray, np.ndarray, np.ndarray, float, float, int], object],
                    seed: int, attempts: int = len(ATTEMPTS)) -> Continuation:
    """Let each deadlocked group go on alone from where the planner stopped.

    Parameters
    ----------
    n : int, robots in the array
    final : (n, 2) deg, where every robot stands when the planner stopped
    dest : (n, 2) deg, every robot's destination (planning frame)
    groups : deadlocked groups (robot index arrays), disjoint, not Eq. 4 neighbours of
        each other
    run : callable ``(start (n, 2), dest (n, 2), movable (n,) bool, greed, phobia, seed)``
        -> an object with ``final``, ``n_steps``, ``ev_robot``, ``ev_step``, ``ev_angles``
        (one stepwise kernel run, :func:`rfp_twin.planners.plan.runs.run_once`)
    seed : int, seed of the first attempt (attempt a uses ``seed + a``)
    attempts : kernel runs at most (greed / phobia from :data:`ATTEMPTS`, cycled); two
        run at once (the second on :func:`rfp_twin.models.second_thread.second_thread`,
        which must not be the caller's thread), with the same results as one at a time

    Returns
    -------
    Continuation
    """
    clock = time.perf_counter()
    out = Continuation()
    final = np.ascontiguousarray(final, dtype=np.float64)
    dest = np.ascontiguousarray(dest, dtype=np.float64)
    todo = list(range(len(groups)))
    attempts = max(0, attempts)

    def start(a: int):
        """Attempt a on the groups still to do: (its run's arguments)."""
        movable = np.zeros(n, dtype=bool)
        for g in todo:
            movable[groups[g]] = True
        greed, phobia = ATTEMPTS[a % len(ATTEMPTS)]
        return final, dest, movable, greed, phobia, seed + a

    a = 0
    while a < attempts and todo:
        # attempts a and a + 1 at once, a + 1 on the second core as if a solves no group
        # (most attempts do not); it counts only then, else it is run again after a
        ahead = second_thread().submit(run, *start(a + 1)) if a + 1 < attempts else None
        try:
            solved = _take(out, n, groups, todo, dest, final, run(*start(a)))
        except BaseException:
            if ahead is not None:
                ahead.cancel()
            raise
        a += 1
        if ahead is not None and (solved or not todo):
            ahead.cancel()           # started already: it ends on its own, unused
        elif ahead is not None:
            _take(out, n, groups, todo, dest, final, ahead.result())
            a += 1
    out.seconds = time.perf_counter() - clock
    return out


def _take(out: Continuation, n: int, groups: list[np.ndarray], todo: list[int],
          dest: np.ndarray, final: np.ndarray, r) -> bool:
    """Record attempt ``r`` in ``out``: the groups of ``todo`` whose members all arrived
    (removed from ``todo``) with their paths. Returns whether any group was solved."""
    out.attempts += 1
    arrived = np.all(np.abs(r.final - dest) < ANGLE_EPS, axis=1)
    ptr, steps, angles = build_paths(n, r.ev_robot, r.ev_step, r.ev_angles, final, r.final,
                                     r.n_steps)
    solved = False
    for g in list(todo):
        members = groups[g]
        if not arrived[members].all():
            continue
        for i in members:
            i = int(i)
            out.paths[i] = (steps[ptr[i]:ptr[i + 1]].copy(), angles[ptr[i]:ptr[i + 1]].copy())
        out.solved.append(g)
        todo.remove(g)
        solved = True
    return solved
