"""Deadlock resolution that keeps targets: Sabater's state-time search for alpha/beta robots.

A group of robots the stepwise planner (:mod:`rfp_twin.planners.stepwise`) leaves
deadlocked is re-planned by prioritized state-time search (Sabater 2018) against the
other robots' stepwise paths; the new paths are merged into the plan on the same step
clock. The robot's black boxes, the paths and the settings are those of
:mod:`rfp_twin.planners.roadmap.alpha_beta` (re-exported here).

Modules
-------
resolve
    :func:`resolve_groups` / :func:`search_group`, the search over priorities per group,
    and its outcome (:class:`SearchOutcome`, :class:`GroupResult`).
trim
    :func:`trim_tails`, cutting the detours robots make after arriving.
strategy
    :class:`SearchResolver`, the search as a strategy of the deadlock chain.

Units: mm and degrees; time in planner steps.
"""
from rfp_twin.planners.deadlocks.search.resolve import (GroupResult, SearchOutcome, resolve_groups,
                                                        search_group)
from rfp_twin.planners.deadlocks.search.trim import trim_tails
from rfp_twin.planners.roadmap.alpha_beta import AlphaBetaWorld, PathSet, SearchResolveSettings

__all__ = ["AlphaBetaWorld", "GroupResult", "PathSet", "SearchOutcome", "SearchResolveSettings",
           "resolve_groups", "search_group", "trim_tails"]
