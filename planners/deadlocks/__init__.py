"""Deadlock resolution: what the planner's run left stuck, resolved strategy by strategy.

Every strategy is a :class:`~rfp_twin.planners.deadlocks.resolver.Resolver` working on a
:class:`~rfp_twin.planners.deadlocks.resolver.Round` and returning a typed record of what
it did; :mod:`.chain` holds their order and builds the plan's metrics from the records.
The strategies do not import each other (an import contract in pyproject.toml): what one
needs of another is handed in by the chain.

Modules
-------
resolver
    The :class:`Resolver` interface and the :class:`Round` the strategies work on.
groups
    Stuck robots and their groups (Eq. 4 neighbour graph), read off a stepwise run.
chain
    The strategies in order, and the metrics of what they did.
fold_repair
    A beta-first switch of the neighbour that holds up the robot ending the run.
rerun
    The planner again, locally, with greedy-first Markov robots around each group.
search
    State-time search of each group after Sabater 2018, keeping its targets.
continuation
    The groups the search left go on alone after the plan's end, with Markov moves.
replacement
    One new target per group left (Sayres 2021 Sect. 5.2), searched again in place.

Units: angles in deg, lengths in mm, time in planner steps.
"""
from __future__ import annotations

from rfp_twin.models.lazy import lazy_exports

_LAZY = {
    **dict.fromkeys(("Resolver", "Round", "Record"), "rfp_twin.planners.deadlocks.resolver"),
    **dict.fromkeys(("Chain", "resolution_chain", "resolution_metrics"),
                    "rfp_twin.planners.deadlocks.chain"),
    **dict.fromkeys(("deadlocked_groups", "stuck_mask"), "rfp_twin.planners.deadlocks.groups"),
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
