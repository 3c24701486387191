"""Prioritized roadmap planning in state-time (Sabater et al. 2018), for any robot model.

Sabater et al. 2018 ("Roadmap search based motion planning for MIRADAS probe arms",
JATIS 4(3) 034001) plan arms one at a time in priority order; an arm planned later treats
the trajectories of the arms planned before it as moving obstacles (their Algorithm 1).
For one arm (Algorithm 2):

* a **roadmap** in joint space (Sect. 6.1): grid vertices outside the forbidden zone,
  random edges between vertex pairs (each vertex in at most one), and the paths
  ``start -> goal``, ``start -> v -> goal`` and ``start -> v_i -> v_j -> goal``, all made
  of straight joint-space edges (their motor controllers cannot blend);
* paths are tried **cheapest first** by the estimated travel time of Eq. 5,
  ``t_e = max_k |dtheta_k| / vmax_k`` per edge (ties in random order);
* each edge is searched in **state-time** (Sect. 6.4): a node is ``(s, ns, m, t)``, the
  fraction ``s`` of the edge travelled, the start-stop cycles ``ns`` so far, the motion
  ``m`` in {-1, 0, +1} that reached it and the time ``t``; the actions are backward /
  stop / forward for one ``dt`` (the edge speed is the largest one not above ``vmax``
  that divides the edge into whole ``dt`` steps); the search is depth-first with forward
  tried first (Algorithm 3), ``ns`` grows when a motion changes to something else
  (Algorithm 6, ``Neigh-DF``) and once ``ns`` reaches ``nStop`` a moving arm must keep
  its motion and a stopped one may stay or go forward (``Neigh-MaxNS``); collisions are
  checked every ``dt_col`` between a node and its parent (Sect. 6.4.2);
* **goal conflicts** (Sect. 6.4.2): an arm that parks before the arms of higher priority
  have arrived must stay collision-free at its goal until the last of them arrives
  (``Arm.hold_until``); arms planned later see the parked arm as an obstacle.

Errata (see shared/references/README.md): in ``Neigh-MaxNS`` of Sabater 2018 Algorithm 6
(line 6) the forward neighbour of a stopped node keeps ``m`` (= 0); it must take
``m = +1``, or the next expansion would stop it again after one step. Neighbours with
``s`` outside [0, 1] are discarded (the paper's algorithms never check). Both are fixed
here.

Beyond the paper (each documented where it is done):

* a node's collision status depends on the transition that reaches it when
  ``dt_col < dt``, so a transition that collides does not mark its target node unsafe
  (another parent may reach it safely); only safely reached nodes are marked visited;
* ``resume_edges=True`` (default ``False``, the paper's Algorithm 2) lets the depth-first
  search back up into an earlier edge of the path when a later edge fails, instead of
  giving up the whole path;
* ``Arm.t_static``: after this time the obstacles no longer move, so waiting or backing
  up cannot help any more; only forward moves are expanded there, which bounds the search
  without a hand-set ``T_f``;
* ``corner_vertices``: the axis-aligned corners between start and goal (in 2D
  ``(start_0, goal_1)`` and ``(goal_0, start_1)``) and the corners of the "every joint
  at full speed" move are added to the vertices (:func:`corner_vertices`): "one joint
  first, then the other" and stepwise-planner-like moves the grid may miss;
* :func:`prioritized_plan` retries with other priority orders (a failing arm is moved to
  the front), as Sect. 2.1 says the MIRADAS software does; :func:`priority_search`
  searches the orders themselves (priority-based search, Ma et al. 2019): on a
  conflict one arm yields to the other, and an arm with no trajectory may recruit the
  fixed obstacles that blocked it as arms below it;
* ``Arm.lead_in``: a motion the arm may follow first and leave at any time (e.g. the
  part of an existing plan worth keeping); ``Arm.via``: extra paths a robot model knows;
* ``search="sweep"``: the same state-time graph explored one time layer at a time (all
  reachable positions of a layer checked in one black-box call): earliest arrival,
  much faster than node-by-node depth-first search when it has to wait long or fails.

The robot model is reached only through black boxes (Sect. 4.1): per arm
``forbidden(q)`` (the zone of avoidance: joint limits, static obstacles) and
``collides(q, t)`` (moving obstacles, i.e. the arms planned before and anything else
that moves on a known schedule). Both are vectorised: ``q`` is ``(m, d)``, ``t`` is
``(m,)`` and they return ``(m,)`` bool. Units are the caller's: joint units (e.g. deg)
and time units (e.g. s, or planner steps), ``vmax`` in joint units per time unit.
Randomness comes from a ``numpy.random.Generator``: same seed, same result.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable, Sequence

import numpy as np
from numba import njit

from models.errors import SpecError, field_error

#: Fractions of an edge closer than this are equal (dimensionless).
_EPS = 1e-9


# ------------------------------------------------------------------------------------
# Inputs
# ------------------------------------------------------------------------------------
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
        (goal conflicts: the arrival of the last higher-priority arm); ``prioritized_plan``
        raises it to the end of every arm planned before.
    t_static : float or None, time after which ``collides(q, t)`` no longer depends on t
        (every obstacle has stopped). Enables pruning; None = unknown.
    extra_vertices : (k, d) float64 or None, vertices added to the grid (joint units)
    lead_in : (times (k,), configs (k, d)) or None, a motion from ``start`` at
        ``t_start`` the arm may follow first and leave at any of its times (e.g. the
        part of an existing plan to keep); its last time is where it ends
    via : callable ``(start, goal) -> list of (k, d) arrays`` or None: extra roadmap
        paths ``start -> via[0] -> ... -> goal`` a robot model knows to be useful
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


# ------------------------------------------------------------------------------------
# Outputs
# ------------------------------------------------------------------------------------
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


# ------------------------------------------------------------------------------------
# Roadmap (Sect. 6.1)
# ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Roadmap:
    """Vertices, random edges, and candidate paths sorted by estimated travel time.

    Attributes
    ----------
    vertices : (V, d) float64, feasible grid (and extra) vertices
    edges : (E, 2) int64, random vertex pairs whose straight line is feasible
    paths : list of (p, d) float64, start ... goal, cheapest first (not yet checked
        against ``forbidden``: :func:`plan_arm` checks each edge when it reaches it)
    est_times : (len(paths),) float64, Eq. 5 summed over each path's edges
    """

    vertices: np.ndarray
    edges: np.ndarray
    paths: list
    est_times: np.ndarray


def edge_time(q0: np.ndarray, q1: np.ndarray, vmax: np.ndarray) -> float:
    """Sabater 2018 Eq. 5: lower bound of the travel time of a straight edge."""
    return float(np.max(np.abs(np.asarray(q1) - np.asarray(q0)) / vmax))


def _edge_samples(q0: np.ndarray, q1: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Points along the straight edge q0 -> q1, ends included, at most ``step`` apart per joint."""
    n = int(max(1, math.ceil(float(np.max(np.abs(q1 - q0) / step)) - 1e-9)))
    f = np.linspace(0.0, 1.0, n + 1)[:, None]
    return q0[None, :] + f * (q1 - q0)[None, :]


