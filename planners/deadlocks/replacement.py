"""Target replacement when the other strategies fail (Sayres 2021 Sect. 5.2), and the
replaced groups searched again in place.

:func:`replace_one` gives one robot of a deadlocked group a new random target.
:class:`ReplacementResolver` is the last strategy of the chain: after a round with groups
left it replaces one target per group; when a search re-planned the round, that search
then plans the replaced groups alone again against everyone else's paths of the plan so
far (*local replacement*, the search handed in by the chain). Only when a group still
fails, or the new paths would lengthen the plan, does a whole new round follow.

Units: deg; md in mm; time in planner steps.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.planners.deadlocks.resolver import Round, SearchedPlan
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.plan.targets import random_targets

#: The search of the replaced groups in place: (round, old targets (n, 2), new targets
#: (n, 2), start (n, 2), goal (n, 2) deg) -> the plan as it left it.
SearchAgain = Callable[[Round, np.ndarray, np.ndarray, np.ndarray, np.ndarray], SearchedPlan]


@dataclass(frozen=True)
class ReplacementRecord:
    """What the replacement did after one round: ``groups`` given a new target,
    ``local_groups`` the search then resolved in place (0: a new round follows), and the
    wall time of that search (``seconds``)."""

    groups: int
    local_groups: int
    seconds: float


def replace_one(geom: ArrayGeometry, rng: np.random.Generator, targets: np.ndarray,
                group: np.ndarray, margin_mm: float, first: int = -1) -> np.ndarray:
    """New random target for one robot of a deadlocked group (Sayres 2021 Sect. 5.2).

    Members are tried in random order (``first``, if given, before them: the robot the
    search could not plan); one whose neighbourhood leaves no clear spot is skipped.
    Returns the updated (n, 2) targets (unchanged if no member fits).
    """
    order = rng.permutation(group)
    if first >= 0:
        order = np.concatenate([[first], order[order != first]])
    for i in order:
        keep = np.ones(geom.n_robots, dtype=bool)
        keep[i] = False
        try:
            return random_targets(geom, rng, fixed=keep, initial=targets, margin_mm=margin_mm,
                                  robots=np.array([i]), attempts=1)
        except TargetError:
            continue
    return targets


class ReplacementResolver:
    """One new target per group left (drawn from ``rng``, the plan's generator), then the
    local search if ``search_again`` is given and the round was searched."""

    def __init__(self, settings: PlannerSettings, rng: np.random.Generator,
                 search_again: SearchAgain | None = None) -> None:
        self.settings = settings
        self.rng = rng
        self.search_again = search_again

    def applies(self, rnd: Round) -> bool:
        return True

    def resolve(self, rnd: Round) -> ReplacementRecord:
        # after a failed search, the robot it could least plan is the first to replace
        firsts = rnd.hardest if rnd.search is not None else [-1] * len(rnd.groups)
        old = targets = rnd.targets
        n_groups = 0
        for group, first in zip(rnd.groups, firsts):
            before = targets
            targets = replace_one(rnd.geom, self.rng, targets, group, rnd.md, first)
            n_groups += int(np.any(targets != before))
            rnd.replaced |= targets[:, 0] != rnd.original[:, 0]
            rnd.replaced |= targets[:, 1] != rnd.original[:, 1]
        rnd.targets = targets
        if rnd.search is None or self.search_again is None:
            return ReplacementRecord(n_groups, 0, 0.0)
        # first the groups alone, with their new targets, against everyone else's paths
        local = self.search_again(rnd, old, targets, rnd.start, rnd.goal)
        # taken when every group is resolved without lengthening the plan it joins (else a
        # whole new round may find a shorter one)
        if not (all(g.success for g in local.groups) and local.n_steps <= rnd.search.n_steps):
            return ReplacementRecord(n_groups, 0, local.seconds)
        n_local = len(rnd.groups)
        rnd.search, rnd.groups, rnd.hardest = local, [], []
        rnd.stuck = rnd.stuck.copy()
        rnd.stuck[local.resolved_robots] = False
        return ReplacementRecord(n_groups, n_local, local.seconds)
