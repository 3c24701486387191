"""The search as a deadlock strategy of the chain: :class:`SearchResolver`.

Each deadlocked group left in the round is re-planned by :func:`.resolve.resolve_groups`
against the other robots' paths of the round's run, keeping every target; the searched
paths become the plan's. After a replacement the same search plans the groups whose
robot got a new target again, in place (:meth:`SearchResolver.search_replaced`, handed to
the replacement strategy by the chain).

Units: deg; md in mm; time in planner steps.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from rfp_twin.planners.deadlocks.resolver import Round
from rfp_twin.planners.deadlocks.search.resolve import GroupResult, SearchOutcome, resolve_groups
from rfp_twin.planners.plan.settings import PlannerSettings
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings


@dataclass(frozen=True)
class SearchRecord:
    """What the search did in one round: groups it could not resolve (``failed_groups``)
    and its wall time (``seconds``). What the final plan owes the search is read off its
    paths (:func:`search_counts`)."""

    failed_groups: int
    seconds: float


def search_counts(outcome: SearchOutcome | None) -> tuple[int, int, int]:
    """(groups, deadlocked robots) a plan's search resolved and the robots whose paths it
    changed (recruited neighbours included); zeros without a search."""
    if outcome is None:
        return 0, 0, 0
    ok = [g for g in outcome.groups if g.success]
    return (len(ok), int(sum(len(g.group) for g in ok)), int(sum(len(g.members) for g in ok)))


class SearchResolver:
    """State-time search of each deadlocked group, keeping its targets
    (``settings.search``, or the defaults). Its memo of results by group and
    surroundings lasts across the rounds of one plan (greedy plans only)."""

    def __init__(self, settings: PlannerSettings) -> None:
        self.settings = settings
        self.search_settings = settings.search or SearchResolveSettings()
        self.memo: dict = {}

    def applies(self, rnd: Round) -> bool:
        return True

    def resolve(self, rnd: Round) -> SearchRecord:
        s = self.settings
        # after a partial whole-array re-run the stuck robots wandered until the cap:
        # keeping that motion as their lead-in would delay the fold, so search from step 0
        options = replace(self.search_settings, step0_first=True) if rnd.partial \
            else self.search_settings
        # its own generator (from the round's seed) leaves the plan's as replacement uses it
        outcome = resolve_groups(rnd.geom, PathSet.from_csr(*rnd.run_paths()), rnd.run.n_steps,
                                 rnd.groups, rnd.start, rnd.goal, rnd.movable, rnd.md,
                                 s.step_deg, options, np.random.default_rng([rnd.seed, 1]),
                                 memo=self.memo if s.greedy else None)
        rnd.search = outcome
        rnd.groups, rnd.hardest = outcome.failed, outcome.failed_hardest
        rnd.stuck = rnd.stuck.copy()
        rnd.stuck[outcome.resolved_robots] = False
        return SearchRecord(len(rnd.groups), outcome.seconds)

    def search_replaced(self, rnd: Round, old_targets: np.ndarray, targets: np.ndarray,
                        start: np.ndarray, goal: np.ndarray) -> SearchOutcome:
        """The search again on the groups of ``rnd`` it could not resolve, now that one
        robot of each has a new target (``targets`` (n, 2) deg, were ``old_targets``),
        against the searched paths of ``rnd`` (everyone else keeps the plan made so far).
        A robot with a new target has no lead-in: its path is reset to standing at its
        start (``start``, ``goal`` : (n, 2) deg, the planning frame's, new targets in).
        Groups without a new robot are not searched again and count as failed."""
        outcome, groups = rnd.search, rnd.groups
        moved = np.any(targets != old_targets, axis=1)
        if not all(moved[g].any() for g in groups):
            return SearchOutcome(outcome.paths, outcome.n_steps,
                                 [GroupResult(np.asarray(g), np.asarray(g), False, 0, 0.0)
                                  for g in groups])
        paths = PathSet(list(outcome.paths.steps), list(outcome.paths.angles))
        for i in np.flatnonzero(moved):
            paths.steps[i] = np.zeros(1)
            paths.angles[i] = start[i][None, :].astype(np.float64)
        return resolve_groups(rnd.geom, paths, outcome.n_steps, groups, start, goal, rnd.movable,
                              rnd.md, self.settings.step_deg,
                              replace(self.search_settings, step0_first=True),
                              np.random.default_rng([rnd.seed, 2]))
