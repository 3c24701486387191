"""What the roadmap planner works on and returns: Arm, RoadmapSettings, ArmTrajectory.

The planner of Sabater et al. 2018 reaches the robot model only through black boxes
(their Sect. 4.1): per arm ``forbidden(q)`` (the zone of avoidance: joint limits, static
obstacles) and ``collides(q, t)`` (moving obstacles, i.e. the arms planned before and
anything else that moves on a known schedule). Both are vectorised: ``q`` is ``(m, d)``,
``t`` is ``(m,)`` and they return ``(m,)`` bool. Units are the caller's: joint units
(e.g. deg) and time units (e.g. s, or planner steps), ``vmax`` in joint units per time
unit.

Beyond the paper: ``Arm.t_static`` (after this time the obstacles no longer move, so
waiting or backing up cannot help any more: the searches then only move forward, which
bounds them without a hand-set ``T_f``); ``Arm.lead_in`` (a motion the arm may follow
first and leave at any time, e.g. the part of an existing plan worth keeping);
``Arm.via`` (extra paths a robot model knows).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numba import njit

from rfp_twin.models.errors import SpecError, field_error


@dataclass(frozen=True)
class Arm:
    """One arm to plan, as the planner sees it: a task and two black boxes.

    Attributes
    ----------
    start, goal : (d,) float64, joint units
    vmax : (d,) float64, largest speed of each joint, joint units per time unit
    forbidden : callable ``(m, d) -> (m,) bool``, True where a configuration is in the
        zone of avoidance (joint limits, static obstacles). Must be False at start, goal.
    collides : callable ``((m, d), (m,)) -> (m,) bool``, True where the arm at ``q[k]`` at
        time ``t[k]`` touches a moving obstacle.
    lower, upper : (d,) float64, box the roadmap grid spans, joint units
    t_start : float, time at which the arm leaves ``start``
    hold_until : float, the arm must stay collision-free at ``goal`` until this time
        (goal conflicts: the arrival of the last higher-priority arm);
        :func:`rfp_twin.planners.roadmap.priority_search` raises it to the end of the arms above.
    t_static : float or None, time after which ``collides(q, t)`` no longer depends on t
        (every obstacle has stopped). Enables pruning; None = unknown.
    extra_vertices : (k, d) float64 or None, vertices added to the grid (joint units)
    lead_in : (times (k,), configs (k, d)) or None, a motion from ``start`` at
        ``t_start`` the arm may follow first and leave at any of its times (e.g. the
        part of an existing plan to keep); its last time is where it ends
    via : callable ``(start, goal) -> list of (k, d) arrays`` or None: extra roadmap
        paths ``start -> via[0] -> ... -> goal`` a robot model knows to be useful
    sweep : callable or None, a compiled replacement of the sweep search's layer loop
        with ``collides`` inside it (same queries, same result, no Python per layer):
        ``sweep(Q, D, frac, k_static, k_max, t0, dt, goal_after, nodes_left) -> (outcome
        0 found / 1 failed / 2 budget, k_end, came (k_end, P + 1) int8, nodes, checks)``,
        indices -1 for none (:func:`rfp_twin.planners.roadmap.alpha_beta.kernels.sweep_layers`)
    sweep_paths : callable or None, ``sweep`` on several paths in one call, stopping at
        the first that finds the goal, for the batched loop of
        :mod:`rfp_twin.planners.roadmap.sweep_batches` (needs ``sweep``, with the
        blocker counts it adds to as its ``hits`` attribute):
        ``sweep_paths(Qs, Ds, q_ptr, frac, k_static, k_maxs, t0, dt, goal_after,
        nodes_left, hits, stop)`` (:func:`rfp_twin.planners.roadmap.alpha_beta.kernels.sweep_paths`)
    edges_forbidden : callable or None, ``forbidden`` along many straight edges in one
        call: ``edges_forbidden(q0s (E, d), q1s (E, d), step (d,)) -> (any point forbidden
        (E,) bool, points (E,) int)``, the points as :func:`rfp_twin.planners.roadmap.graph.edge_samples`
        places them
    edge_memo : dict or None, where :func:`rfp_twin.planners.roadmap.plan_arm` keeps which
        straight edges avoid ``forbidden``: arms that share one ``forbidden`` (the same
        robot planned again with other moving obstacles) may share it, so that an edge is
        checked once (None: one memo per ``plan_arm`` call)
    """

    start: np.ndarray
    goal: np.ndarray
    vmax: np.ndarray
    forbidden: Callable[[np.ndarray], np.ndarray]
    collides: Callable[[np.ndarray, np.ndarray], np.ndarray]
    lower: np.ndarray
    upper: np.ndarray
    t_start: float = 0.0
    hold_until: float = 0.0
    t_static: float | None = None
    extra_vertices: np.ndarray | None = None
    lead_in: tuple[np.ndarray, np.ndarray] | None = None
    via: Callable[[np.ndarray, np.ndarray], list] | None = None
    sweep: Callable | None = None
    edge_memo: dict | None = None
    sweep_paths: Callable | None = None
    edges_forbidden: Callable | None = None

    @property
    def dim(self) -> int:
        return int(np.asarray(self.start).shape[0])


@dataclass(frozen=True)
class RoadmapSettings:
    """Parameters of the roadmap and of the state-time search.

    Attributes
    ----------
    dt : float, duration of one motion action (Sabater's Delta t), time units
    dt_col : float or None, collision-check spacing inside an action (Delta t_col);
        ``dt / dt_col`` must be a whole number; None = ``dt``
    n_stop : int or None, largest number of start-stop cycles per trajectory (nSSC);
        None = unlimited
    grid : tuple of int, vertices per joint of the roadmap grid (Sabater: 8 x 6)
    n_random_edges : int, random vertex pairs tried as extra edges
    corner_vertices : bool, add the axis-aligned start/goal corners as vertices
    max_paths : int or None, try at most this many paths per arm
    max_path_time : float or None, skip paths whose estimated travel time exceeds this
    t_max : float or None, T_f: nodes at or after this time are not expanded; None =
        unbounded (then every arm needs ``t_static``)
    max_nodes : int or None, budget of expanded nodes per arm (over all its paths)
    resume_edges : bool, back up into earlier edges of a path when a later one fails
        (False: Sabater's Algorithm 2, an edge's first trajectory is final)
    edge_check_step : float or None, spacing (joint units, per joint) at which edges are
        checked against ``forbidden``; None = the motion of one ``dt_col`` at ``vmax``
    max_departures : int, times tried to leave an arm's ``lead_in`` (latest first);
        ``max_paths`` applies to each
    depart_at_start : bool, with a ``lead_in``, one of those times is ``t_start`` (leave
        it at once); False drops that one (a caller that also plans the arm without its
        lead-in has tried it)
    search : "dfs" (Sabater's depth-first search, Algorithms 3-6) | "sweep" (the same
        state-time graph explored one time layer at a time: earliest arrival, much
        faster on hard searches; unlimited ``n_stop`` only)
    """

    dt: float = 1.0
    dt_col: float | None = None
    n_stop: int | None = 1
    grid: tuple[int, ...] = (8, 6)
    n_random_edges: int = 16
    corner_vertices: bool = False
    max_paths: int | None = None
    max_path_time: float | None = None
    t_max: float | None = None
    max_nodes: int | None = None
    resume_edges: bool = False
    edge_check_step: float | None = None
    max_departures: int = 4
    depart_at_start: bool = True
    search: str = "dfs"

    def __post_init__(self) -> None:
        where = "RoadmapSettings"
        if self.search not in ("dfs", "sweep"):
            raise field_error(SpecError, "search", self.search, "dfs, sweep", where)
        if self.search == "sweep" and self.n_stop is not None:
            raise field_error(SpecError, "n_stop", self.n_stop, "None with search = sweep", where)
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise field_error(SpecError, "dt", self.dt, "a finite number > 0", where)
        if self.dt_col is not None:
            r = self.dt / self.dt_col if self.dt_col > 0 else math.nan
            if not (math.isfinite(r) and r >= 1 and abs(r - round(r)) < 1e-9):
                raise field_error(SpecError, "dt_col", self.dt_col, "dt / n for a whole n >= 1", where)
        if self.n_stop is not None and self.n_stop < 0:
            raise field_error(SpecError, "n_stop", self.n_stop, "an integer >= 0 or None", where)
        if len(self.grid) == 0 or any(int(g) < 1 for g in self.grid):
            raise field_error(SpecError, "grid", self.grid, "one integer >= 1 per joint", where)
        if self.n_random_edges < 0:
            raise field_error(SpecError, "n_random_edges", self.n_random_edges, ">= 0", where)
        if self.max_nodes is not None and self.max_nodes < 1:
            raise field_error(SpecError, "max_nodes", self.max_nodes, ">= 1 or None", where)

    @property
    def n_sub(self) -> int:
        """Collision checks per action (dt / dt_col)."""
        return 1 if self.dt_col is None else int(round(self.dt / self.dt_col))


@dataclass(frozen=True)
class ArmTrajectory:
    """A planned arm motion: breakpoints, linearly interpolated; holds after the end.

    Attributes
    ----------
    times : (k,) float64, non-decreasing, time units
    configs : (k, d) float64, joint units
    path : (p, d) float64, the roadmap path followed (start, vertices..., goal)
    n_start_stop : int, start-stop cycles (Sabater's ns; vertex stops included)
    n_go, n_stop_steps : int, actions moving / standing still (Table 2's n dt go / stop)
    """

    times: np.ndarray
    configs: np.ndarray
    path: np.ndarray
    n_start_stop: int
    n_go: int
    n_stop_steps: int

    @property
    def t_end(self) -> float:
        """Arrival time at the goal (the last breakpoint), time units."""
        return float(self.times[-1])

    def at(self, t: np.ndarray) -> np.ndarray:
        """Configurations at times t: (len(t), d); before the start / after the end the
        first / last configuration."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        out = np.empty((t.size, self.configs.shape[1]))
        for k in range(self.configs.shape[1]):
            out[:, k] = np.interp(t, self.times, self.configs[:, k])
        return out


@dataclass
class SearchStats:
    """Effort of one arm's search: paths tried, nodes expanded, configurations checked."""

    paths_tried: int = 0
    nodes: int = 0
    checks: int = 0
    seconds: float = 0.0
    budget_exhausted: bool = False


def compress_breakpoints(times: np.ndarray, configs: np.ndarray, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Drop breakpoints that linear interpolation reproduces (and zero-time duplicates).

    times (k,), configs (k, d): two passes of :func:`_compress_keep` (compiled; equality as
    ``np.allclose(x, y, atol=tol)``, relative tolerance 1e-5 of ``y``)."""
    times = np.ascontiguousarray(times, dtype=np.float64)
    configs = np.ascontiguousarray(configs, dtype=np.float64)
    keep = _compress_keep(times, configs, tol, False)
    times, configs = times[keep], configs[keep]
    if len(times) <= 2:
        return times, configs
    out = _compress_keep(times, configs, tol, True)
    return times[out], configs[out]


@njit(cache=True)
def _close(x, y, tol):
    """``np.allclose(x, y, atol=tol)`` of two (d,) rows."""
    for c in range(x.shape[0]):
        if not abs(x[c] - y[c]) <= tol + 1e-5 * abs(y[c]):
            return False
    return True


@njit(cache=True)
def _compress_keep(times, configs, tol, interpolated):
    """Indices kept: without ``interpolated``, each breakpoint that is not a zero-time
    duplicate of the last kept one; with it, the ends and each breakpoint that linear
    interpolation between the last kept one and the next does not reproduce."""
    k_n = times.shape[0]
    out = np.empty(k_n, dtype=np.int64)
    out[0] = 0
    m = 1
    if not interpolated:
        for k in range(1, k_n):
            a = out[m - 1]
            if times[k] == times[a] and _close(configs[k], configs[a], tol):
                continue
            out[m] = k
            m += 1
        return out[:m]
    for k in range(1, k_n - 1):
        a, b = out[m - 1], k + 1
        span = times[b] - times[a]
        if span <= 0:
            out[m] = k
            m += 1
            continue
        pred = configs[a] + (times[k] - times[a]) / span * (configs[b] - configs[a])
        if not _close(pred, configs[k], tol):
            out[m] = k
            m += 1
    out[m] = k_n - 1
    return out[:m + 1]
