"""The roadmap of one arm in joint space (Sabater et al. 2018, Sect. 6.1).

Grid vertices outside the forbidden zone, random edges between vertex pairs (each
vertex in at most one), and the paths ``start -> goal``, ``start -> v -> goal`` and
``start -> v_i -> v_j -> goal``, all made of straight joint-space edges (the MIRADAS
motor controllers cannot blend). Paths are tried cheapest first by the estimated travel
time of Sabater 2018 Eq. 5, ``t_e = max_k |dtheta_k| / vmax_k`` per edge (ties in
random order). Beyond the paper, ``RoadmapSettings.corner_vertices`` adds the vertices of
"one joint after the other" and "every joint at full speed" moves
(:func:`_corner_vertices`), which the grid may miss. Joint and time units are the
caller's (:mod:`rfp_twin.planners.roadmap.arm`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.planners.roadmap.arm import Arm, RoadmapSettings


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


def edge_samples(q0: np.ndarray, q1: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Points along the straight edge q0 -> q1, ends included, at most ``step`` apart per joint."""
    n = int(max(1, math.ceil(float(np.max(np.abs(q1 - q0) / step)) - 1e-9)))
    f = np.linspace(0.0, 1.0, n + 1)[:, None]
    return q0[None, :] + f * (q1 - q0)[None, :]


class EdgeFeasibility:
    """Memoised ``forbidden`` check of straight edges (the path's edges must avoid the ZoA)."""

    def __init__(self, arm: Arm, step: np.ndarray):
        self.arm = arm
        self.step = step
        # the arm's shared memo (keyed with the check step too), or a new one
        self.memo: dict[bytes, bool] = {} if arm.edge_memo is None else arm.edge_memo
        self.checks = 0

    def prefetch(self, paths: list) -> None:
        """Check every edge of ``paths`` ((k, d) arrays) not yet in the memo, in one
        ``Arm.edges_forbidden`` call (nothing without one): the same answers as
        :meth:`ok` one edge at a time."""
        self._fill(paths, self._path_keys(paths))

    def clear_paths(self, paths: list) -> list:
        """``paths`` whose every edge avoids the forbidden zone, in order (the edges not
        yet known checked together, as :meth:`prefetch`)."""
        keys = self._path_keys(paths)
        self._fill(paths, keys)
        return [p for p, ks in zip(paths, keys)
                if all(self._known(key, p[k], p[k + 1]) for k, key in enumerate(ks))]

    def ok(self, q0: np.ndarray, q1: np.ndarray) -> bool:
        return self._known(self._key(q0, q1), q0, q1)

    def _key(self, q0: np.ndarray, q1: np.ndarray) -> bytes:
        """The memo key of edge q0 -> q1 (with the check step: memos are shared)."""
        return np.concatenate([q0, q1, self.step]).tobytes()

    def _path_keys(self, paths: list) -> list[list[bytes]]:
        return [[self._key(p[k], p[k + 1]) for k in range(len(p) - 1)] for p in paths]

    def _fill(self, paths: list, keys: list[list[bytes]]) -> None:
        """The memo entries of the edges of ``paths`` (``keys`` theirs) not yet in it, by
        one ``Arm.edges_forbidden`` call (nothing without one)."""
        if self.arm.edges_forbidden is None:
            return
        new, q0s, q1s = [], [], []
        for path, ks in zip(paths, keys):
            for k, key in enumerate(ks):
                if key not in self.memo:
                    self.memo[key] = None            # placeholder: one check per edge
                    new.append(key)
                    q0s.append(path[k])
                    q1s.append(path[k + 1])
        if not new:
            return
        hit, counts = self.arm.edges_forbidden(np.array(q0s), np.array(q1s), self.step)
        self.checks += int(counts.sum())
        for key, h in zip(new, hit.tolist()):
            self.memo[key] = not h

    def _known(self, key: bytes, q0: np.ndarray, q1: np.ndarray) -> bool:
        """The memo's answer for edge q0 -> q1 (``key``), checked point by point if absent."""
        hit = self.memo.get(key)
        if hit is None:
            pts = edge_samples(q0, q1, self.step)
            self.checks += len(pts)
            hit = not bool(np.any(self.arm.forbidden(pts)))
            self.memo[key] = hit
        return hit


def build_roadmap(arm: Arm, settings: RoadmapSettings, rng: np.random.Generator,
                  feasible: EdgeFeasibility | None = None) -> Roadmap:
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
        feasible = EdgeFeasibility(arm, edge_check_spacing(arm, settings))
    axes = [np.linspace(lo, hi, int(g)) if int(g) > 1 else np.array([0.5 * (lo + hi)])
            for lo, hi, g in zip(arm.lower, arm.upper, settings.grid)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
    extra = [grid]
    if arm.extra_vertices is not None and len(arm.extra_vertices):
        extra.append(np.asarray(arm.extra_vertices, dtype=np.float64).reshape(-1, d))
    if settings.corner_vertices and d > 1:
        extra.append(_corner_vertices(start, goal, vmax))
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
    via_one = np.empty((len(verts), 3, d))         # start -> v -> goal for every vertex v
    via_one[:, 0], via_one[:, 1], via_one[:, 2] = start, verts, goal
    paths += list(via_one)
    for i, j in edges:
        paths.append(np.stack([start, verts[i], verts[j], goal]))
        paths.append(np.stack([start, verts[j], verts[i], goal]))
    if arm.via is not None:
        for mid in arm.via(start, goal):
            mid = np.asarray(mid, dtype=np.float64).reshape(-1, d)
            paths.append(np.vstack([start[None, :], mid, goal[None, :]]))
    est = _path_times(paths, vmax)
    tie = rng.random(len(paths))
    order = np.lexsort((tie, np.round(est, 9)))
    return Roadmap(verts, edges_arr, [paths[k] for k in order], est[order])


def _path_times(paths: list, vmax: np.ndarray) -> np.ndarray:
    """(len(paths),) Eq. 5 summed over each path's edges (edge after edge, as
    :func:`edge_time`), paths of equal length at once."""
    est = np.empty(len(paths))
    lengths = np.array([len(p) for p in paths])
    for m in np.unique(lengths):
        rows = np.flatnonzero(lengths == m)
        stack = np.stack([paths[k] for k in rows])                 # (r, m, d)
        per_edge = np.max(np.abs(np.diff(stack, axis=1)) / vmax, axis=2)
        total = np.zeros(len(rows))
        for k in range(m - 1):
            total = total + per_edge[:, k]
        est[rows] = total
    return est


def _corner_vertices(start: np.ndarray, goal: np.ndarray, vmax: np.ndarray) -> np.ndarray:
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


def edge_check_spacing(arm: Arm, settings: RoadmapSettings) -> np.ndarray:
    """(dim,) spacing, joint units, at which an edge's configurations are checked:
    ``settings.edge_check_step``, else each joint's top speed over one collision step."""
    if settings.edge_check_step is not None:
        return np.full(arm.dim, float(settings.edge_check_step))
    dt_col = settings.dt if settings.dt_col is None else settings.dt_col
    return np.asarray(arm.vmax, dtype=np.float64) * dt_col
