"""Sabater's roadmap planner on alpha/beta arrays, on the stepwise planners' step clock.

What the deadlock search (:mod:`rfp_twin.planners.deadlocks.search`) and the roadmap
planner of every robot (``PlannerSettings(algorithm="roadmap")``) share: one alpha/beta
robot's black boxes among the others' stepwise paths.

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
array
    :func:`~rfp_twin.planners.roadmap.alpha_beta.array.roadmap_pass`, the prioritized
    planner over every robot of an array (imported by its module path).

Units: mm and degrees; time in planner steps.
"""
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.roadmap.alpha_beta.settings import SearchResolveSettings
from rfp_twin.planners.roadmap.alpha_beta.world import AlphaBetaWorld

__all__ = ["AlphaBetaWorld", "PathSet", "SearchResolveSettings"]
