"""Deadlock resolution that keeps targets: Sabater's state-time search for alpha/beta robots.

A group of robots the stepwise planner (:mod:`rfp_twin.planners.stepwise`) leaves deadlocked is
re-planned by prioritized state-time search (Sabater 2018) against the other robots'
stepwise paths; the new paths are merged into the plan on the same step clock.

Modules
-------
settings
    :class:`SearchResolveSettings`, and their conversion to the roadmap's step clock.
paths
    :class:`PathSet`, per-robot breakpoint paths on the step clock (planning frame).
kernels
    Numba kernels of the collision tests (beta segments, step rule, Eqs. 6-7).
world
    :class:`AlphaBetaWorld`, one robot's ``forbidden`` / ``collides`` black boxes.
trim
    :func:`trim_tails`, cutting the detours robots make after arriving.
resolve
    :func:`resolve_groups` / :func:`search_group`, the search over priorities per group,
    and its outcome (:class:`SearchOutcome`, :class:`GroupResult`).
strategy
    :class:`SearchResolver`, the search as a strategy of the deadlock chain.

Units: mm and degrees; time in planner steps.
"""
from rfp_twin.planners.deadlocks.search.paths import PathSet
from rfp_twin.planners.deadlocks.search.resolve import GroupResult, SearchOutcome, resolve_groups, search_group
from rfp_twin.planners.deadlocks.search.settings import SearchResolveSettings
from rfp_twin.planners.deadlocks.search.trim import trim_tails
from rfp_twin.planners.deadlocks.search.world import AlphaBetaWorld

__all__ = ["AlphaBetaWorld", "GroupResult", "PathSet", "SearchOutcome", "SearchResolveSettings",
           "resolve_groups", "search_group", "trim_tails"]
