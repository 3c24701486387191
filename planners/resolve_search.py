"""Deadlock resolution that keeps targets: Sabater's state-time search for alpha/beta robots.

The reverse GC/MC planner (:mod:`planners.stepwise`) sometimes leaves a group of robots
deadlocked (Sayres 2021 Sect. 5.2). Instead of replacing one target of the group, this
module re-plans the group with the roadmap / state-time planner of
:mod:`planners.roadmap` (Sabater 2018), in the planner's frame (reverse: each
deadlocked robot goes from its target, at step 0, to the folded state):

* every robot outside the group follows its existing stepwise path, a **moving
  obstacle** on the planner's step clock (after its last breakpoint it stays put);
  fiducials, offline robots and the joint limits are **static** (``forbidden``);
* the group's robots are planned one at a time, each against the robots above it in a
  priority order (Sabater's Algorithm 1), and the order itself is searched
  (:func:`planners.roadmap.priority_search`): where two trajectories conflict, one
  robot yields to the other and is planned again;
* a deadlocked robot may keep, for as long as it likes, the stepwise motion it made
  before it got stuck (its lead-in, :attr:`planners.roadmap.Arm.lead_in`); if that
  fails, the group is searched again from step 0;
* a robot that finds no trajectory at all **recruits** the neighbours that blocked it
  most (robots that had reached their destination): they join the group below it and
  may leave their stepwise paths at any time to make way (``max_recruits`` at most);
* each robot's roadmap (25 x 25 grid over the joint limits, random edges, the
  start/goal corners) also holds a "retract beta to 180 deg, turn alpha, go to the
  goal" path (:meth:`AlphaBetaWorld.via`): a beta arm folded over its own axis sweeps
  the smallest disk when alpha turns;
* the single-robot search is Sabater's state-time graph explored one time layer at a
  time (``search="sweep"``, earliest arrival; ``"dfs"`` is the paper's depth-first
  search); start-stop cycles are unlimited: stepwise plans stop and restart freely and
  post-processing smooths them.

What made it work (deadlocked groups of the first greedy run on the 547 grid that the
search resolved; 2.5 mm / 0.25 deg seeds 0-7 or 0-15, 3.5 mm / 0.1 deg seeds 0-2, 29
groups): Sabater's fixed order with reorder-on-failure, 13 x 13 grid, lead-in or step-0
start: 80 % / 62 %; plus recruiting blocking neighbours: 95 % / 76 %; the search over
priorities with 25 x 25 grids, 300 paths and 200 000 nodes per robot: - / 90 %.
Whole-plan figures, with replacement where the search fails: benchmarks/RESULTS.md.

Time grid: one action lasts ``K`` planner steps (``K = round(action_deg / step_deg)``),
and a robot moves at most ``step_deg`` per axis per step (the stepwise planner's speed,
or slower on the shorter axis). Collisions are checked at every step (``dt_col`` = 1
step) with the stepwise planner's step rule (Sayres 2021 Eqs. 6-7): the beta capsules
must be farther apart than ``buffer_i + buffer_j + MD`` (fiducials ``buffer_i +
fiducial_buffer + MD``), ``MD = max_displacement(...)``. Since both robots of a pair
move at most one step per axis between two checks, that margin keeps the pair apart at
the collision buffer in continuous time, exactly as it does for the stepwise planner
(see the :mod:`planners.stepwise` docstring), so the merged plan passes
:func:`validation.checker2d.check_trajectory` at the planning buffer.

Units: mm and degrees; the search runs on the step clock (time unit = one planner step,
``step_s`` seconds).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit

from models.array import ArrayGeometry
from models.errors import SpecError, field_error
from models.geometry2d import beta_segment, point_segment_distance, segments_within
from planners.roadmap import Arm, ArmTrajectory, RoadmapSettings, priority_search

DEG = math.pi / 180.0


# ------------------------------------------------------------------------------------
# Settings
# ------------------------------------------------------------------------------------
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
        (:func:`planners.roadmap.priority_search`)
    resume_edges : bool, see :class:`planners.roadmap.RoadmapSettings`
    max_recruits : int, most non-deadlocked neighbours that may join a group to make way
        for a robot they block (re-planned below it, free to leave their stepwise paths)
    max_departures : int, times at which a deadlocked robot may leave the stepwise
        motion it made before it got stuck (latest first)
    search : "sweep" (earliest arrival, one time layer at a time) | "dfs" (Sabater's
        depth-first search); see :class:`planners.roadmap.RoadmapSettings`
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
                               max_departures=self.max_departures, search=self.search)


# ------------------------------------------------------------------------------------
# Paths on the step clock
# ------------------------------------------------------------------------------------
@dataclass
class PathSet:
    """Per-robot breakpoint paths on the step clock, in the planner's frame.

    steps[i] : (k,) float64 step index (non-decreasing); angles[i] : (k, 2) deg.
    Before the first / after the last breakpoint a robot holds its first / last angles.
    """

    steps: list
    angles: list

    @classmethod
    def from_csr(cls, ptr: np.ndarray, steps: np.ndarray, angles: np.ndarray) -> PathSet:
        n = len(ptr) - 1
        return cls([steps[ptr[i]:ptr[i + 1]].copy() for i in range(n)],
                   [angles[ptr[i]:ptr[i + 1]].copy() for i in range(n)])

    def to_csr(self, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CSR arrays (ptr, steps, angles) with every path ending at ``n_steps``.

        Breakpoints after ``n_steps`` are dropped; a path must not move after it."""
        st, an = [], []
        for i, (s, a) in enumerate(zip(self.steps, self.angles)):
            if s[-1] > n_steps:
                if self.motion_end(i) > n_steps:
                    raise field_error(SpecError, "n_steps", n_steps,
                                      f">= {self.motion_end(i)} (robot index {i} still moves)",
                                      "PathSet.to_csr")
                keep = s < n_steps
                s = np.append(s[keep], float(n_steps))
                a = np.vstack([a[keep], a[-1:]])
            if s[-1] < n_steps:
                s = np.append(s, float(n_steps))
                a = np.vstack([a, a[-1:]])
            st.append(s)
            an.append(a)
        ptr = np.zeros(len(st) + 1, dtype=np.int64)
        ptr[1:] = np.cumsum([len(s) for s in st])
        return ptr, np.concatenate(st), np.concatenate(an)

    def motion_end(self, i: int) -> float:
        """Step of robot i's last motion (its last breakpoint that changes the angles)."""
        a = self.angles[i]
        moved = np.flatnonzero(np.any(np.abs(np.diff(a, axis=0)) > 1e-12, axis=1))
        return 0.0 if moved.size == 0 else float(self.steps[i][moved[-1] + 1])

    def signature(self, i: int) -> bytes:
        """Robot i's path up to its last motion, as bytes (equal paths, equal bytes)."""
        a = self.angles[i]
        moved = np.flatnonzero(np.any(np.abs(np.diff(a, axis=0)) > 1e-12, axis=1))
        k = 1 if moved.size == 0 else int(moved[-1]) + 2
        return self.steps[i][:k].tobytes() + a[:k].tobytes()

    def sample(self, i: int, k: np.ndarray) -> np.ndarray:
        """Robot i's angles at steps k: (len(k), 2) deg."""
        s, a = self.steps[i], self.angles[i]
        return np.column_stack([np.interp(k, s, a[:, 0]), np.interp(k, s, a[:, 1])])


