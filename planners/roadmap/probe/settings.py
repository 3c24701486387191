"""ProbePlanSettings: Sabater et al. 2018's planning parameters for probe arms (Sect. 8).

Defaults are the paper's: an 8 x 6 roadmap grid with random extra edges (more than 64
routes per arm), routes estimated over 120 s discarded, ``dt`` = 6 s motion actions,
``dt_col`` = 100 ms collision checks, at most one start-stop cycle per arm, priorities
by estimated travel time. Units: s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from rfp_twin.models.errors import SpecError, field_error

#: Priority policies: the paper's (longest estimated travel time first); the same with
#: the arms that do not move first (they are then fixed obstacles the others avoid,
#: instead of arms that must dodge them with one start-stop cycle); a random order
#: drawn from the plan's generator.
PRIORITIES = ("travel-time", "still-first", "random")


@dataclass(frozen=True)
class ProbePlanSettings:
    """How probe arms are planned.

    Attributes
    ----------
    dt_s : float, duration of one motion action (Sabater's Delta t), s
    dt_col_s : float, collision-check spacing (Delta t_col), s; dt / dt_col whole
    max_start_stop : int, start-stop cycles allowed per arm (nSSC)
    grid : (int, int), roadmap grid points per joint (theta1, theta2)
    n_random_edges : int, random disjoint vertex pairs tried as extra edges (each feasible
        one gives two routes; 24 uses about every vertex of the 8 x 6 grid)
    min_routes : int, routes per arm at least (Sect. 8: more than 64), made up with
        further random vertex pairs when the disjoint random edges leave fewer
    max_path_time_s : float, routes with a longer estimated travel time (Eq. 5) are
        discarded
    horizon_s : float, T_f: nodes at or after this time are not expanded, so every arm
        arrives by then (the paper's 120 s configuration-time goal)
    replans : int, passes after a failed one, each with the arm that failed first in the
        order (Sect. 2.1: "replanning with a different arm-priority scheme"); 0 = the one
        pass of the paper's experiments (Sect. 8)
    search_nodes : int, when the passes fail: priority-based search (Ma et al. 2019) with
        at most this many search-tree nodes (0: none, the paper's planner)
    priority : "travel-time" (Sect. 7) | "still-first" | "random" (:data:`PRIORITIES`)
    windows_s : tuple of float, make-way windows tried in turn when the passes fail, s:
        passes in which each arm that found no trajectory in an earlier pass, while not
        yet planned, stands at its start for the first ``w`` s, so that arms planned
        before it wait for it to leave (each window with the re-plans); () = none, the
        paper's planner
    retreat_deg : tuple of float, in every pass after the first, each roadmap also gets its
        start and goal with theta1 raised by these amounts (retreats towards the park
        side) and three stop-overs on its direct route, deg (Sect. 9's "garage" idea)
    """

    dt_s: float = 6.0
    dt_col_s: float = 0.1
    max_start_stop: int = 1
    grid: tuple[int, int] = (8, 6)
    n_random_edges: int = 24
    min_routes: int = 64
    max_path_time_s: float = 120.0
    horizon_s: float = 120.0
    priority: str = "travel-time"
    replans: int = 0
    search_nodes: int = 0
    windows_s: tuple[float, ...] = ()
    retreat_deg: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        where = "ProbePlanSettings"
        for name in ("dt_s", "dt_col_s", "max_path_time_s", "horizon_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise field_error(SpecError, name, v, "a finite number > 0 s", where)
        ratio = self.dt_s / self.dt_col_s
        if abs(ratio - round(ratio)) > 1e-9:
            raise field_error(SpecError, "dt_col_s", self.dt_col_s, "dt_s / n for a whole n", where)
        if not isinstance(self.max_start_stop, int) or self.max_start_stop < 0:
            raise field_error(SpecError, "max_start_stop", self.max_start_stop, "an integer >= 0",
                              where)
        if len(self.grid) != 2 or any(int(g) < 1 for g in self.grid):
            raise field_error(SpecError, "grid", self.grid, "two integers >= 1", where)
        if self.n_random_edges < 0:
            raise field_error(SpecError, "n_random_edges", self.n_random_edges, ">= 0", where)
        if not isinstance(self.replans, int) or self.replans < 0:
            raise field_error(SpecError, "replans", self.replans, "an integer >= 0", where)
        if not isinstance(self.search_nodes, int) or self.search_nodes < 0:
            raise field_error(SpecError, "search_nodes", self.search_nodes, "an integer >= 0",
                              where)
        for name in ("windows_s", "retreat_deg"):
            v = getattr(self, name)
            if not isinstance(v, tuple) or not all(
                    isinstance(x, (int, float)) and math.isfinite(x) and x > 0 for x in v):
                raise field_error(SpecError, name, v, "a tuple of finite numbers > 0", where)
        if self.priority not in PRIORITIES:
            raise field_error(SpecError, "priority", self.priority, ", ".join(PRIORITIES), where)


#: The paper's planner followed by what it leaves unsolved going to our recovery: up to 8
#: re-plans with the failing arm first, then make-way windows of 12 / 24 / 36 s, retreat
#: and stop-over vertices in every pass after the first (the first pass is the paper's).
RECOVERING = dict(replans=8, windows_s=(12.0, 24.0, 36.0), retreat_deg=(15.0, 30.0, 45.0))
