"""The search's view of an alpha/beta array: one robot's black boxes on the step clock.

:class:`AlphaBetaWorld` turns a robot of the array into a :class:`rfp_twin.planners.roadmap.Arm`
for the roadmap / state-time planner (Sabater 2018): ``forbidden(q)`` holds the static
obstacles (joint limits, offline robots, fiducials) and ``collides(q, t)`` the moving
ones (every other robot on its current path, a time table of beta segments).

Time grid: one action lasts ``K`` planner steps (``K = round(action_deg / step_deg)``),
and a robot moves at most ``step_deg`` per axis per step (the stepwise planner's speed,
or slower on the shorter axis). Collisions are checked at every step (``dt_col`` = 1
step) with the stepwise planner's step rule (Sayres 2021 Eqs. 6-7): the beta capsules
must be farther apart than ``buffer_i + buffer_j + MD`` (obstacles ``buffer_i +
fid_buffer_f + MD``), ``MD = max_displacement(...)``. Since both robots of a pair
move at most one step per axis between two checks, that margin keeps the pair apart at
the collision buffer in continuous time, exactly as it does for the stepwise planner
(see :mod:`rfp_twin.planners.stepwise.kernel`), so the merged plan passes
:func:`rfp_twin.validation.checker2d.check_trajectory` at the planning buffer.

Per-robot geometry: each robot's beta segment uses its own alpha length, segment start
and end and buffer (``geom.alpha_len``, ``geom.seg_start``, ``geom.seg_end``,
``geom.buffer``, (n,) mm); an obstacle (fiducial: a point, guide-camera edge: a segment
``geom.fid_xy``-``geom.fid_end_xy``) has its own keep-out radius ``geom.fid_buffer``.

Units: mm and degrees; time unit = one planner step (``step_s`` seconds).
"""
from __future__ import annotations

from functools import partial

import math

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.planners.roadmap.alpha_beta.kernels import (block_discs, edges_forbidden,
                                                      moving_collisions, pair_conflict, reach_of,
                                                      segments_at, static_collisions,
                                                      sweep_layers, sweep_paths)
from rfp_twin.planners.roadmap.alpha_beta.paths import PathSet
from rfp_twin.planners.roadmap import Arm, ArmTrajectory

#: Coordinate (mm) that puts an obstacle out of reach once it is gone.
_FAR_MM = 1.0e7


