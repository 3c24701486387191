"""Prioritized roadmap planning in state-time (Sabater et al. 2018), for any robot model.

Sabater et al. 2018 ("Roadmap search based motion planning for MIRADAS probe arms",
JATIS 4(3) 034001) plan arms one at a time in priority order; an arm planned later
treats the trajectories of the arms planned before it as moving obstacles. For one arm
(their Algorithm 2) a roadmap of straight joint-space paths is searched cheapest first,
each path in state-time (position along the path x time). The robot model is reached
only through two vectorised black boxes per arm, ``forbidden(q)`` and ``collides(q, t)``;
units are the caller's. Randomness comes from a ``numpy.random.Generator``: same seed,
same result.

Modules: :mod:`~rfp_twin.planners.roadmap.arm` (inputs, settings, outputs),
:mod:`~rfp_twin.planners.roadmap.graph` (the roadmap, Sect. 6.1), :mod:`~rfp_twin.planners.roadmap.search`
(depth-first state-time search, Sect. 6.4, Algorithms 3-6),
:mod:`~rfp_twin.planners.roadmap.sweep` (the same graph, one time layer at a time),
:mod:`~rfp_twin.planners.roadmap.planner` (one arm, Algorithm 2), :mod:`~rfp_twin.planners.roadmap.priority`
(many arms: search over priorities). Its robots, each a subpackage imported by its path:
:mod:`~rfp_twin.planners.roadmap.alpha_beta` (alpha/beta arrays on the stepwise planners'
step clock: the robot's black boxes among the others' paths, shared with the deadlock
search, and every robot planned, ``PlannerSettings(algorithm="roadmap")``) and
:mod:`~rfp_twin.planners.roadmap.probe` (MIRADAS probe arms).
"""
from rfp_twin.planners.roadmap.arm import Arm, ArmTrajectory, RoadmapSettings, SearchStats
from rfp_twin.planners.roadmap.graph import Roadmap, build_roadmap, edge_time
from rfp_twin.planners.roadmap.planner import goal_clear_after, plan_arm
from rfp_twin.planners.roadmap.priority import PrioritySearchResult, priority_search

__all__ = [
    "Arm", "ArmTrajectory", "PrioritySearchResult", "Roadmap", "RoadmapSettings",
    "SearchStats", "build_roadmap", "edge_time", "goal_clear_after", "plan_arm",
    "priority_search",
]
