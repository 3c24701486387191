"""Prioritized planning of probe arms: Sabater et al. 2018, Algorithm 1 with Algorithm 2.

Arms are ordered by priority (Sect. 7: the longest estimated travel time of the direct
route first, Eq. 5) and planned one at a time; each arm searches its roadmap
(:func:`rfp_twin.planners.roadmap.build_roadmap`: an 8 x 6 grid with random extra edges)
in state-time with the depth-first search of :func:`rfp_twin.planners.roadmap.plan_arm`,
against the trajectories of the arms planned before it (the obstacle-time set,
:class:`~rfp_twin.planners.roadmap.probe.world.ObstacleTime`). An arm that arrives before the arms
above it stays clear at its goal until the last of them has arrived (goal conflicts,
Sect. 6.4.2). Unplanned arms are not obstacles (Algorithm 1): each pair is checked when
its lower arm is planned.

Units: deg, mm, s. Randomness: a ``numpy.random.Generator`` (roadmap edges, ties).
"""
from __future__ import annotations

import math
import string
import time
from dataclasses import replace

import numpy as np

from rfp_twin.models.errors import TargetError
from rfp_twin.models.kinds import MIRADAS_PROBE, require_kind
from rfp_twin.models.kinds.probe_kinematics import edges_forbidden
from rfp_twin.planners.roadmap.probe.report import ArmRow, ProbePlan
from rfp_twin.planners.roadmap.probe.retreat import retreat_poses
from rfp_twin.planners.roadmap.probe.settings import ProbePlanSettings
from rfp_twin.planners.roadmap.probe.world import ObstacleTime, pose_gaps
from rfp_twin.planners.roadmap import Arm, RoadmapSettings, build_roadmap, edge_time, plan_arm

#: Robot kinds this planner supports.
SUPPORTED_KINDS = (MIRADAS_PROBE,)


def roadmap_settings(s: ProbePlanSettings) -> RoadmapSettings:
    """The generic roadmap planner's settings for :class:`ProbePlanSettings` (deg, s)."""
    return RoadmapSettings(dt=s.dt_s, dt_col=s.dt_col_s, n_stop=s.max_start_stop,
                           grid=tuple(int(g) for g in s.grid), n_random_edges=s.n_random_edges,
                           max_path_time=s.max_path_time_s, t_max=s.horizon_s, search="dfs",
                           resume_edges=False)