# ------------------------------------------------------------------------------------
# Numba kernels: the black boxes' inner loops
# ------------------------------------------------------------------------------------
@njit(cache=True)
def _segments_at(base_x, base_y, ang, l_alpha, s0, s1):
    """Beta segments (x0, y0, x1, y1) of one robot at each row of ang (T, 2) deg: (T, 4)."""
    out = np.empty((ang.shape[0], 4))
    for k in range(ang.shape[0]):
        x0, y0, x1, y1 = beta_segment(base_x, base_y, ang[k, 0], ang[k, 1], l_alpha, s0, s1)
        out[k, 0] = x0
        out[k, 1] = y0
        out[k, 2] = x1
        out[k, 3] = y1
    return out


@njit(cache=True)
def _collides(q, t, bx, by, l_alpha, s0, s1, obs_seg, obs_rho, obs_d, obs_th, out, hits):
    """Moving-obstacle test of one robot.

    q : (m, 2) deg; t : (m,) step index (whole numbers; clamped to the table)
    obs_seg : (T + 1, n_obs, 4) obstacle beta segments at each step, mm
    obs_rho : (T + 1, n_obs) farthest point of each obstacle segment from its base, mm
    obs_d : (n_obs,) base-to-base distance, mm
    obs_th : (n_obs,) clearance threshold per obstacle (buffer_i + buffer_j + MD), mm
    out : (m,) bool, written
    hits : (n_obs,) int64, incremented for the first obstacle each colliding query meets

    Two base disks farther apart than the threshold are skipped before the exact test.
    """
    n_t = obs_seg.shape[0]
    n_obs = obs_seg.shape[1]
    for r in range(q.shape[0]):
        k = int(round(t[r]))
        if k < 0:
            k = 0
        elif k >= n_t:
            k = n_t - 1
        x0, y0, x1, y1 = beta_segment(bx, by, q[r, 0], q[r, 1], l_alpha, s0, s1)
        rho = math.sqrt(max((x0 - bx) ** 2 + (y0 - by) ** 2, (x1 - bx) ** 2 + (y1 - by) ** 2))
        hit = False
        for o in range(n_obs):
            if obs_d[o] - rho - obs_rho[k, o] > obs_th[o]:
                continue
            if segments_within(x0, y0, x1, y1, obs_seg[k, o, 0], obs_seg[k, o, 1],
                               obs_seg[k, o, 2], obs_seg[k, o, 3], obs_th[o]):
                hit = True
                hits[o] += 1
                break
        out[r] = hit