class _EdgeFeasibility:
    """Memoised ``forbidden`` check of straight edges (the path's edges must avoid the ZoA)."""

    def __init__(self, arm: Arm, step: np.ndarray):
        self.arm = arm
        self.step = step
        self.memo: dict[bytes, bool] = {}
        self.checks = 0

    def ok(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        key = np.concatenate([q0, q1]).tobytes()
        hit = self.memo.get(key)
        if hit is None:
            pts = _edge_samples(q0, q1, self.step)
            self.checks += len(pts)
            hit = not bool(np.any(self.arm.forbidden(pts)))
            self.memo[key] = hit
        return hit


def build_roadmap(arm: Arm, settings: RoadmapSettings, rng: np.random.Generator,
                  feasible: _EdgeFeasibility | None = None) -> Roadmap:
    """Roadmap of one arm (Sabater 2018 Sect. 6.1), paths sorted cheapest first.

    Vertices are the junctions of a ``settings.grid`` grid over ``[arm.lower,
    arm.upper]`` (plus ``arm.extra_vertices`` and, if asked, the start/goal corners) that
    are not ``forbidden``. Random edges join disjoint vertex pairs whose straight line is
    feasible. Paths: direct, one vertex, each random edge in both directions, and the
    arm's own ``via`` paths. Paths are sorted by Eq. 5 summed over their edges, ties in
    random order.
    """
    d = arm.dim
    if len(settings.grid) != d:
        raise field_error(SpecError, "grid", settings.grid, f"{d} integers (one per joint)",
                          "RoadmapSettings")
    start = np.asarray(arm.start, dtype=np.float64)
    goal = np.asarray(arm.goal, dtype=np.float64)
    vmax = np.asarray(arm.vmax, dtype=np.float64)
    if feasible is None:
        feasible = _EdgeFeasibility(arm, _check_step(arm, settings))
    axes = [np.linspace(lo, hi, int(g)) if int(g) > 1 else np.array([0.5 * (lo + hi)])
            for lo, hi, g in zip(arm.lower, arm.upper, settings.grid)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
    extra = [grid]
    if arm.extra_vertices is not None and len(arm.extra_vertices):
        extra.append(np.asarray(arm.extra_vertices, dtype=np.float64).reshape(-1, d))
    if settings.corner_vertices and d > 1:
        extra.append(corner_vertices(start, goal, vmax))
    cand = np.unique(np.concatenate(extra), axis=0)
    cand = cand[~np.asarray(arm.forbidden(cand), dtype=bool)] if len(cand) else cand
    same = np.all(np.isclose(cand, start[None]), axis=1) | np.all(np.isclose(cand, goal[None]), axis=1)
    verts = cand[~same]

    # random edges: disjoint pairs (Sect. 6.1, "a vertex cannot be in more than one edge")
    edges = []
    perm = rng.permutation(len(verts))
    for p in range(0, len(perm) - 1, 2):
        if len(edges) >= settings.n_random_edges:
            break
        i, j = int(perm[p]), int(perm[p + 1])
        if feasible.ok(verts[i], verts[j]):
            edges.append((i, j))
    edges_arr = np.array(edges, dtype=np.int64).reshape(-1, 2)

    paths = [np.stack([start, goal])]
    paths += [np.stack([start, v, goal]) for v in verts]
    for i, j in edges:
        paths.append(np.stack([start, verts[i], verts[j], goal]))
        paths.append(np.stack([start, verts[j], verts[i], goal]))
    if arm.via is not None:
        for mid in arm.via(start, goal):
            mid = np.asarray(mid, dtype=np.float64).reshape(-1, d)
            paths.append(np.vstack([start[None, :], mid, goal[None, :]]))
    est = np.array([sum(edge_time(p[k], p[k + 1], vmax) for k in range(len(p) - 1)) for p in paths])
    tie = rng.random(len(paths))
    order = np.lexsort((tie, np.round(est, 9)))
    return Roadmap(verts, edges_arr, [paths[k] for k in order], est[order])


def corner_vertices(start: np.ndarray, goal: np.ndarray, vmax: np.ndarray) -> np.ndarray:
    """Vertices of "one joint after the other" and "every joint at full speed" moves.

    * axis corners: ``start`` with some joints already at ``goal`` (2^d - 2 points);
    * speed corners: where a joint moving at its full speed from ``start`` (or, played
      backwards, from ``goal``) has finished: the breakpoints of the motion a stepwise
      planner makes when it moves every joint at full speed towards its destination.

    Returns (k, d) float64, joint units.
    """
    d = start.shape[0]
    out = []
    for mask in range(1, 2 ** d - 1):
        c = start.copy()
        for k in range(d):
            if mask >> k & 1:
                c[k] = goal[k]
        out.append(c)
    delta = goal - start
    t_joint = np.abs(delta) / vmax
    for t in np.unique(t_joint[(t_joint > 0) & (t_joint < t_joint.max())]):
        step = np.sign(delta) * np.minimum(t_joint, t) * vmax
        out.append(start + step)        # full speed from the start
        out.append(goal - step)         # full speed into the goal
    return np.array(out).reshape(-1, d)


def _check_step(arm: Arm, settings: RoadmapSettings) -> np.ndarray:
    if settings.edge_check_step is not None:
        return np.full(arm.dim, float(settings.edge_check_step))
    dt_col = settings.dt if settings.dt_col is None else settings.dt_col
    return np.asarray(arm.vmax, dtype=np.float64) * dt_col


# ------------------------------------------------------------------------------------
# State-time search along a path (Sect. 6.4, Algorithms 3-6)
# ------------------------------------------------------------------------------------
def neighbour_actions(ns: int, m: int, n_stop: int | None) -> list[tuple[int, int]]:
    """(motion, ns) of the children of a node, least promising first (Algorithms 5-6).

    The depth-first search pops the last entry first, so forward is tried first.

    ``Neigh-MaxNS`` (``ns == nStop``): the node keeps its motion; a stopped node may also
    go forward. Sabater 2018 Algorithm 6 line 6 gives that forward neighbour the current
    ``m`` (0), which would stop it again after one step: it must take ``m = +1``
    (erratum, shared/references/README.md).

    ``Neigh-DF``: all three; ``ns`` grows when a motion changes to something else
    (backward -> stop/forward, forward -> stop/backward); starting from a stop is free.
    """
    if n_stop is not None and ns >= n_stop:
        out = [(m, ns)]
        if m == 0:
            out.append((1, ns))     # erratum fixed: the forward neighbour moves, m = +1
        return out
    if m == -1:
        return [(-1, ns), (0, ns + 1), (1, ns + 1)]
    if m == 0:
        return [(-1, ns), (0, ns), (1, ns)]
    return [(-1, ns + 1), (0, ns + 1), (1, ns)]


class _PathSearch:
    """Depth-first state-time search along one roadmap path (its edges in sequence).

    Node = (edge e, step index i along the edge (s = i / n_seg), ns, m, time index k);
    time of node k is ``t_start + k dt``. Reaching the end of a non-final edge leads,
    with no time passing, to the start of the next edge stopped (a vertex is a stop of
    the motor controller: one start-stop cycle if the arm arrived moving).
    """

    def __init__(self, arm: Arm, path: np.ndarray, settings: RoadmapSettings,
                 stats: SearchStats, goal_clear_after: float):
        self.arm = arm
        self.path = path
        self.s = settings
        self.stats = stats
        self.goal_clear_after = goal_clear_after
        vmax = np.asarray(arm.vmax, dtype=np.float64)
        self.n_seg = []
        for e in range(len(path) - 1):
            te = edge_time(path[e], path[e + 1], vmax)
            # the fastest edge speed <= vmax that divides the edge into whole dt steps
            self.n_seg.append(max(1, int(math.ceil(te / settings.dt - 1e-9))))
        self.n_sub = settings.n_sub
        self.frac = np.arange(1, self.n_sub + 1) / self.n_sub   # sub-check offsets in an action
        # the three actions (-1, 0, +1) of a node are checked in one black-box call
        self.offsets = np.concatenate([-self.frac, 0.0 * self.frac, self.frac])
        self.t_offsets = np.tile(self.frac * settings.dt, 3)
        self.q0 = [np.asarray(path[e], dtype=np.float64) for e in range(len(path) - 1)]
        self.dq = [(np.asarray(path[e + 1], dtype=np.float64) - self.q0[e]) / self.n_seg[e]
                   for e in range(len(path) - 1)]
        self.moves: dict[tuple[int, int, int], np.ndarray] = {}

    def time(self, k: int) -> float:
        return self.arm.t_start + k * self.s.dt

    def config(self, e: int, i: float) -> np.ndarray:
        q0, q1 = self.path[e], self.path[e + 1]
        return q0 + (i / self.n_seg[e]) * (q1 - q0)

    def moves_clear(self, e: int, i: int, k: int) -> np.ndarray:
        """(3,) bool: is the action backward / stop / forward from node (e, i, k) clear?

        Clear = ``collides`` is False every ``dt_col`` after the node until the next
        node time (the node itself was checked when it was reached). Memoised per
        (e, i, k); positions beyond the edge's ends are clipped (never used).
        """
        key = (e, i, k)
        out = self.moves.get(key)
        if out is None:
            fi = np.clip(i + self.offsets, 0.0, float(self.n_seg[e]))
            q = self.q0[e][None, :] + fi[:, None] * self.dq[e][None, :]
            t = self.time(k) + self.t_offsets
            self.stats.checks += t.size
            hit = np.asarray(self.arm.collides(q, t), dtype=bool).reshape(3, self.n_sub)
            out = ~hit.any(axis=1)
            self.moves[key] = out
        return out

    def run(self) -> ArmTrajectory | None:
        s = self.s
        n_edges = len(self.path) - 1
        n_stop = s.n_stop
        t_static = self.arm.t_static
        k_static = None if t_static is None else max(0, math.ceil((t_static - self.arm.t_start)
                                                                 / s.dt - 1e-9))
        k_max = None if s.t_max is None else math.floor((s.t_max - self.arm.t_start) / s.dt + 1e-9)
        keyed_ns = n_stop is not None
        # node = (e, i, ns, m, k); the visited key drops (ns, m) when nStop is unlimited:
        # then a node's future does not depend on them
        start = (0, 0, 0, 0, 0)
        self.stats.checks += 1
        if bool(np.any(self.arm.collides(self.path[:1], np.array([self.arm.t_start])))):
            return None
        parent: dict[tuple, tuple | None] = {}
        stack: list[tuple[tuple, tuple | None]] = [(start, None)]
        committed_edge = 0
        while stack:
            node, par = stack.pop()
            e, i, ns, m, k = node
            key = (e, i, ns, m, k) if keyed_ns else (e, i, k)
            if key in parent:
                continue
            # children are pushed only when the action reaching them is clear, so a
            # collision never marks a node: another parent may still reach it safely
            parent[key] = par
            self.stats.nodes += 1
            if s.max_nodes is not None and self.stats.nodes >= s.max_nodes:
                self.stats.budget_exhausted = True
                return None
            if i == self.n_seg[e]:
                if e == n_edges - 1:
                    # goal reached: it must stay clear until the arms before have arrived
                    if self.time(k) > self.goal_clear_after - 1e-12:
                        return self._trajectory(node, parent, keyed_ns)
                else:
                    ns2 = ns + (1 if m != 0 else 0)     # a vertex stops the motor
                    if n_stop is None or ns2 <= n_stop:
                        if not s.resume_edges and e + 1 > committed_edge:
                            # Sabater's Algorithm 2: the edge's first trajectory is final
                            stack.clear()
                            committed_edge = e + 1
                        stack.append(((e + 1, 0, ns2, 0, k), node))
                    continue
            if k_max is not None and k >= k_max:
                continue
            static = k_static is not None and k >= k_static
            clear = None
            for m2, ns2 in neighbour_actions(ns, m, n_stop):
                if static and m2 != 1:
                    continue          # obstacles have stopped: waiting or backing up is useless
                i2 = i + m2
                if i2 < 0 or i2 > self.n_seg[e]:
                    continue          # erratum: discard s outside [0, 1]
                if clear is None:
                    clear = self.moves_clear(e, i, k)
                if clear[m2 + 1]:
                    stack.append(((e, i2, ns2, m2, k + 1), node))
        return None

    def _trajectory(self, node: tuple, parent: dict, keyed_ns: bool) -> ArmTrajectory:
        chain = []
        cur = node
        while cur is not None:
            chain.append(cur)
            e, i, ns, m, k = cur
            cur = parent[(e, i, ns, m, k) if keyed_ns else (e, i, k)]
        chain.reverse()
        times, configs = [], []
        n_go = n_stop = 0
        prev = None
        for e, i, ns, m, k in chain:
            if prev is not None and prev[4] != k:
                if m == 0:
                    n_stop += 1
                else:
                    n_go += 1
            times.append(self.time(k))
            configs.append(self.config(e, i))
            prev = (e, i, ns, m, k)
        times = np.array(times)
        configs = np.array(configs)
        times, configs = _compress(times, configs)
        return ArmTrajectory(times, configs, self.path.copy(), int(chain[-1][2]), n_go, n_stop)


@njit(cache=True)
def _sweep_queries(reach, Q, D, frac, static, t_k, dt):
    """Configurations and times to check for every action of every reachable position.

    reach : (P + 1,) bool; Q : (P + 1, d) positions; D : (P, d) forward steps;
    frac : (K,) sub-check offsets in (0, 1]. Actions forward, stop, backward (forward
    only when ``static``). Returns q (n K, d), t (n K,), src (n,) position and act (n,)
    action of each block of K rows.
    """
    P = Q.shape[0] - 1
    d = Q.shape[1]
    K = frac.shape[0]
    n = 0
    for p in range(P + 1):
        if reach[p]:
            n += (p < P) + (0 if static else 1 + (p > 0))
    q = np.empty((n * K, d))
    t = np.empty(n * K)
    src = np.empty(n, dtype=np.int64)
    act = np.empty(n, dtype=np.int64)
    b = 0
    for m in (1, 0, -1):
        if static and m != 1:
            break
        for p in range(P + 1):
            if not reach[p] or (m == 1 and p == P) or (m == -1 and p == 0):
                continue
            src[b] = p
            act[b] = m
            for j in range(K):
                r = b * K + j
                for c in range(d):
                    step = 0.0
                    if m == 1:
                        step = D[p, c]
                    elif m == -1:
                        step = -D[p - 1, c]
                    q[r, c] = Q[p, c] + frac[j] * step
                t[r] = t_k + frac[j] * dt
            b += 1
    return q, t, src, act


@njit(cache=True)
def _sweep_advance(hit, src, act, K, P):
    """Positions reached at the next time and the action that reached each (forward
    first, then stop, then backward: blocks are ordered that way)."""
    nxt = np.zeros(P + 1, dtype=np.bool_)
    how = np.zeros(P + 1, dtype=np.int8)
    for b in range(src.shape[0]):
        ok = True
        for j in range(K):
            if hit[b * K + j]:
                ok = False
                break
        if ok:
            p2 = src[b] + act[b]
            if not nxt[p2]:
                nxt[p2] = True
                how[p2] = act[b]
    return nxt, how


class _PathSweep:
    """Earliest-arrival search along one roadmap path, one time layer at a time.

    Beyond the paper (``RoadmapSettings.search = "sweep"``, unlimited ``n_stop`` only):
    the same state-time graph as :class:`_PathSearch` (positions ``i / n_seg`` along
    each edge, actions backward / stop / forward of one ``dt``, collisions every
    ``dt_col``), explored breadth first in time: the set of positions reachable at
    time ``t_start + k dt`` is advanced to ``k + 1`` by checking the three actions of
    every reachable position in one black-box call. Each (position, time) is checked
    once, as in the depth-first search, but per time layer instead of per node, which
    makes hard searches (long waits, dead ends) much cheaper; the trajectory reaches
    the goal at the earliest time the graph allows. The edges of the path are joined
    into one sequence of positions (a vertex is crossed without a stop).
    """

    def __init__(self, arm: Arm, path: np.ndarray, settings: RoadmapSettings,
                 stats: SearchStats, goal_clear_after: float):
        self.arm = arm
        self.path = path
        self.s = settings
        self.stats = stats
        self.goal_clear_after = goal_clear_after
        vmax = np.asarray(arm.vmax, dtype=np.float64)
        pts = [np.asarray(path[0], dtype=np.float64)[None, :]]
        self.vertex_pos = []
        for e in range(len(path) - 1):
            n = max(1, int(math.ceil(edge_time(path[e], path[e + 1], vmax) / settings.dt - 1e-9)))
            f = np.arange(1, n + 1)[:, None] / n
            pts.append(path[e][None, :] + f * (path[e + 1] - path[e])[None, :])
            self.vertex_pos.append(sum(len(p) for p in pts) - 1)
        self.Q = np.vstack(pts)                      # (P + 1, d) configurations
        self.D = np.diff(self.Q, axis=0)             # (P, d) forward step from each position
        self.n_sub = settings.n_sub
        self.frac = np.arange(1, self.n_sub + 1) / self.n_sub

    def time(self, k: int) -> float:
        return self.arm.t_start + k * self.s.dt

    def run(self) -> ArmTrajectory | None:
        s = self.s
        P = len(self.Q) - 1
        t_static = self.arm.t_static
        k_static = None if t_static is None else max(0, math.ceil((t_static - self.arm.t_start)
                                                                 / s.dt - 1e-9))
        k_max = None if s.t_max is None else math.floor((s.t_max - self.arm.t_start) / s.dt + 1e-9)
        if k_static is not None:
            k_bound = k_static + P + 1            # after t_static only forward moves help
            k_max = k_bound if k_max is None else min(k_max, k_bound)
        self.stats.checks += 1
        if bool(np.any(self.arm.collides(self.Q[:1], np.array([self.arm.t_start])))):
            return None
        reach = np.zeros(P + 1, dtype=bool)
        reach[0] = True
        came: list[np.ndarray] = []                 # per layer: action that reached each position
        frac = self.frac
        k = 0
        while True:
            if reach[P] and self.time(k) > self.goal_clear_after - 1e-12:
                return self._trajectory(came, k)
            if k_max is not None and k >= k_max:
                return None
            self.stats.nodes += int(reach.sum())
            if s.max_nodes is not None and self.stats.nodes >= s.max_nodes:
                self.stats.budget_exhausted = True
                return None
            static = k_static is not None and k >= k_static
            q_all, t_all, src, act = _sweep_queries(reach, self.Q, self.D, frac, static,
                                                     self.time(k), s.dt)
            self.stats.checks += t_all.size
            hit = np.asarray(self.arm.collides(q_all, t_all), dtype=np.bool_)
            nxt, how = _sweep_advance(hit, src, act, self.n_sub, P)
            if not nxt.any():
                return None
            came.append(how)
            reach = nxt
            k += 1

    def _trajectory(self, came: list[np.ndarray], k_end: int) -> ArmTrajectory:
        P = len(self.Q) - 1
        pos = [P]
        acts = []
        p = P
        for k in range(k_end, 0, -1):
            m = int(came[k - 1][p])
            acts.append(m)
            p -= m
            pos.append(p)
        pos.reverse()
        acts.reverse()
        times = self.time(0) + self.s.dt * np.arange(len(pos))
        configs = self.Q[np.array(pos)]
        ns = 0
        prev = 0
        for m in acts:
            if prev != 0 and m != prev:
                ns += 1
            prev = m
        crossed = sum(1 for v in self.vertex_pos[:-1] if v in set(pos))
        n_go = sum(1 for m in acts if m != 0)
        times, configs = _compress(times, configs)
        return ArmTrajectory(times, configs, self.path.copy(), ns + crossed, n_go, len(acts) - n_go)


def _compress(times: np.ndarray, configs: np.ndarray, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Drop breakpoints that linear interpolation reproduces (and zero-time duplicates)."""
    keep = [0]
    for k in range(1, len(times)):
        if times[k] == times[keep[-1]] and np.allclose(configs[k], configs[keep[-1]], atol=tol):
            continue
        keep.append(k)
    times, configs = times[keep], configs[keep]
    if len(times) <= 2:
        return times, configs
    out = [0]
    for k in range(1, len(times) - 1):
        a, b = out[-1], k + 1
        span = times[b] - times[a]
        if span <= 0:
            out.append(k)
            continue
        pred = configs[a] + (times[k] - times[a]) / span * (configs[b] - configs[a])
        if not np.allclose(pred, configs[k], atol=tol):
            out.append(k)
    out.append(len(times) - 1)
    return times[out], configs[out]


def goal_clear_after(arm: Arm, settings: RoadmapSettings) -> float:
    """Earliest arrival time from which the arm can stay at its goal until ``hold_until``.

    The goal is checked every ``dt_col`` from ``t_start`` to ``hold_until``; parking at
    time t is safe when no check at or after t collides. Returns -inf if none collides.
    """
    dt_col = settings.dt if settings.dt_col is None else settings.dt_col
    if arm.hold_until <= arm.t_start:
        return -math.inf
    n = int(math.ceil((arm.hold_until - arm.t_start) / dt_col - 1e-9))
    t = arm.t_start + dt_col * np.arange(n + 1)
    q = np.repeat(np.asarray(arm.goal, dtype=np.float64)[None, :], t.size, axis=0)
    hit = np.flatnonzero(np.asarray(arm.collides(q, t), dtype=bool))
    return -math.inf if hit.size == 0 else float(t[hit[-1]]) + 1e-9


def plan_arm(arm: Arm, settings: RoadmapSettings, rng: np.random.Generator,
             roadmap: Roadmap | None = None) -> tuple[ArmTrajectory | None, SearchStats]:
    """Sabater 2018 Algorithm 2: the first path of the roadmap whose edges all get a trajectory.

    With a ``lead_in`` the arm may first follow that motion and leave it at one of up to
    ``settings.max_departures`` times on it (the latest first); the lead-in is checked
    against ``collides`` every ``dt_col`` like any other motion.

    Parameters
    ----------
    arm : Arm
    settings : RoadmapSettings
    rng : numpy Generator (roadmap vertices pairing and tie order)
    roadmap : a prebuilt roadmap for this arm, or None to build one (per departure)

    Returns
    -------
    (trajectory or None, stats). The trajectory starts at ``arm.t_start`` at ``start`` and
    ends at ``goal``, collision-free at every ``dt_col`` and clear at the goal until
    ``arm.hold_until``.
    """
    clock = time.perf_counter()
    stats = SearchStats()
    if arm.t_static is None and settings.t_max is None:
        raise field_error(SpecError, "t_max", None, "a time when the arm has no t_static",
                          "RoadmapSettings")
    for name, q in (("start", arm.start), ("goal", arm.goal)):
        if bool(np.any(arm.forbidden(np.asarray(q, dtype=np.float64)[None, :]))):
            raise field_error(SpecError, name, tuple(np.round(np.asarray(q, dtype=float), 6)),
                              "a configuration outside the forbidden zone", "Arm")
    feasible = _EdgeFeasibility(arm, _check_step(arm, settings))
    clear_after = goal_clear_after(arm, settings)
    result = None
    for t_dep in _departures(arm, settings, stats):
        sub = arm
        if arm.lead_in is not None:
            q_dep = _lead_in_at(arm, t_dep)
            sub = replace(arm, start=q_dep, t_start=t_dep, lead_in=None)
        rm = roadmap if roadmap is not None else build_roadmap(sub, settings, rng, feasible)
        result = _search_roadmap(sub, rm, settings, stats, clear_after, feasible)
        if result is not None:
            if arm.lead_in is not None:
                result = _with_lead_in(arm, t_dep, result)
            break
        if stats.budget_exhausted:
            break
    stats.checks += feasible.checks
    stats.seconds = time.perf_counter() - clock
    return result, stats


def _search_roadmap(arm: Arm, roadmap: Roadmap, settings: RoadmapSettings, stats: SearchStats,
                    clear_after: float, feasible: _EdgeFeasibility) -> ArmTrajectory | None:
    """Algorithm 2's loop: paths cheapest first, the first one that gets a trajectory."""
    tried = 0
    for path, est in zip(roadmap.paths, roadmap.est_times):
        if settings.max_paths is not None and tried >= settings.max_paths:
            break
        if settings.max_path_time is not None and est > settings.max_path_time:
            break
        # drop zero-length edges (a vertex on the start or goal)
        keep = [0] + [k for k in range(1, len(path)) if not np.allclose(path[k], path[k - 1])]
        path = path[keep]
        if len(path) < 2:
            path = np.stack([path[0], path[0]])
        if not all(feasible.ok(path[k], path[k + 1]) for k in range(len(path) - 1)):
            continue
        tried += 1
        stats.paths_tried += 1
        searcher = _PathSweep if settings.search == "sweep" else _PathSearch
        result = searcher(arm, path, settings, stats, clear_after).run()
        if result is not None:
            return result
        if stats.budget_exhausted:
            break
    return None


def _lead_in_at(arm: Arm, t: float) -> np.ndarray:
    times, configs = arm.lead_in
    return np.array([np.interp(t, times, configs[:, k]) for k in range(configs.shape[1])])


def _departures(arm: Arm, settings: RoadmapSettings, stats: SearchStats) -> list[float]:
    """Times at which the arm may leave its lead-in, latest first ([t_start] without one).

    Candidates lie on the dt grid from ``t_start`` to the end of the lead-in, up to the
    first ``dt_col`` check of the lead-in that collides; at most ``max_departures`` of
    them, evenly spread, always including the first and the last.
    """
    if arm.lead_in is None:
        return [arm.t_start]
    times, configs = arm.lead_in
    dt_col = settings.dt if settings.dt_col is None else settings.dt_col
    t_end = float(times[-1])
    n = int(math.floor((t_end - arm.t_start) / dt_col + 1e-9))
    tc = arm.t_start + dt_col * np.arange(n + 1)
    q = np.column_stack([np.interp(tc, times, configs[:, k]) for k in range(configs.shape[1])])
    stats.checks += len(tc)
    hit = np.flatnonzero(np.asarray(arm.collides(q, tc), dtype=bool))
    last_ok = t_end if hit.size == 0 else (float(tc[hit[0]]) - dt_col if hit[0] > 0 else None)
    if last_ok is None:
        return []
    k_last = int(math.floor((last_ok - arm.t_start) / settings.dt + 1e-9))
    grid = arm.t_start + settings.dt * np.arange(k_last + 1)
    if hit.size == 0 and grid[-1] < t_end - 1e-9 and \
            abs((t_end - arm.t_start) / dt_col - round((t_end - arm.t_start) / dt_col)) < 1e-9:
        grid = np.append(grid, t_end)     # the end of the lead-in itself (on the dt_col grid)
    m = max(1, int(settings.max_departures))
    if len(grid) > m:
        pick = np.unique(np.round(np.linspace(0, len(grid) - 1, m)).astype(int))
        grid = grid[pick]
    return [float(t) for t in grid[::-1]]


def _with_lead_in(arm: Arm, t_dep: float, tr: ArmTrajectory) -> ArmTrajectory:
    """The lead-in up to ``t_dep`` followed by the searched trajectory."""
    times, configs = arm.lead_in
    keep = times < t_dep - 1e-12
    t = np.concatenate([times[keep], tr.times])
    q = np.vstack([configs[keep], tr.configs])
    t, q = _compress(t, q)
    return replace(tr, times=t, configs=q)


# ------------------------------------------------------------------------------------
# Prioritized planning (Algorithm 1) with priority re-ordering on failure (Sect. 2.1)
# ------------------------------------------------------------------------------------
@dataclass
class PrioritizedResult:
    """Outcome of :func:`prioritized_plan`.

    Attributes
    ----------
    trajectories : {arm index: ArmTrajectory} of the successful order (empty on failure)
    order : the priority order of the last attempt (the successful one), highest first
    success : bool
    orders_tried : int
    failed_arm : index of the arm that failed in the last attempt, or None
    stats : {arm index: SearchStats} of the last attempt
    seconds : float, wall time of all attempts
    """

    trajectories: dict[int, ArmTrajectory]
    order: list[int]
    success: bool
    orders_tried: int
    failed_arm: int | None
    stats: dict[int, SearchStats] = field(default_factory=dict)
    seconds: float = 0.0


def default_priority(arms: Sequence[Arm]) -> list[int]:
    """Sabater 2018 Sect. 7: longest estimated direct travel time first (stable)."""
    est = [edge_time(np.asarray(a.start, float), np.asarray(a.goal, float), np.asarray(a.vmax, float))
           for a in arms]
    return sorted(range(len(arms)), key=lambda i: -est[i])


def prioritized_plan(n_arms: int, make_arm: Callable[[int, dict[int, ArmTrajectory]], Arm],
                     settings: RoadmapSettings, rng: np.random.Generator, *,
                     order: Sequence[int] | None = None, max_orders: int = 1,
                     orders: Sequence[Sequence[int]] | None = None) -> PrioritizedResult:
    """Sabater 2018 Algorithm 1: plan arms one at a time, earlier ones are moving obstacles.

    Parameters
    ----------
    n_arms : int
    make_arm : callable ``(i, planned) -> Arm``; ``planned`` maps the indices of the arms
        planned so far to their trajectories, which arm ``i``'s ``collides`` must treat as
        moving obstacles (holding their last configuration after their end). The planner
        raises ``hold_until`` to the latest end among ``planned`` (goal conflicts).
    settings : RoadmapSettings
    rng : numpy Generator
    order : first priority order, highest first; default :func:`default_priority`
    max_orders : attempts; after a failure the failing arm moves to the front
        (or the next entry of ``orders`` is used)
    orders : explicit orders to try after ``order``, in turn

    Returns
    -------
    PrioritizedResult
    """
    clock = time.perf_counter()
    if order is None:
        order = default_priority([make_arm(i, {}) for i in range(n_arms)])
    order = [int(i) for i in order]
    if sorted(order) != list(range(n_arms)):
        raise field_error(SpecError, "order", order, f"a permutation of 0..{n_arms - 1}",
                          "prioritized_plan")
    queue = [list(o) for o in (orders or [])]
    seen: set[tuple[int, ...]] = set()
    tried = 0
    failed = None
    stats: dict[int, SearchStats] = {}
    while tried < max_orders:
        seen.add(tuple(order))
        tried += 1
        planned: dict[int, ArmTrajectory] = {}
        stats = {}
        failed = None
        for i in order:
            arm = make_arm(i, dict(planned))
            if planned:
                arm = replace(arm, hold_until=max(arm.hold_until,
                                                  max(tr.t_end for tr in planned.values())))
            tr, st = plan_arm(arm, settings, rng)
            stats[i] = st
            if tr is None:
                failed = i
                break
            planned[i] = tr
        if failed is None:
            return PrioritizedResult(planned, order, True, tried, None, stats,
                                     time.perf_counter() - clock)
        last_order = order
        nxt = None
        while queue and nxt is None:
            cand = queue.pop(0)
            if tuple(cand) not in seen:
                nxt = cand
        if nxt is None:
            cand = [failed] + [j for j in order if j != failed]
            if tuple(cand) in seen:
                rest = [j for j in order if j != failed]
                cand = [failed] + [rest[k] for k in rng.permutation(len(rest))]
            if tuple(cand) in seen:
                break
            nxt = cand
        order = nxt
    return PrioritizedResult({}, last_order, False, tried, failed, stats,
                             time.perf_counter() - clock)


# ------------------------------------------------------------------------------------
# Search over priorities (beyond the paper): which arm yields to which
# ------------------------------------------------------------------------------------
@dataclass
class PrioritySearchResult:
    """Outcome of :func:`priority_search`.

    Attributes
    ----------
    trajectories : {arm index: ArmTrajectory}, every arm (recruited ones included) when
        ``success``; empty otherwise
    success : bool
    n_arms : int, arms at the end (initial ones plus recruited ones)
    priorities : set of (higher, lower) pairs of the solution (or of the last node)
    nodes : int, search-tree nodes expanded
    plans : int, single-arm searches run
    seconds : float
    failures : {arm index: single-arm searches that found no trajectory}
    """

    trajectories: dict[int, ArmTrajectory]
    success: bool
    n_arms: int
    priorities: set
    nodes: int
    plans: int
    seconds: float = 0.0
    failures: dict = field(default_factory=dict)


def priority_search(n_arms: int,
                    make_arm: Callable[[int, dict[int, ArmTrajectory], frozenset], Arm],
                    conflict: Callable[[int, ArmTrajectory, int, ArmTrajectory], bool],
                    settings: RoadmapSettings, rng: np.random.Generator, *,
                    recruit: Callable[[int, int], list[tuple[int, ArmTrajectory]]] | None = None,
                    max_nodes: int = 24, max_recruits: int = 6) -> PrioritySearchResult:
    """Depth-first search over pairwise priorities with Sabater's planner for each arm.

    Sabater 2018 plan with one fixed priority order and retry with other orders
    (Sect. 2.1); searching the orders themselves finds more solutions. This is
    priority-based search (Ma et al., AAAI 2019) with :func:`plan_arm` as the
    single-arm planner: each arm is planned against the arms above it in a partial
    order only (``make_arm(i, higher)``: the trajectories of those arms are its moving
    obstacles, the others are ignored). The root plans every arm alone. A node whose
    trajectories conflict pairwise (``conflict``) branches on the first conflict
    (i, j): "i above j" or "j above i"; the lower arm and every arm below it whose
    trajectory now conflicts with one above it are planned again (in topological
    order). A child in which an arm gets no trajectory is dropped, unless ``recruit``
    brings in new arms for it: ``recruit(i, limit)`` returns at most ``limit``
    ``(index, trajectory)`` of arms that arm i met as fixed obstacles and that may now
    get out of its way (they are placed below i; indices continue from the current
    number of arms; at most ``max_recruits`` in all). The first node without conflicts
    is the solution.

    Parameters
    ----------
    n_arms : int, arms at the start
    make_arm : callable ``(i, higher, arms) -> Arm``; ``higher`` = {index: trajectory}
        of the arms above i, its moving obstacles; ``arms`` = the arms of this search
        node: those not in ``higher`` are ignored, and arms recruited in other branches
        (not in ``arms``) are part of the fixed environment again. Goal conflicts: the
        planner raises ``hold_until`` to the latest end among ``higher``.
    conflict : callable ``(i, traj_i, j, traj_j) -> bool``, do arms i and j collide
        (each holding its last configuration after its end)
    settings : RoadmapSettings; rng : numpy Generator
    recruit : see above (optional)
    max_nodes : search-tree nodes expanded at most
    max_recruits : arms recruited at most

    Returns
    -------
    PrioritySearchResult
    """
    clock = time.perf_counter()
    counter = {"plans": 0, "n": n_arms, "recruits": 0}
    base_paths: dict[int, ArmTrajectory] = {}
    failures: dict[int, int] = {}

    def closure_up(prio: dict[int, set], i: int) -> set:
        out, todo = set(), list(prio.get(i, ()))
        while todo:
            h = todo.pop()
            if h not in out:
                out.add(h)
                todo.extend(prio.get(h, ()))
        return out

    def plan(i: int, prio: dict[int, set], paths: dict[int, ArmTrajectory]) -> ArmTrajectory | None:
        higher = {h: paths[h] for h in closure_up(prio, i)}
        arm = make_arm(i, higher, frozenset(range(n_arms)) | frozenset(paths) | {i})
        if higher:
            arm = replace(arm, hold_until=max(arm.hold_until, max(t.t_end for t in higher.values())))
        counter["plans"] += 1
        tr, _ = plan_arm(arm, settings, rng)
        return tr

    def plan_or_recruit(i, prio, paths) -> bool:
        """Plan arm i; if it fails, recruit the arms that blocked it and try once more."""
        tr = plan(i, prio, paths)
        if tr is None and recruit is not None and counter["recruits"] < max_recruits:
            new = list(recruit(i, max_recruits - counter["recruits"]))
            if len(new) > max_recruits - counter["recruits"]:
                raise field_error(SpecError, "recruit", len(new),
                                  f"at most {max_recruits - counter['recruits']} arms", "priority_search")
            if new:
                for j, trj in new:
                    counter["recruits"] += 1
                    counter["n"] = max(counter["n"], j + 1)
                    base_paths[j] = trj
                    paths[j] = trj
                    prio.setdefault(j, set()).add(i)
                tr = plan(i, prio, paths)
        if tr is None:
            failures[i] = failures.get(i, 0) + 1
            return False
        paths[i] = tr
        return True

    def update(prio: dict[int, set], paths: dict[int, ArmTrajectory], low: int) -> bool:
        """Re-plan ``low`` and, in topological order, every arm below it that conflicts."""
        todo = [low] + [a for a in range(counter["n"]) if a in paths and low in closure_up(prio, a)]
        done = set()
        while todo:
            # the next arm none of whose higher arms is still waiting to be updated
            pick = next(a for a in todo if not (closure_up(prio, a) & set(todo) - {a}))
            todo.remove(pick)
            if pick in done:
                continue
            done.add(pick)
            higher = closure_up(prio, pick)
            if pick == low or any(conflict(pick, paths[pick], h, paths[h]) for h in higher):
                if not plan_or_recruit(pick, prio, paths):
                    return False
                # arms recruited meanwhile sit below pick: check them too
                for a in range(counter["n"]):
                    if a in paths and a not in done and a not in todo and pick in closure_up(prio, a):
                        todo.append(a)
        return True

    def first_conflict(paths: dict[int, ArmTrajectory]):
        keys = sorted(paths)
        for x, i in enumerate(keys):
            for j in keys[x + 1:]:
                if conflict(i, paths[i], j, paths[j]):
                    return i, j
        return None

    prio: dict[int, set] = {}
    paths: dict[int, ArmTrajectory] = {}
    for i in range(n_arms):
        if not plan_or_recruit(i, prio, paths):
            return PrioritySearchResult({}, False, counter["n"], set(), 0, counter["plans"],
                                        time.perf_counter() - clock, failures)
    stack = [(prio, paths)]
    nodes = 0
    last_pairs: set = set()
    while stack and nodes < max_nodes:
        prio, paths = stack.pop()
        nodes += 1
        last_pairs = {(h, lo) for lo, hs in prio.items() for h in hs}
        c = first_conflict(paths)
        if c is None:
            return PrioritySearchResult(dict(paths), True, counter["n"], last_pairs, nodes,
                                        counter["plans"], time.perf_counter() - clock, failures)
        children = []
        for hi, lo in (c, c[::-1]):
            if lo in closure_up(prio, hi):
                continue              # would make the order cyclic
            p2 = {k: set(v) for k, v in prio.items()}
            p2.setdefault(lo, set()).add(hi)
            q2 = dict(paths)
            if update(p2, q2, lo):
                cost = sum(t.t_end for t in q2.values())
                children.append((cost, p2, q2))
        # depth first, the cheaper child first
        for _, p2, q2 in sorted(children, key=lambda x: -x[0]):
            stack.append((p2, q2))
    return PrioritySearchResult({}, False, counter["n"], last_pairs, nodes, counter["plans"],
                                time.perf_counter() - clock, failures)