def travel_times(kind, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """(n,) estimated travel time of each arm's direct route (Sabater 2018 Eq. 5), s."""
    return np.max(np.abs(goal - start) / kind.max_speed_deg_s()[None, :], axis=1)


def priority_order(kind, start: np.ndarray, goal: np.ndarray, policy: str,
                   rng: np.random.Generator) -> list[int]:
    """Arm indices, highest priority first: longest estimated travel first (ties by
    index) for ``"travel-time"``, the same after the arms that do not move for
    ``"still-first"``, a random permutation for ``"random"``."""
    if policy == "random":
        return [int(i) for i in rng.permutation(len(start))]
    est = travel_times(kind, start, goal)
    if policy == "still-first":
        return sorted(range(len(start)), key=lambda i: (est[i] > 0, -round(float(est[i]), 9), i))
    return sorted(range(len(start)), key=lambda i: (-round(float(est[i]), 9), i))


def check_clear(kind, q: np.ndarray, what: str) -> None:
    """Raise :class:`TargetError` naming the first two arms that touch at poses ``q``."""
    gaps = pose_gaps(np.ascontiguousarray(q, dtype=np.float64), kind.links, kind.sizes,
                     kind.frames(), 2.0 * kind.spec.buffer_mm)
    a, b = np.unravel_index(int(np.argmin(gaps)), gaps.shape)
    if gaps[a, b] <= 0.0:
        raise TargetError(f"arms {min(a, b)} and {max(a, b)}: {what} poses touch (gap "
                          f"{gaps[a, b]:.2f} mm with buffers); allowed: {what} poses clear of "
                          "each other by the safety buffer")


def plan_probe_arms(kind, start: np.ndarray, goal: np.ndarray,
                    settings: ProbePlanSettings | None = None,
                    rng: np.random.Generator | None = None) -> ProbePlan:
    """Plan every arm from ``start`` to ``goal`` ((n_arms, 2) deg) by prioritized planning.

    Parameters
    ----------
    kind : ProbeArmKind (any other kind raises KindError)
    start, goal : (n_arms, 2) float64, (theta1, theta2) deg, mutually clear each
    settings : ProbePlanSettings (the paper's by default)
    rng : numpy Generator (default: seed 0)

    Returns
    -------
    ProbePlan: per-arm rows (Tables 1-2) of the last pass and, when every arm got one,
    trajectories. With ``settings.replans`` > 0 a failed pass is followed by another with
    the arm that failed first in the order (Sect. 2.1), at most that many times (fewer
    when an order comes back); then, for each make-way window of
    ``settings.windows_s``, the same passes with that window given to the arms that found
    no trajectory in an earlier pass (:func:`_one_pass`); with
    ``settings.search_nodes`` > 0, what they leave unsolved goes to a search over the
    priorities (:func:`rfp_twin.planners.roadmap.probe.search.search_priorities`).
    """
    require_kind(kind.name, SUPPORTED_KINDS, "the probe-arm prioritized planner")
    s = settings or ProbePlanSettings()
    rng = rng if rng is not None else np.random.default_rng(0)
    start = np.asarray(start, dtype=np.float64)
    goal = np.asarray(goal, dtype=np.float64)
    kind.check_poses(start, "start")
    kind.check_poses(goal, "target")
    check_clear(kind, start, "start")
    check_clear(kind, goal, "target")
    clock = time.perf_counter()
    first = priority_order(kind, start, goal, s.priority, rng)
    passes, checks, stuck = 0, 0, set()
    for window in (0.0, *s.windows_s):
        order, tried = first, set()
        for again in range(s.replans + 1):
            if again:
                # Sect. 2.1: plan again with another priority order; the arm that found
                # no trajectory goes first (an order tried before ends this window's passes)
                order = [plan.failed_arm] + [a for a in order if a != plan.failed_arm]
                if tuple(order) in tried:
                    break
            tried.add(tuple(order))
            plan = _one_pass(kind, start, goal, s, order, rng, window, retreats=passes > 0,
                             window_arms=stuck)
            passes += 1
            checks += plan.checks
            if not plan.success:
                stuck.add(plan.failed_arm)
            if plan.success:
                break
        if plan.success:
            break
    if not plan.success and s.search_nodes:
        # what prioritized passes cannot solve: search the priorities themselves
        from rfp_twin.planners.roadmap.probe.search import search_priorities

        found = search_priorities(kind, start, goal, s, rng, s.search_nodes, roadmap_settings(s),
                                  travel_times(kind, start, goal))
        passes += 1
        checks += found.checks
        if found.success:
            plan = found
    plan.passes, plan.all_checks, plan.seconds = passes, checks, time.perf_counter() - clock
    return plan


def _one_pass(kind, start: np.ndarray, goal: np.ndarray, s: ProbePlanSettings, order: list[int],
              rng: np.random.Generator, window_s: float = 0.0,
              retreats: bool = False, window_arms: set | None = None) -> ProbePlan:
    """Algorithm 1 once, in priority ``order``.

    With ``window_s`` > 0, every arm not yet planned (of ``window_arms``, default all) is
    also an obstacle at its start pose for the first ``window_s`` s (make-way window): an
    arm planned earlier waits for it to leave instead of sweeping through it at once, and
    that arm, planned later against the earlier ones, must then leave its start within
    the window. With
    ``retreats`` every roadmap also gets the retreat and stop-over vertices of
    ``s.retreat_deg`` (:func:`~rfp_twin.planners.roadmap.probe.retreat.retreat_poses`)."""
    clock = time.perf_counter()
    rs = roadmap_settings(s)
    est = travel_times(kind, start, goal)
    horizon = s.horizon_s + s.dt_s
    planned = ObstacleTime(kind, s.dt_col_s, horizon)
    vmax = kind.max_speed_deg_s()
    limits = kind.joint_limits_deg()
    step = vmax * s.dt_col_s
    trajectories, rows = {}, []
    letters = iter(string.ascii_uppercase * 4)
    t_end_above = 0.0
    for rank, i in enumerate(order):
        arm_clock = time.perf_counter()
        counter = {"checks": 0}
        world = planned
        below = [j for j in order[rank + 1:] if window_arms is None or j in window_arms] \
            if window_s > 0.0 else []
        if below:
            world = ObstacleTime(kind, s.dt_col_s, horizon)
            world.obs, world.circ = planned.obs, planned.circ
            world.members = list(planned.members)
            for j in below:
                world.add_until(j, start[j], window_s)

        def collides(q, t, i=i, counter=counter, world=world):
            if world.members:
                counter["checks"] += len(t)
            return world.collides(i, q, t)

        t_fixed = max(t_end_above, window_s if below else 0.0)
        arm = Arm(start=start[i], goal=goal[i], vmax=vmax, forbidden=kind.forbidden,
                  collides=collides, lower=limits[:, 0], upper=limits[:, 1], t_start=0.0,
                  hold_until=t_fixed, t_static=t_fixed,
                  extra_vertices=retreat_poses(kind, start[i], goal[i],
                                               s.retreat_deg if retreats else ()),
                  edges_forbidden=lambda q0, q1, st: edges_forbidden(
                      np.ascontiguousarray(q0), np.ascontiguousarray(q1), st, kind.links,
                      kind.limits))
        roadmap = _roadmap(arm, rs, rng, s, kind, step)
        usable = _usable_paths(roadmap, kind, step, s)
        traj, _ = plan_arm(arm, rs, rng, roadmap=roadmap)
        steps_usable = [_path_steps(p, vmax, s.dt_s) for p in usable]
        row = ArmRow(arm=i, priority=len(order) - rank, est_travel_s=float(est[i]),
                     optimum_steps=_path_steps(np.stack([start[i], goal[i]]), vmax, s.dt_s),
                     roadmap_routes=len(roadmap.paths), roadmap_paths=len(usable),
                     roadmap_min_steps=min(steps_usable) if steps_usable else 0,
                     roadmap_mean_steps=float(np.mean(steps_usable)) if steps_usable else 0.0,
                     checks=counter["checks"], seconds=time.perf_counter() - arm_clock)
        if traj is None:
            rows.append(row)
            return ProbePlan(kind, start, goal, s, order, rows, trajectories, False, i,
                             time.perf_counter() - clock)
        n_mid = len(traj.path) - 2
        row.path = "-".join(["Start", *(next(letters) for _ in range(n_mid)), "end"])
        row.steps = int(round(traj.t_end / s.dt_s))
        row.n_go, row.n_stop = traj.n_go, traj.n_stop_steps
        row.start_stop = traj.n_start_stop
        rows.append(row)
        trajectories[i] = traj
        planned.add(i, traj.times, traj.configs)
        t_end_above = max(t_end_above, traj.t_end)
    return ProbePlan(kind, start, goal, s, order, rows, trajectories, True, None,
                     time.perf_counter() - clock)


def _roadmap(arm: Arm, rs: RoadmapSettings, rng: np.random.Generator, s: ProbePlanSettings,
             kind, step: np.ndarray):
    """The arm's roadmap with at least ``s.min_routes`` routes: Sect. 6.1's grid, its
    disjoint random edges, and, if those leave fewer routes (some random pairs cross the
    ZoA), further disjoint pairs of grid vertices drawn the same way (each gives the
    routes ``start -> v_i -> v_j -> goal`` and back)."""
    roadmap = build_roadmap(arm, rs, rng)
    short = s.min_routes - len(roadmap.paths)
    if short <= 0 or len(roadmap.vertices) < 2:
        return roadmap
    verts = roadmap.vertices
    pairs: list[np.ndarray] = []
    for _ in range(8):                      # fresh permutations, enough pairs for any draw
        perm = rng.permutation(len(verts))
        cand = np.stack([verts[perm[0:-1:2]], verts[perm[1::2]]], axis=1)   # (k, 2, 2)
        hit, _ = edges_forbidden(np.ascontiguousarray(cand[:, 0]), np.ascontiguousarray(cand[:, 1]),
                                 step, kind.links, kind.limits)
        pairs.extend(cand[~hit])
        if 2 * len(pairs) >= s.min_routes:
            break
    for n_extra in range((short + 1) // 2, len(pairs) + 1):
        extra = pairs[:n_extra]
        with_extra = replace(arm, via=lambda q0, q1, extra=extra: [m for p in extra
                                                                   for m in (p, p[::-1])])
        rebuilt = build_roadmap(with_extra, rs, rng)
        if len(rebuilt.paths) >= s.min_routes:
            break
    return rebuilt


def _path_steps(path: np.ndarray, vmax: np.ndarray, dt: float) -> int:
    """Steps of ``dt`` a path takes at full speed, each edge rounded up (Sect. 6.4.1)."""
    return int(sum(max(1, math.ceil(edge_time(path[k], path[k + 1], vmax) / dt - 1e-9))
                   for k in range(len(path) - 1)))


def _usable_paths(roadmap, kind, step: np.ndarray, s: ProbePlanSettings) -> list:
    """The roadmap's routes kept by Sect. 8: estimated travel time within
    ``max_path_time_s`` and every edge outside the ZoA."""
    out = []
    for path, est in zip(roadmap.paths, roadmap.est_times):
        if est > s.max_path_time_s:
            break
        hit, _ = edges_forbidden(np.ascontiguousarray(path[:-1]), np.ascontiguousarray(path[1:]),
                                 step, kind.links, kind.limits)
        if not hit.any():
            out.append(path)
    return out