@njit(cache=True)
def _reach_of(seg, bx, by):
    """(T,) farthest distance of each segment (T, 4) from the base (bx, by), mm."""
    out = np.empty(seg.shape[0])
    for k in range(seg.shape[0]):
        out[k] = math.sqrt(max((seg[k, 0] - bx) ** 2 + (seg[k, 1] - by) ** 2,
                               (seg[k, 2] - bx) ** 2 + (seg[k, 3] - by) ** 2))
    return out


@njit(cache=True)
def _forbidden(q, bx, by, l_alpha, s0, s1, limits, st_seg, st_th, pt_xy, pt_th, out):
    """Static test of one robot: joint limits, static segments (offline robots), points
    (fiducials). q (m, 2) deg; limits (4,) deg; st_seg (a, 4) mm, st_th (a,) mm;
    pt_xy (b, 2) mm, pt_th (b,) mm; out (m,) bool."""
    for r in range(q.shape[0]):
        a = q[r, 0]
        b = q[r, 1]
        if a < limits[0] - 1e-9 or a > limits[1] + 1e-9 or b < limits[2] - 1e-9 or b > limits[3] + 1e-9:
            out[r] = True
            continue
        x0, y0, x1, y1 = beta_segment(bx, by, a, b, l_alpha, s0, s1)
        hit = False
        for o in range(st_seg.shape[0]):
            if segments_within(x0, y0, x1, y1, st_seg[o, 0], st_seg[o, 1], st_seg[o, 2],
                               st_seg[o, 3], st_th[o]):
                hit = True
                break
        if not hit:
            for o in range(pt_xy.shape[0]):
                if point_segment_distance(pt_xy[o, 0], pt_xy[o, 1], x0, y0, x1, y1) <= pt_th[o]:
                    hit = True
                    break
        out[r] = hit


