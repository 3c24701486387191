"""Earliest-arrival state-time search along one roadmap path, one time layer at a time.

Beyond Sabater et al. 2018 (``RoadmapSettings(search="sweep")``, unlimited ``n_stop``
only): the state-time graph of their Sect. 6.4 (:mod:`rfp_twin.planners.roadmap.search`)
explored breadth first in time, all reachable positions of a layer checked in one
black-box call; much faster than node-by-node depth-first search when the arm has to
wait long or the path fails. The two numba kernels build the layer's queries and
advance the reachable set; positions are whole ``dt`` steps along the path, times in the
caller's units.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.planners.roadmap.arm import (Arm, ArmTrajectory, RoadmapSettings, SearchStats,
                                           compress_breakpoints)
from rfp_twin.planners.roadmap.search import PathWalk


#: The actions in the order they take a position: forward, stop, backward (+1, 0, -1
#: along the path); once every obstacle has stopped, only forward.
ACTIONS = (1, 0, -1)


@njit(cache=True)
def action_taken(reach, p, m, P, static):
    """Is action ``m`` (of :data:`ACTIONS`) tried from position ``p`` of ``P + 1``:
    ``p`` reachable, the move stays on the path, and forward only when ``static``."""
    return reach[p] and not ((m == 1 and p == P) or (m == -1 and p == 0)
                             or (static and m != 1))


@njit(cache=True)
def action_step(D, p, m, c):
    """Joint ``c``'s change over action ``m`` from position ``p``: ``D[p]`` forward,
    ``-D[p - 1]`` backward, 0 for a stop."""
    if m == 1:
        return D[p, c]
    if m == -1:
        return -D[p - 1, c]
    return 0.0


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
    for m in ACTIONS:
        for p in range(P + 1):
            if not action_taken(reach, p, m, P, static):
                continue
            src[b] = p
            act[b] = m
            for j in range(K):
                r = b * K + j
                for c in range(d):
                    q[r, c] = Q[p, c] + frac[j] * action_step(D, p, m, c)
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


@njit(cache=True)
def path_positions(pts, p_ptr, vmax, dt):
    """The sweep positions of several roadmap paths at once, as :class:`PathSweep`
    builds them one path at a time: path m is ``pts[p_ptr[m]:p_ptr[m + 1]]`` ((k_m, d)
    vertices); edge e is cut into ``n = max(1, ceil(max_c |dq_c| / vmax_c / dt))`` steps,
    position j of it at ``q_e + (j / n) dq``. Returns (Qs (sum of P_m + 1, d) positions,
    Ds (sum of P_m, d) forward steps, q_ptr (M + 1,): path m's rows of Qs; its rows of Ds
    are ``q_ptr[m] - m:q_ptr[m + 1] - m - 1``)."""
    M = p_ptr.shape[0] - 1
    d = pts.shape[1]
    q_ptr = np.zeros(M + 1, dtype=np.int64)
    n_seg = np.zeros(pts.shape[0], dtype=np.int64)
    for m in range(M):
        total = 1
        for e in range(p_ptr[m], p_ptr[m + 1] - 1):
            x = 0.0
            for c in range(d):
                x = max(x, abs(pts[e + 1, c] - pts[e, c]) / vmax[c])
            n_seg[e] = max(1, int(math.ceil(x / dt - 1e-9)))
            total += n_seg[e]
        q_ptr[m + 1] = q_ptr[m] + total
    Qs = np.empty((q_ptr[M], d))
    Ds = np.empty((q_ptr[M] - M, d))
    for m in range(M):
        r = q_ptr[m]
        Qs[r] = pts[p_ptr[m]]
        r += 1
        for e in range(p_ptr[m], p_ptr[m + 1] - 1):
            n = n_seg[e]
            for j in range(1, n + 1):
                f = j / n
                for c in range(d):
                    Qs[r, c] = pts[e, c] + f * (pts[e + 1, c] - pts[e, c])
                r += 1
        for i in range(q_ptr[m], q_ptr[m + 1] - 1):
            for c in range(d):
                Ds[i - m, c] = Qs[i + 1, c] - Qs[i, c]
    return Qs, Ds, q_ptr


def length_bound(k_static, k_max, n_positions):
    """The last layer a sweep along a path of ``n_positions`` positions (an int or an
    array of them) expands: once the obstacles have stopped (layer ``k_static``), only
    forward moves help, so ``k_static + n_positions``, within ``k_max`` (None: no bound)."""
    if k_static is None:
        return k_max
    bound = k_static + n_positions
    return bound if k_max is None else np.minimum(k_max, bound)


class PathSweep(PathWalk):
    """Earliest-arrival search along one roadmap path, one time layer at a time.

    Beyond the paper (``RoadmapSettings.search = "sweep"``, unlimited ``n_stop`` only):
    the same state-time graph as :class:`PathSearch` (positions ``i / n_seg`` along
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
        super().__init__(arm, path, settings, stats, goal_clear_after)
        pts = np.ascontiguousarray(path, dtype=np.float64)
        # (P + 1, d) configurations and (P, d) forward step from each position
        self.Q, self.D, _ = path_positions(pts, np.array([0, len(pts)], dtype=np.int64),
                                           np.asarray(arm.vmax, dtype=np.float64),
                                           float(settings.dt))
        self.vertex_pos = np.cumsum(self.n_seg).tolist()   # index in Q of each edge's end

    def run(self) -> ArmTrajectory | None:
        s = self.s
        P = len(self.Q) - 1
        k_static, k_max = self.bounds()          # after t_static only forward moves help
        if self.start_collides():
            return None
        if self.arm.sweep is not None:
            return self._run_compiled(k_static, k_max)
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

    def bounds(self) -> tuple[int | None, int | None]:
        """(k_static, k_max) of :meth:`run`: k_max also bounded by the path's length
        (once the obstacles have stopped, only forward moves help)."""
        k_static, k_max = self.time_bounds()
        return k_static, length_bound(k_static, k_max, len(self.Q))

    def _run_compiled(self, k_static: int | None, k_max: int | None) -> ArmTrajectory | None:
        """The layer loop run by the arm's compiled ``sweep`` (same queries and result)."""
        s = self.s
        left = -1 if s.max_nodes is None else max(0, s.max_nodes - self.stats.nodes)
        outcome, k_end, came, nodes, checks = self.arm.sweep(
            self.Q, self.D, self.frac, -1 if k_static is None else k_static,
            -1 if k_max is None else k_max, self.time(0), s.dt, self.goal_clear_after, left)
        self.stats.nodes += int(nodes)
        self.stats.checks += int(checks)
        if outcome == 2:
            self.stats.budget_exhausted = True
        return self._trajectory(came, int(k_end)) if outcome == 0 else None

    def _trajectory(self, came, k_end: int) -> ArmTrajectory:
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
        times, configs = compress_breakpoints(times, configs)
        return ArmTrajectory(times, configs, self.path.copy(), ns + crossed, n_go, len(acts) - n_go)