class AlphaBetaWorld:
    """Black boxes ``forbidden(q)`` and ``collides(q, t)`` of alpha/beta robots on a step clock.

    Parameters
    ----------
    geom : ArrayGeometry (layout, spec, per-robot geometry and buffers, Eq. 4
        neighbours, obstacles)
    paths : PathSet, every robot's current path in the planning frame (step clock)
    movable : (n,) bool; False = offline robot (a static obstacle at its path's start)
    md : float, step-rule margin MD, mm (:func:`rfp_twin.planners.stepwise.max_displacement`)
    step_deg : float, planner step, deg (the search's top speed: one step per axis per step)
    """

    def __init__(self, geom: ArrayGeometry, paths: PathSet, movable: np.ndarray, md: float,
                 step_deg: float):
        self.geom = geom
        self.paths = paths
        self.movable = np.asarray(movable, dtype=bool)
        self.md = float(md)
        self.step_deg = float(step_deg)
        #: (n, 4) each robot's travel range, model deg
        self.limits = np.ascontiguousarray(geom.limits)
        #: robot index -> (obstacle robot indices, collisions met) of its latest arm
        self.hits: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        #: (robot index, its static neighbours) -> the edge memo its arms share: the
        #: ``forbidden`` zone depends on nothing else, so an edge is checked once per
        #: search instead of once per plan of the robot
        self.edge_memos: dict[tuple, dict] = {}

    def conflict(self, i: int, tri: ArmTrajectory, j: int, trj: ArmTrajectory) -> bool:
        """Do robots i and j, on these trajectories (step clock), break the step rule?

        Both are sampled at every step up to the later end (each holds its last
        configuration); True when their capsules come within ``buffer_i + buffer_j +
        MD`` at some step. Robots that are not Eq. 4 neighbours never conflict.
        """
        g = self.geom
        if j not in set(int(x) for x in self.neighbours(i)):
            return False
        t_last = int(math.ceil(max(tri.t_end, trj.t_end)))
        ks = np.arange(t_last + 1, dtype=np.float64)
        sa = self.segments(i, tri.at(ks))
        sb = self.segments(j, trj.at(ks))
        return bool(pair_conflict(sa, sb, float(g.buffer[i] + g.buffer[j]) + self.md))

    def segments(self, i: int, ang: np.ndarray) -> np.ndarray:
        """Robot index i's beta segments (T, 4) mm at angles ``ang`` (T, 2) deg, with its
        own alpha length and segment (``geom.alpha_len[i]``, ``seg_start[i]``, ``seg_end[i]``)."""
        g = self.geom
        return segments_at(float(g.base_xy[i, 0]), float(g.base_xy[i, 1]),
                           np.ascontiguousarray(ang, dtype=np.float64), float(g.alpha_len[i]),
                           float(g.seg_start[i]), float(g.seg_end[i]))

    def obstacles(self, i: int, th: float):
        """The obstacles near robot index i, split for :func:`.kernels.static_collisions`.

        Returns ``(seg (a, 4), seg_th (a,), pt (b, 2), pt_th (b,))`` mm: segment obstacles
        (guide-camera edges, ``fid_xy``-``fid_end_xy``) and point obstacles (fiducials),
        each with threshold ``th + fid_buffer[f]`` (``th``: robot i's buffer, mm; the
        caller adds MD afterwards, which keeps the nominal sum ``(b_i + b_f) + MD``).
        """
        g = self.geom
        fids = g.fid_idx[g.fid_ptr[i]:g.fid_ptr[i + 1]]
        a = np.asarray(g.fid_xy, dtype=np.float64).reshape(-1, 2)[fids]
        b = np.asarray(g.fid_end_xy, dtype=np.float64).reshape(-1, 2)[fids]
        fb = np.asarray(g.fid_buffer, dtype=np.float64).reshape(-1)[fids]
        point = np.all(a == b, axis=1)
        seg = np.ascontiguousarray(np.hstack([a[~point], b[~point]])).reshape(-1, 4)
        return (seg, th + fb[~point], np.ascontiguousarray(a[point]).reshape(-1, 2),
                th + fb[point])

    def blockers(self, i: int, exclude=()) -> list[int]:
        """Moving obstacles robot i met most in its latest search, most first."""
        if i not in self.hits:
            return []
        robots, counts = self.hits[i]
        order = np.argsort(-counts, kind="stable")
        ex = set(int(j) for j in exclude)
        return [int(robots[k]) for k in order if counts[k] > 0 and int(robots[k]) not in ex]

    def neighbours(self, i: int) -> np.ndarray:
        g = self.geom
        return g.nbr_idx[g.nbr_ptr[i]:g.nbr_ptr[i + 1]]

    def arm(self, i: int, start: np.ndarray, goal: np.ndarray, t_start: float = 0.0,
            ignore: frozenset[int] = frozenset(), override: dict | None = None) -> Arm:
        """Robot index i as a :class:`rfp_twin.planners.roadmap.Arm` on the step clock.

        Parameters
        ----------
        i : robot index; start, goal : (2,) deg; t_start : step at which it leaves start
        ignore : robot indices that are no obstacle at all (group members not planned yet
            that have no fixed prefix)
        override : {robot index: (steps, angles, active_until)}: paths that replace the
            ones of ``self.paths`` (members planned before i, or a member's fixed
            prefix); after ``active_until`` (a step, or None = never) the robot is no
            obstacle any more (a member not planned yet, beyond its prefix)
        """
        g = self.geom
        override = override or {}
        bx, by = float(g.base_xy[i, 0]), float(g.base_xy[i, 1])
        s1 = float(g.seg_end[i])
        bi = float(g.buffer[i])
        movers, statics = [], []
        for j in self.neighbours(i):
            j = int(j)
            if j == i or j in ignore:
                continue
            (movers if self.movable[j] else statics).append(j)
        # time table of the moving obstacles, to the step where the last one stops
        ends = []
        for j in movers:
            if j in override:
                st, an, until = override[j]
                ends.append(float(st[-1]) if until is None else float(until))
            else:
                ends.append(self.paths.motion_end(j))
        t_last = int(math.ceil(max(ends + [t_start], default=0.0)))
        ks = np.arange(t_last + 1, dtype=np.float64)
        obs_seg = np.empty((t_last + 1, len(movers), 4))
        obs_rho = np.empty((t_last + 1, len(movers)))
        obs_d = np.empty(len(movers))
        obs_th = np.empty(len(movers))
        for o, j in enumerate(movers):
            until = None
            if j in override:
                st, an, until = override[j]
                ang = np.column_stack([np.interp(ks, st, an[:, 0]), np.interp(ks, st, an[:, 1])])
            else:
                ang = self.paths.sample(j, ks)
            obs_seg[:, o, :] = self.segments(j, ang)
            bjx, bjy = float(g.base_xy[j, 0]), float(g.base_xy[j, 1])
            obs_rho[:, o] = reach_of(obs_seg[:, o, :], bjx, bjy)
            obs_d[o] = math.hypot(bjx - bx, bjy - by)
            if until is not None:
                gone = ks > until
                obs_seg[gone, o, :] = _FAR_MM           # gone: no longer an obstacle
                obs_rho[gone, o] = -_FAR_MM
            obs_th[o] = bi + float(g.buffer[j]) + self.md
        st_seg = np.empty((len(statics), 4))
        st_th = np.empty(len(statics))
        for o, j in enumerate(statics):
            a = self.paths.angles[j][0]
            st_seg[o] = self.segments(j, a[None, :])[0]
            st_th[o] = bi + float(g.buffer[j]) + self.md
        # obstacles: segments join the static robots' table, points keep their own test
        ob_seg, ob_th, pt_xy, pt_th = self.obstacles(i, bi)
        pt_th = pt_th + self.md
        st_seg = np.ascontiguousarray(np.vstack([st_seg, ob_seg]))
        st_th = np.concatenate([st_th, ob_th + self.md])
        l_alpha, s0, limits = float(g.alpha_len[i]), float(g.seg_start[i]), self.limits[i]
        obs_blk = block_discs(obs_seg)
        hits = np.zeros(len(movers), dtype=np.int64)
        self.hits[i] = (np.array(movers, dtype=np.int64), hits)

        def collides(q: np.ndarray, t: np.ndarray) -> np.ndarray:
            out = np.empty(q.shape[0], dtype=np.bool_)
            moving_collisions(np.ascontiguousarray(q, dtype=np.float64), np.asarray(t, dtype=np.float64),
                      bx, by, l_alpha, s0, s1, obs_seg, obs_rho, obs_d, obs_th, out, hits)
            return out

        def forbidden(q: np.ndarray) -> np.ndarray:
            out = np.empty(q.shape[0], dtype=np.bool_)
            static_collisions(np.ascontiguousarray(q, dtype=np.float64), bx, by, l_alpha, s0, s1, limits,
                       st_seg, st_th, pt_xy, pt_th, out)
            return out

        def along_edges(q0s: np.ndarray, q1s: np.ndarray, step: np.ndarray):
            out = np.empty(q0s.shape[0], dtype=np.bool_)
            counts = np.empty(q0s.shape[0], dtype=np.int64)
            edges_forbidden(np.ascontiguousarray(q0s, dtype=np.float64),
                            np.ascontiguousarray(q1s, dtype=np.float64),
                            np.ascontiguousarray(step, dtype=np.float64), bx, by, l_alpha, s0,
                            s1, limits, st_seg, st_th, pt_xy, pt_th, out, counts)
            return out, counts

        def sweep(Q, D, frac, k_static, k_max, t0, dt, goal_after, nodes_left):
            return sweep_layers(np.ascontiguousarray(Q, dtype=np.float64),
                                np.ascontiguousarray(D, dtype=np.float64),
                                np.ascontiguousarray(frac, dtype=np.float64), int(k_static),
                                int(k_max), float(t0), float(dt), float(goal_after),
                                int(nodes_left), bx, by, l_alpha, s0, s1, obs_seg, obs_rho,
                                obs_d, obs_th, obs_blk, hits)
        sweep.hits = hits            # the blocker counts it adds to

        def sweep_many(Qs, Ds, q_ptr, frac, k_static, k_maxs, t0, dt, goal_after, nodes_left,
                       hits_out, stop):
            return sweep_paths(Qs, Ds, q_ptr, np.ascontiguousarray(frac, dtype=np.float64),
                               int(k_static), k_maxs, float(t0), float(dt), float(goal_after),
                               int(nodes_left), bx, by, l_alpha, s0, s1, obs_seg, obs_rho,
                               obs_d, obs_th, obs_blk, hits_out, stop)

        v = np.full(2, self.step_deg)
        return Arm(start=np.asarray(start, dtype=np.float64), goal=np.asarray(goal, dtype=np.float64),
                   vmax=v, forbidden=forbidden, collides=collides,
                   lower=limits[[0, 2]].copy(), upper=limits[[1, 3]].copy(),
                   t_start=float(t_start), hold_until=float(t_last), t_static=float(t_last),
                   via=partial(self.via, robot=i), sweep=sweep, sweep_paths=sweep_many,
                   edges_forbidden=along_edges,
                   edge_memo=self.edge_memos.setdefault((i, tuple(statics)), {}))

    def via(self, start: np.ndarray, goal: np.ndarray, robot: int) -> list[np.ndarray]:
        """Extra roadmap paths: retract beta fully, turn alpha, then go to the goal.

        A beta arm folded over its own axis (beta = 180 deg) sweeps the smallest disk
        when alpha turns (at 3.5 mm a robot at beta = 170 deg cannot turn past a folded
        neighbour, at 180 deg it can). Paths: ``start -> (alpha_s, 180) -> (alpha_g, 180)
        -> goal`` and, if the goal's beta is not 180, the same with the goal's beta (180
        clipped to the robot's beta range).
        """
        b_fold = float(np.clip(180.0, self.limits[robot, 2], self.limits[robot, 3]))
        out = [np.array([[start[0], b_fold], [goal[0], b_fold]])]
        return out