# ------------------------------------------------------------------------------------
# The alpha/beta adapter: one robot's black boxes
# ------------------------------------------------------------------------------------
class AlphaBetaWorld:
    """Black boxes ``forbidden(q)`` and ``collides(q, t)`` of alpha/beta robots on a step clock.

    Parameters
    ----------
    geom : ArrayGeometry (layout, spec, buffers, Eq. 4 neighbours, fiducials)
    paths : PathSet, every robot's current path in the planning frame (step clock)
    movable : (n,) bool; False = offline robot (a static obstacle at its path's start)
    md : float, step-rule margin MD, mm (:func:`planners.stepwise.max_displacement`)
    step_deg : float, planner step, deg (the search's top speed: one step per axis per step)
    """

    def __init__(self, geom: ArrayGeometry, paths: PathSet, movable: np.ndarray, md: float,
                 step_deg: float):
        self.geom = geom
        self.paths = paths
        self.movable = np.asarray(movable, dtype=bool)
        self.md = float(md)
        self.step_deg = float(step_deg)
        spec = geom.spec
        self.l_alpha = float(spec.alpha_length_mm)
        self.s0 = float(spec.segment_start_mm)
        self.limits = np.array([*spec.alpha_limits_deg, *spec.beta_limits_deg], dtype=np.float64)
        #: robot index -> (obstacle robot indices, collisions met) of its latest arm
        self.hits: dict[int, tuple[np.ndarray, np.ndarray]] = {}

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
        sa = _segments_at(float(g.base_xy[i, 0]), float(g.base_xy[i, 1]),
                          np.ascontiguousarray(tri.at(ks)), self.l_alpha, self.s0, float(g.seg_end[i]))
        sb = _segments_at(float(g.base_xy[j, 0]), float(g.base_xy[j, 1]),
                          np.ascontiguousarray(trj.at(ks)), self.l_alpha, self.s0, float(g.seg_end[j]))
        return bool(_pair_conflict(sa, sb, float(g.buffer[i] + g.buffer[j]) + self.md))

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
        """Robot index i as a :class:`planners.roadmap.Arm` on the step clock.

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
            obs_seg[:, o, :] = _segments_at(float(g.base_xy[j, 0]), float(g.base_xy[j, 1]),
                                            np.ascontiguousarray(ang), self.l_alpha, self.s0,
                                            float(g.seg_end[j]))
            bjx, bjy = float(g.base_xy[j, 0]), float(g.base_xy[j, 1])
            obs_rho[:, o] = _reach_of(obs_seg[:, o, :], bjx, bjy)
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
            st_seg[o] = _segments_at(float(g.base_xy[j, 0]), float(g.base_xy[j, 1]),
                                     np.ascontiguousarray(a[None, :]), self.l_alpha, self.s0,
                                     float(g.seg_end[j]))[0]
            st_th[o] = bi + float(g.buffer[j]) + self.md
        fids = g.fid_idx[g.fid_ptr[i]:g.fid_ptr[i + 1]]
        pt_xy = np.ascontiguousarray(g.fid_xy[fids], dtype=np.float64).reshape(-1, 2)
        pt_th = np.full(len(fids), bi + g.fiducial_buffer + self.md)
        l_alpha, s0, limits = self.l_alpha, self.s0, self.limits
        hits = np.zeros(len(movers), dtype=np.int64)
        self.hits[i] = (np.array(movers, dtype=np.int64), hits)

        def collides(q: np.ndarray, t: np.ndarray) -> np.ndarray:
            out = np.empty(q.shape[0], dtype=np.bool_)
            _collides(np.ascontiguousarray(q, dtype=np.float64), np.asarray(t, dtype=np.float64),
                      bx, by, l_alpha, s0, s1, obs_seg, obs_rho, obs_d, obs_th, out, hits)
            return out

        def forbidden(q: np.ndarray) -> np.ndarray:
            out = np.empty(q.shape[0], dtype=np.bool_)
            _forbidden(np.ascontiguousarray(q, dtype=np.float64), bx, by, l_alpha, s0, s1, limits,
                       st_seg, st_th, pt_xy, pt_th, out)
            return out

        v = np.full(2, self.step_deg)
        return Arm(start=np.asarray(start, dtype=np.float64), goal=np.asarray(goal, dtype=np.float64),
                   vmax=v, forbidden=forbidden, collides=collides,
                   lower=self.limits[[0, 2]].copy(), upper=self.limits[[1, 3]].copy(),
                   t_start=float(t_start), hold_until=float(t_last), t_static=float(t_last),
                   via=self.via)

    def via(self, start: np.ndarray, goal: np.ndarray) -> list[np.ndarray]:
        """Extra roadmap paths: retract beta fully, turn alpha, then go to the goal.

        A beta arm folded over its own axis (beta = 180 deg) sweeps the smallest disk
        when alpha turns (at 3.5 mm a robot at beta = 170 deg cannot turn past a folded
        neighbour, at 180 deg it can). Paths: ``start -> (alpha_s, 180) -> (alpha_g, 180)
        -> goal`` and, if the goal's beta is not 180, the same with the goal's beta.
        """
        b_fold = float(np.clip(180.0, self.limits[2], self.limits[3]))
        out = [np.array([[start[0], b_fold], [goal[0], b_fold]])]
        return out


#: Coordinate (mm) that puts an obstacle out of reach once it is gone.
_FAR_MM = 1.0e7


def trim_tails(geom: ArrayGeometry, paths: PathSet, dest: np.ndarray, skip: np.ndarray,
               md: float) -> list[int]:
    """Robots that reach their destination and leave it again stay there instead, where
    that is safe. Updates ``paths`` in place; returns the robot indices trimmed.

    A Markov run that deadlocks goes on to its step limit, and the arrived neighbours of
    its stuck robots keep stepping aside and back (Eq. 10) all that time: moving
    obstacles for the search, and a plan as long as the step limit. Robot j's path is
    cut at its first arrival (then it holds its destination) when, at every step from
    there to the end, its held capsule keeps the step rule (``buffer_j + buffer_k + MD``)
    with the *current* path of every Eq. 4 neighbour k; robots are taken in index order,
    each against the paths as trimmed so far, so every pair stays checked. The
    destination is clear of fiducials and offline robots (the caller checked it).

    Parameters
    ----------
    geom : ArrayGeometry; paths : PathSet (planning frame, step clock)
    dest : (n, 2) deg, destinations; skip : (n,) bool, robots left alone (stuck, offline)
    md : float, step-rule margin MD, mm
    """
    l_alpha = float(geom.spec.alpha_length_mm)
    s0 = float(geom.spec.segment_start_mm)
    n = geom.n_robots
    end = max((paths.motion_end(i) for i in range(n)), default=0.0)
    trimmed = []
    for j in range(n):
        if skip[j]:
            continue
        st, an = paths.steps[j], paths.angles[j]
        at = np.flatnonzero(np.all(np.abs(an - dest[j]) < 1e-9, axis=1))
        if at.size == 0 or paths.motion_end(j) <= st[at[0]]:
            continue                    # never arrives, or arrives once and stays
        first = float(st[at[0]])
        ks = np.arange(math.floor(first), math.ceil(end) + 1, dtype=np.float64)
        bj = geom.base_xy[j]
        held = _segments_at(float(bj[0]), float(bj[1]), np.ascontiguousarray(
            np.repeat(dest[j][None, :], ks.size, axis=0)), l_alpha, s0, float(geom.seg_end[j]))
        ok = True
        for k in geom.nbr_idx[geom.nbr_ptr[j]:geom.nbr_ptr[j + 1]]:
            k = int(k)
            bk = geom.base_xy[k]
            seg_k = _segments_at(float(bk[0]), float(bk[1]), np.ascontiguousarray(paths.sample(k, ks)),
                                 l_alpha, s0, float(geom.seg_end[k]))
            if _pair_conflict(held, seg_k, float(geom.buffer[j] + geom.buffer[k]) + md):
                ok = False
                break
        if ok:
            paths.steps[j] = np.append(st[:at[0] + 1], st[-1])
            paths.angles[j] = np.vstack([an[:at[0] + 1], dest[j][None, :]])
            trimmed.append(j)
    return trimmed


# ------------------------------------------------------------------------------------
# Resolving groups
# ------------------------------------------------------------------------------------
@dataclass
class GroupResult:
    """Outcome of one deadlocked group.

    Attributes
    ----------
    group : (g,) robot indices deadlocked together
    members : robot indices re-planned (the group, plus the neighbours it recruited)
    success : bool
    orders_tried : int, nodes of the search over priorities (both starts)
    seconds : float
    hardest : robot index of the group that most often found no trajectory (-1: none)
    """

    group: np.ndarray
    members: np.ndarray
    success: bool
    orders_tried: int
    seconds: float
    hardest: int = -1


@dataclass
class SearchOutcome:
    """What :func:`resolve_groups` did.

    Attributes
    ----------
    paths : PathSet with the paths of every resolved group replaced (planning frame)
    n_steps : int, length of the plan on the step clock: its last motion
    groups : list of GroupResult, in the order processed
    seconds : float, wall time of the search
    trimmed : robot indices whose detours after arriving were cut (:func:`trim_tails`)
    """

    paths: PathSet
    n_steps: int
    groups: list = field(default_factory=list)
    seconds: float = 0.0
    trimmed: list = field(default_factory=list)

    @property
    def failed(self) -> list[np.ndarray]:
        """The groups the search could not resolve."""
        return [g.group for g in self.groups if not g.success]

    @property
    def failed_hardest(self) -> list[int]:
        """For each failed group, the robot that most often found no trajectory (the one
        to give a new target), or -1."""
        return [g.hardest for g in self.groups if not g.success]

    @property
    def resolved_robots(self) -> np.ndarray:
        """Indices of the deadlocked robots whose groups the search resolved."""
        ok = [g.group for g in self.groups if g.success]
        return np.concatenate(ok) if ok else np.zeros(0, dtype=np.int64)


def _prefix(paths: PathSet, i: int, cut: float) -> tuple[np.ndarray, np.ndarray]:
    """Robot i's path up to step ``cut`` (its breakpoints before, and the point at cut)."""
    st, an = paths.steps[i], paths.angles[i]
    keep = st < cut
    end = paths.sample(i, np.array([cut]))
    return np.append(st[keep], cut), np.vstack([an[keep], end])


