"""Settings of the deadlock-resolving search: :class:`SearchResolveSettings`.

The search (:mod:`rfp_twin.planners.deadlocks.search.resolve`) plans each robot with the roadmap /
state-time planner of :mod:`rfp_twin.planners.roadmap` (Sabater 2018) on the stepwise planner's
step clock; :meth:`SearchResolveSettings.roadmap_settings` converts these settings to
that clock (one action = a whole number of planner steps).

Units: deg; the search's time unit is one planner step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.planners.roadmap import RoadmapSettings


@dataclass(frozen=True)
class SearchResolveSettings:
    """How the search resolves a deadlocked group.

    Attributes
    ----------
    action_deg : float, motion of one search action (Sabater's dt at full speed), deg;
        rounded to a whole number of planner steps (at least one)
    n_stop : int or None, start-stop cycles allowed per robot (nSSC); None = unlimited
        (stepwise plans stop and restart freely; post-processing smooths them)
    grid : (n_alpha, n_beta) roadmap grid over the joint limits
    n_random_edges : int, random vertex pairs (3-edge paths)
    max_paths : int, paths tried per robot and departure
    max_nodes : int, state-time nodes expanded per robot (all its paths)
    priority_nodes : int, nodes of the search over priorities per group and start
        (:func:`rfp_twin.planners.roadmap.priority_search`)
    resume_edges : bool, see :class:`rfp_twin.planners.roadmap.RoadmapSettings`
    max_recruits : int, most non-deadlocked neighbours that may join a group to make way
        for a robot they block (re-planned below it, free to leave their stepwise paths)
    max_departures : int, times at which a deadlocked robot may leave the stepwise
        motion it made before it got stuck (latest first)
    depart_at_start : bool, one of them is step 0 (leave that motion at once). Off by
        default: each group is also searched from step 0 without lead-ins (the other
        pass of :func:`rfp_twin.planners.deadlocks.search.resolve.search_group`), and a
        single-robot plan that finds a trajectory almost always finds it at the first
        departures, while failing plans spend a quarter of their time on this one
    search : "sweep" (earliest arrival, one time layer at a time) | "dfs" (Sabater's
        depth-first search); see :class:`rfp_twin.planners.roadmap.RoadmapSettings`
    step0_first : search each group from step 0 first, then with the lead-ins (False:
        lead-ins first). A Markov run that deadlocks goes on to its step limit, its
        stuck robots stepping about all that time: keeping that motion delays the fold
        by the rest of the step limit, so the solver sets this for Markov plans.
    """

    action_deg: float = 2.0
    n_stop: int | None = None
    grid: tuple[int, int] = (25, 25)
    n_random_edges: int = 16
    max_paths: int = 300
    max_nodes: int = 200_000
    priority_nodes: int = 32
    resume_edges: bool = True
    max_recruits: int = 16
    max_departures: int = 4
    depart_at_start: bool = False
    search: str = "sweep"
    step0_first: bool = False

    def __post_init__(self) -> None:
        where = "SearchResolveSettings"
        if not (math.isfinite(self.action_deg) and self.action_deg > 0):
            raise field_error(SpecError, "action_deg", self.action_deg, "> 0 deg", where)
        if self.priority_nodes < 1:
            raise field_error(SpecError, "priority_nodes", self.priority_nodes, ">= 1", where)
        if self.max_recruits < 0:
            raise field_error(SpecError, "max_recruits", self.max_recruits, ">= 0", where)

    def roadmap_settings(self, step_deg: float) -> RoadmapSettings:
        """Roadmap settings on the step clock (time unit: one planner step)."""
        k = max(1, int(round(self.action_deg / step_deg)))
        return RoadmapSettings(dt=float(k), dt_col=1.0, n_stop=self.n_stop, grid=tuple(self.grid),
                               n_random_edges=self.n_random_edges, corner_vertices=True,
                               max_paths=self.max_paths, max_nodes=self.max_nodes,
                               resume_edges=self.resume_edges, edge_check_step=step_deg,
                               max_departures=self.max_departures,
                               depart_at_start=self.depart_at_start, search=self.search)
