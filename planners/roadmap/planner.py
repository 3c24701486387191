"""One arm: Sabater et al. 2018, Algorithm 2 (the first roadmap path that gets a trajectory).

:func:`plan_arm` builds the arm's roadmap (:mod:`rfp_twin.planners.roadmap.graph`), tries its
paths cheapest first and searches each in state-time (:mod:`rfp_twin.planners.roadmap.search`,
or :mod:`rfp_twin.planners.roadmap.sweep`). Goal conflicts (Sect. 6.4.2): an arm that parks
before the arms of higher priority have arrived must stay collision-free at its goal
until the last of them arrives (``Arm.hold_until``, :func:`goal_clear_after`). Beyond
the paper, an arm with a ``lead_in`` may follow it first and leave it at one of a few
departure times (latest first). Joint and time units are the caller's.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import replace
from typing import Iterator

import numpy as np

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.planners.roadmap.arm import (Arm, ArmTrajectory, RoadmapSettings, SearchStats,
                                           compress_breakpoints)
from rfp_twin.planners.roadmap.graph import (EdgeFeasibility, Roadmap, build_roadmap,
                                             edge_check_spacing)
from rfp_twin.planners.roadmap.search import PathSearch
from rfp_twin.planners.roadmap.sweep import PathSweep
from rfp_twin.planners.roadmap.sweep_batches import search_batched


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
    feasible = EdgeFeasibility(arm, edge_check_spacing(arm, settings))
    clear_after = goal_clear_after(arm, settings)
    result = None
    for t_dep in departure_times(arm, settings, stats):
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
                    clear_after: float, feasible: EdgeFeasibility) -> ArmTrajectory | None:
    """Algorithm 2's loop: paths cheapest first, the first one that gets a trajectory
    (with a compiled sweep of several paths, in batches on two cores:
    :mod:`rfp_twin.planners.roadmap.sweep_batches`, the same result)."""
    paths = candidate_paths(roadmap, settings, feasible)
    if settings.search == "sweep" and arm.sweep_paths is not None and arm.sweep is not None:
        first = next(paths, None)
        if first is None:
            return None
        probe = PathSweep(arm, first, settings, stats, clear_after)
        if not probe.start_collides():
            return search_batched(probe, paths, stats)
        paths = itertools.chain([first], paths)
    for path in paths:
        stats.paths_tried += 1
        searcher = PathSweep if settings.search == "sweep" else PathSearch
        result = searcher(arm, path, settings, stats, clear_after).run()
        if result is not None:
            return result
        if stats.budget_exhausted:
            break
    return None


def candidate_paths(roadmap: Roadmap, settings: RoadmapSettings,
                feasible: EdgeFeasibility) -> Iterator[np.ndarray]:
    """The roadmap's paths to try, in order: zero-length edges dropped, edges through the
    forbidden zone skipped, at most ``max_paths`` and none slower than ``max_path_time``.
    The edges of the next :data:`EDGE_BLOCK` paths are checked together."""
    def cleaned() -> Iterator[np.ndarray]:
        paths, times = roadmap.paths, roadmap.est_times
        for lo in range(0, len(paths), EDGE_BLOCK):
            block = paths[lo:lo + EDGE_BLOCK]
            # drop zero-length edges (a vertex on the start or goal), a block at a time:
            # a vertex is kept unless it repeats the one before it in its path
            v = np.concatenate(block)
            keep = np.ones(len(v), dtype=bool)
            keep[1:] = ~np.all(np.abs(v[1:] - v[:-1]) <= 1e-8 + 1e-5 * np.abs(v[:-1]), axis=1)
            first = np.cumsum([0] + [len(p) for p in block[:-1]])
            keep[first] = True
            for path, est, at in zip(block, times[lo:lo + EDGE_BLOCK], first):
                if settings.max_path_time is not None and est > settings.max_path_time:
                    return
                path = path[keep[at:at + len(path)]]
                yield path if len(path) >= 2 else np.stack([path[0], path[0]])

    def clear(paths: Iterator[np.ndarray]) -> Iterator[np.ndarray]:
        while block := list(itertools.islice(paths, EDGE_BLOCK)):
            yield from feasible.clear_paths(block)

    return itertools.islice(clear(cleaned()), settings.max_paths)


#: Roadmap paths whose edges :func:`candidate_paths` checks in one call.
EDGE_BLOCK = 64


def _lead_in_at(arm: Arm, t: float) -> np.ndarray:
    times, configs = arm.lead_in
    return np.array([np.interp(t, times, configs[:, k]) for k in range(configs.shape[1])])


def departure_times(arm: Arm, settings: RoadmapSettings, stats: SearchStats) -> list[float]:
    """Times at which the arm may leave its lead-in, latest first ([t_start] without one).

    Candidates lie on the dt grid from ``t_start`` to the end of the lead-in, up to the
    first ``dt_col`` check of the lead-in that collides; at most ``max_departures`` of
    them, evenly spread, always including the first and the last; without
    ``settings.depart_at_start`` the first (``t_start``: leaving the lead-in at once) is
    then dropped, unless it is the only one.
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
    if not settings.depart_at_start and len(grid) > 1:
        grid = grid[1:]                   # t_start, always the first pick
    return [float(t) for t in grid[::-1]]


def _with_lead_in(arm: Arm, t_dep: float, tr: ArmTrajectory) -> ArmTrajectory:
    """The lead-in up to ``t_dep`` followed by the searched trajectory."""
    times, configs = arm.lead_in
    keep = times < t_dep - 1e-12
    t = np.concatenate([times[keep], tr.times])
    q = np.vstack([configs[keep], tr.configs])
    t, q = compress_breakpoints(t, q)
    return replace(tr, times=t, configs=q)