@njit(cache=True)
def _pair_conflict(seg_a, seg_b, th):
    """True when two robots' segments (T, 4) come within th mm at the same step."""
    for k in range(seg_a.shape[0]):
        if segments_within(seg_a[k, 0], seg_a[k, 1], seg_a[k, 2], seg_a[k, 3],
                           seg_b[k, 0], seg_b[k, 1], seg_b[k, 2], seg_b[k, 3], th):
            return True
    return False


def _traj_from_path(steps: np.ndarray, angles: np.ndarray) -> ArmTrajectory:
    return ArmTrajectory(np.asarray(steps, dtype=np.float64), np.asarray(angles, dtype=np.float64),
                         np.asarray(angles, dtype=np.float64)[[0, -1]], 0, 0, 0)


def _lead_in_end(world: AlphaBetaWorld, i: int, deadlocked: np.ndarray) -> float:
    """Where robot i's lead-in ends: its last motion, or the last motion of its
    neighbours that are not deadlocked if that is earlier. A Markov run that deadlocks
    goes on to its step limit and its stuck robots step about all that time; once their
    neighbours have stopped that motion leads nowhere, and keeping it would only delay
    the fold."""
    settle = max((world.paths.motion_end(int(j)) for j in world.neighbours(i)
                  if not deadlocked[int(j)]), default=0.0)
    return min(world.paths.motion_end(i), settle)


