"""Probe arms planned by a search over priorities, for what one priority order cannot solve.

Sabater et al. 2018 plan with one priority order and, on failure, try others (Sect.
2.1). :func:`search_priorities` searches the orders themselves: priority-based search
(Ma et al., AAAI 2019) with Sabater's single-arm planner,
:func:`rfp_twin.planners.roadmap.priority_search`, which is kind-agnostic; here it is given
the probe arms' obstacle-time sets (each arm against the arms above it in a partial
order) and a pairwise conflict test of two planned arms on the ``dt_col`` clock. Units:
deg, mm, s.
"""
from __future__ import annotations

import string
import time

import numpy as np

from rfp_twin.models.kinds.probe_kinematics import edges_forbidden
from rfp_twin.planners.roadmap.probe.report import ArmRow, ProbePlan
from rfp_twin.planners.roadmap.probe.retreat import retreat_poses
from rfp_twin.planners.roadmap.probe.settings import ProbePlanSettings
from rfp_twin.planners.roadmap.probe.world import ObstacleTime, trajectories_touch
from rfp_twin.planners.roadmap import Arm, priority_search


def search_priorities(kind, start: np.ndarray, goal: np.ndarray, s: ProbePlanSettings,
                      rng: np.random.Generator, max_nodes: int, roadmap_settings,
                      travel_times: np.ndarray) -> ProbePlan:
    """Plan every arm by priority-based search (at most ``max_nodes`` search-tree nodes).

    Returns a :class:`ProbePlan` whose ``order`` is a topological order of the priorities
    found (rows in that order; ``priority`` n = first); roadmap columns are left 0."""
    clock = time.perf_counter()
    n = kind.n_arms
    horizon = s.horizon_s + s.dt_s
    probe = ObstacleTime(kind, s.dt_col_s, horizon)
    vmax, limits = kind.max_speed_deg_s(), kind.joint_limits_deg()
    cache: dict[tuple[int, int], tuple] = {}
    checks = {i: 0 for i in range(n)}

    def sampled(i: int, tr):
        key = (i, id(tr))
        if key not in cache:
            cache[key] = (tr, probe.sample(i, tr.times, tr.configs))   # tr kept alive
        return cache[key][1]

    def make_arm(i: int, higher: dict, arms) -> Arm:
        world = ObstacleTime(kind, s.dt_col_s, horizon)
        for j, tr in higher.items():
            world.add_sampled(j, *sampled(j, tr))

        def collides(q, t):
            if world.members:
                checks[i] += len(t)
            return world.collides(i, q, t)

        t_static = max((tr.t_end for tr in higher.values()), default=0.0)
        return Arm(start=start[i], goal=goal[i], vmax=vmax, forbidden=kind.forbidden,
                   collides=collides, lower=limits[:, 0], upper=limits[:, 1],
                   t_static=t_static,
                   extra_vertices=retreat_poses(kind, start[i], goal[i], s.retreat_deg),
                   edges_forbidden=lambda q0, q1, st: edges_forbidden(
                       np.ascontiguousarray(q0), np.ascontiguousarray(q1), st, kind.links,
                       kind.limits))

    def conflict(i: int, ti, j: int, tj) -> bool:
        ca, ra = sampled(i, ti)
        cb, rb = sampled(j, tj)
        return bool(trajectories_touch(ca, ra, cb, rb, probe.pad))

    res = priority_search(n, make_arm, conflict, roadmap_settings, rng, max_nodes=max_nodes)
    order = topological_order(n, res.priorities)
    rows, letters = [], iter(string.ascii_uppercase * 4)
    for rank, i in enumerate(order):
        row = ArmRow(arm=i, priority=n - rank, est_travel_s=float(travel_times[i]),
                     optimum_steps=0, roadmap_routes=0, roadmap_paths=0, roadmap_min_steps=0,
                     roadmap_mean_steps=0.0, checks=checks[i], seconds=0.0)
        tr = res.trajectories.get(i)
        if tr is not None:
            row.path = "-".join(["Start", *(next(letters) for _ in range(len(tr.path) - 2)), "end"])
            row.steps = int(round(tr.t_end / s.dt_s))
            row.n_go, row.n_stop, row.start_stop = tr.n_go, tr.n_stop_steps, tr.n_start_stop
        rows.append(row)
    failed = None if res.success else (min(res.failures) if res.failures else order[-1])
    return ProbePlan(kind, start, goal, s, order, rows, dict(res.trajectories), res.success,
                     failed, time.perf_counter() - clock)


def topological_order(n: int, pairs: set) -> list[int]:
    """Arms 0..n-1 ordered so that each (higher, lower) pair has higher first (ties by index)."""
    above = {i: {h for h, lo in pairs if lo == i} for i in range(n)}
    out: list[int] = []
    while len(out) < n:
        ready = [i for i in range(n) if i not in out and above[i] <= set(out)]
        out.append(ready[0] if ready else min(set(range(n)) - set(out)))
    return out
