"""Depth-first state-time search along one roadmap path (Sabater et al. 2018, Sect. 6.4).

Each edge is searched in state-time: a node is ``(s, ns, m, t)``, the fraction ``s`` of
the edge travelled, the start-stop cycles ``ns`` so far, the motion ``m`` in {-1, 0, +1}
that reached it and the time ``t``; the actions are backward / stop / forward for one
``dt``. The search is depth-first with forward tried first (Algorithm 3), ``ns`` grows
when a motion changes to something else (Algorithm 6, ``Neigh-DF``) and once ``ns``
reaches ``nStop`` a moving arm must keep its motion and a stopped one may stay or go
forward (``Neigh-MaxNS``); collisions are checked every ``dt_col`` between a node and
its parent (Sect. 6.4.2). Goal conflicts (Sect. 6.4.2): the goal is accepted only from
``goal_clear_after`` on.

Errata of Sabater 2018 fixed here: in ``Neigh-MaxNS`` (Algorithm 6 line 6) the forward
neighbour of a stopped node keeps ``m`` (= 0); it must take ``m = +1``, or the next
expansion would stop it again after one step. Neighbours with ``s`` outside [0, 1] are
discarded (the paper's algorithms never check).

Beyond the paper: a node's collision status depends on the transition that reaches it
when ``dt_col < dt``, so a transition that collides does not mark its target node unsafe
(another parent may reach it safely); only safely reached nodes are marked visited.
``resume_edges=True`` lets the search back up into an earlier edge of the path when a
later edge fails, instead of giving up the whole path (the paper's Algorithm 2 keeps an
edge's first trajectory). After ``Arm.t_static`` only forward moves are expanded.
"""
from __future__ import annotations

import math

import numpy as np

from rfp_twin.planners.roadmap.arm import (Arm, ArmTrajectory, RoadmapSettings, SearchStats,
                                           compress_breakpoints)


def neighbour_actions(ns: int, m: int, n_stop: int | None) -> list[tuple[int, int]]:
    """(motion, ns) of the children of a node, least promising first (Algorithms 5-6).

    The depth-first search pops the last entry first, so forward is tried first.

    ``Neigh-MaxNS`` (``ns == nStop``): the node keeps its motion; a stopped node may also
    go forward. Sabater 2018 Algorithm 6 line 6 gives that forward neighbour the current
    ``m`` (0), which would stop it again after one step: it must take ``m = +1``
    (erratum).

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


class PathWalk:
    """What the searches along one roadmap path share: the task, the clock, the bounds.

    The path's edges are cut into whole ``dt`` steps: ``n_seg[e]`` steps for edge e, the
    fastest edge speed <= vmax that divides the edge (Sabater 2018 Sect. 6.4.1).
    """

    def __init__(self, arm: Arm, path: np.ndarray, settings: RoadmapSettings,
                 stats: SearchStats, goal_clear_after: float):
        self.arm = arm
        self.path = path
        self.s = settings
        self.stats = stats
        self.goal_clear_after = goal_clear_after
        vmax = np.asarray(arm.vmax, dtype=np.float64)
        # edge_time of every edge (Eq. 5), in dt steps, rounded up
        steps = np.max(np.abs(np.diff(np.asarray(path), axis=0)) / vmax, axis=1) / settings.dt
        self.n_seg = [max(1, int(math.ceil(x - 1e-9))) for x in steps.tolist()]
        self.n_sub = settings.n_sub
        self.frac = np.arange(1, self.n_sub + 1) / self.n_sub   # sub-check offsets in an action

    def time(self, k: int) -> float:
        return self.arm.t_start + k * self.s.dt

    def time_bounds(self) -> tuple[int | None, int | None]:
        """(k_static, k_max): first time index at which the obstacles have stopped
        (``Arm.t_static``) and last one that may be expanded (``t_max``); None = none."""
        s = self.s
        t_static = self.arm.t_static
        k_static = None if t_static is None else max(0, math.ceil((t_static - self.arm.t_start)
                                                                 / s.dt - 1e-9))
        k_max = None if s.t_max is None else math.floor((s.t_max - self.arm.t_start) / s.dt + 1e-9)
        return k_static, k_max

    def start_collides(self) -> bool:
        """Is the start itself hit at ``t_start``? (one black-box check)"""
        self.stats.checks += 1
        return bool(np.any(self.arm.collides(self.path[:1], np.array([self.arm.t_start]))))


class PathSearch(PathWalk):
    """Depth-first state-time search along one roadmap path (its edges in sequence).

    Node = (edge e, step index i along the edge (s = i / n_seg), ns, m, time index k);
    time of node k is ``t_start + k dt``. Reaching the end of a non-final edge leads,
    with no time passing, to the start of the next edge stopped (a vertex is a stop of
    the motor controller: one start-stop cycle if the arm arrived moving).
    """

    def __init__(self, arm: Arm, path: np.ndarray, settings: RoadmapSettings,
                 stats: SearchStats, goal_clear_after: float):
        super().__init__(arm, path, settings, stats, goal_clear_after)
        # the three actions (-1, 0, +1) of a node are checked in one black-box call
        self.offsets = np.concatenate([-self.frac, 0.0 * self.frac, self.frac])
        self.t_offsets = np.tile(self.frac * settings.dt, 3)
        self.q0 = [np.asarray(path[e], dtype=np.float64) for e in range(len(path) - 1)]
        self.dq = [(np.asarray(path[e + 1], dtype=np.float64) - self.q0[e]) / self.n_seg[e]
                   for e in range(len(path) - 1)]
        self.moves: dict[tuple[int, int, int], np.ndarray] = {}

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
        k_static, k_max = self.time_bounds()
        keyed_ns = n_stop is not None
        # node = (e, i, ns, m, k); the visited key drops (ns, m) when nStop is unlimited:
        # then a node's future does not depend on them
        start = (0, 0, 0, 0, 0)
        if self.start_collides():
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
        times, configs = compress_breakpoints(times, configs)
        return ArmTrajectory(times, configs, self.path.copy(), int(chain[-1][2]), n_go, n_stop)