def search_group(world: AlphaBetaWorld, group: np.ndarray, start: np.ndarray, dest: np.ndarray,
                 movable: np.ndarray, deadlocked: np.ndarray, settings: SearchResolveSettings,
                 rng: np.random.Generator):
    """Re-plan one deadlocked group by a search over priorities (Sabater's planner per robot).

    Uses :func:`planners.roadmap.priority_search`: each robot is planned against the
    robots above it only; pairwise conflicts branch on who yields. A robot that finds
    no trajectory recruits the non-deadlocked neighbours it met most (two at a time,
    ``settings.max_recruits`` in all): they join below it, free to leave their stepwise
    paths (their lead-in) to make way. Two starts are tried: (1) each deadlocked robot
    may keep, for as long as it likes, the stepwise motion it made before it got stuck;
    (2) it is searched from step 0 (the other way round with ``settings.step0_first``).

    Returns (success, robot indices re-planned, {robot: (steps, angles)}, tree nodes,
    the deadlocked robot that most often found no trajectory or -1).
    """
    rs = settings.roadmap_settings(world.step_deg)
    nodes = 0
    agents: list[int] = []
    fails: dict[int, int] = {}
    for keep_prefix in ((False, True) if settings.step0_first else (True, False)):
        agents = [int(i) for i in group]
        lead = {}
        if keep_prefix:
            lead = {i: _prefix(world.paths, i, _lead_in_end(world, i, deadlocked)) for i in agents}

        def make_arm(a: int, higher: dict[int, ArmTrajectory], arms: frozenset) -> Arm:
            i = agents[a]
            override = {agents[h]: (tr.times, tr.configs, None) for h, tr in higher.items()}
            # robots of this search node not above i are ignored; robots recruited in
            # another branch are not in this node: their current paths are obstacles
            ignore = frozenset(agents[b] for b in arms if b != a and b not in higher)
            arm = world.arm(i, start[i], dest[i], 0.0, ignore, override)
            if i in lead and lead[i][0][-1] > 0:
                # it may keep its stepwise motion for a while and leave it at any time
                arm = replace(arm, lead_in=lead[i])
            return arm

        def conflict(a: int, tra: ArmTrajectory, b: int, trb: ArmTrajectory) -> bool:
            return world.conflict(agents[a], tra, agents[b], trb)

        def recruit(a: int, limit: int) -> list[tuple[int, ArmTrajectory]]:
            i = agents[a]
            new = [j for j in world.blockers(i, exclude=agents)
                   if movable[j] and not deadlocked[j]][:min(2, limit)]
            out = []
            for j in new:
                agents.append(j)
                lead[j] = _prefix(world.paths, j, world.paths.motion_end(j))
                out.append((len(agents) - 1, _traj_from_path(world.paths.steps[j],
                                                            world.paths.angles[j])))
            return out

        res = priority_search(len(agents), make_arm, conflict, rs, rng, recruit=recruit,
                              max_nodes=settings.priority_nodes,
                              max_recruits=settings.max_recruits)
        nodes += res.nodes
        for a, c in res.failures.items():
            fails[agents[a]] = fails.get(agents[a], 0) + c
        if res.success:
            paths = {agents[a]: (tr.times, tr.configs) for a, tr in res.trajectories.items()}
            return True, [agents[a] for a in sorted(res.trajectories)], paths, nodes, -1
    in_group = {int(i): fails.get(int(i), 0) for i in group}
    hardest = max(in_group, key=lambda i: in_group[i]) if any(in_group.values()) else -1
    return False, agents, {}, nodes, hardest


def resolve_groups(geom: ArrayGeometry, paths: PathSet, n_steps: int, groups: list[np.ndarray],
                   start: np.ndarray, dest: np.ndarray, movable: np.ndarray, md: float,
                   step_deg: float, settings: SearchResolveSettings,
                   rng: np.random.Generator, memo: dict | None = None) -> SearchOutcome:
    """Re-plan each deadlocked group by prioritized state-time search, keeping targets.

    Parameters
    ----------
    geom : ArrayGeometry
    paths : PathSet, the stepwise run's paths (planning frame: start -> dest)
    n_steps : int, length of that run in steps
    groups : deadlocked groups (robot index arrays), e.g. from ``deadlocked_groups``
    start, dest : (n, 2) deg, every robot's start and destination in the planning frame
    movable : (n,) bool, False for offline robots
    md : float, step-rule margin MD, mm; step_deg : float, planner step, deg
    settings : SearchResolveSettings; rng : numpy Generator
    memo : dict or None, kept by the caller across planning rounds: a group whose
        robots and surroundings (the paths, up to their last motion, of the robots it
        re-planned and of their Eq. 4 neighbours) are the same as in an earlier round
        gets that round's result again without a search (after a target replacement
        the greedy planner re-plans everything, mostly to the same paths)

    Returns
    -------
    SearchOutcome. Groups are processed one after the other; a resolved group's new
    paths are moving obstacles for the groups after it. A group that fails keeps its
    stepwise paths (still deadlocked). Non-deadlocked neighbours that block a robot may
    be re-planned too (recruited, ``settings.max_recruits``).
    """
    clock = time.perf_counter()
    paths = PathSet(list(paths.steps), list(paths.angles))
    world = AlphaBetaWorld(geom, paths, movable, md, step_deg)
    deadlocked = np.zeros(geom.n_robots, dtype=bool)
    for g in groups:
        deadlocked[g] = True
    out = SearchOutcome(paths, int(n_steps))
    out.trimmed = trim_tails(geom, paths, dest, deadlocked | ~np.asarray(movable, bool), md)
    def context(robots) -> dict[int, bytes]:
        near = set(int(i) for i in robots)
        for i in robots:
            near.update(int(j) for j in world.neighbours(int(i)))
        return {j: paths.signature(j) for j in near}

    for group in groups:
        t0 = time.perf_counter()
        key = tuple(sorted(int(i) for i in group))
        hit = None
        for entry in (memo or {}).get(key, []):
            if all(paths.signature(j) == sig for j, sig in entry[0].items()):
                hit = entry
                break
        if hit is not None:
            _, ok, members, new_paths, tried, hardest = hit
        else:
            ok, members, new_paths, tried, hardest = search_group(
                world, group, start, dest, movable, deadlocked, settings, rng)
            if memo is not None:
                ctx = context(members if ok else group)
                memo.setdefault(key, []).append((ctx, ok, members, new_paths, tried, hardest))
        if ok:
            for i, (st, an) in new_paths.items():
                paths.steps[i] = np.asarray(st, dtype=np.float64)
                paths.angles[i] = np.asarray(an, dtype=np.float64)
                out.n_steps = max(out.n_steps, int(math.ceil(float(st[-1]))))
        out.groups.append(GroupResult(np.asarray(group), np.asarray(members), ok, tried,
                                      time.perf_counter() - t0, int(hardest)))
    # the plan ends with its last motion (the run it came from may have gone on longer)
    last = max((paths.motion_end(i) for i in range(geom.n_robots)), default=0.0)
    out.n_steps = max(1, int(math.ceil(last)))
    out.seconds = time.perf_counter() - clock
    return out
