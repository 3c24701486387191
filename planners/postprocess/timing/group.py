"""Timing one group: its grid, its path derivatives, its backend (:func:`time_group`).

A group of ``k`` robots is one path with ``2k`` joints (alpha, beta of each robot), timed
by one shared ``s(t)`` (:mod:`rfp_twin.planners.postprocess.timing.grouping` says which robots share one).
:func:`time_group` builds the group's grid (:func:`rfp_twin.planners.postprocess.timing.grid.group_grid`),
evaluates ``q'`` at the gridpoints and the constant ``q''`` of each interval, and hands
the discretised problem to the backend chosen by name
(:mod:`rfp_twin.planners.postprocess.timing.backends`); with ``"toppra"``, groups larger than
:data:`TOPPRA_MAX_ROBOTS` and groups the library finds no solution for are timed by the
numba kernel.

Units: plan steps, degrees, seconds.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rfp_twin.models.errors import PlanningError, SpecError, field_error
from rfp_twin.planners.postprocess.smoothing import SmoothPath
from rfp_twin.planners.postprocess.timing.backends import DEFAULT_BACKEND, TimingProblem, get_backend
from rfp_twin.planners.postprocess.timing.backends import numba_kernel
from rfp_twin.planners.postprocess.timing.grid import group_grid
from rfp_twin.planners.postprocess.timing.kernel import SD_CAP
from rfp_twin.planners.postprocess.timing.law import TimeLaw

__all__ = ["LIMIT_MARGIN", "TOPPRA_MAX_ROBOTS", "time_group"]

#: With the toppra backend, groups of more robots than this are timed by the kernel
#: (solver "numba-large"): the library's Python loops grow with the joints, and a crowded
#: Markov plan at 3.5 mm on the 547 grid is one group of 547 robots (1094 joints), 35 s
#: with the library, 1.5 s with the kernel, the same law. SDSS-V groups at 2-2.5 mm have
#: at most ~7 robots.
TOPPRA_MAX_ROBOTS = 32
#: The speed and acceleration limits are applied times this factor (rounding head-room).
LIMIT_MARGIN = 0.999


def time_group(path: SmoothPath, robots, max_speed, max_accel, *, grid_steps: float = 4.0,
               backend: str = DEFAULT_BACKEND, limit_margin: float = LIMIT_MARGIN,
               moving_range: np.ndarray | None = None, span=(None, None),
               sd_cap: float = SD_CAP, straight_steps: float | None = None,
               fallback: bool = True, toppra_max_robots: int | None = TOPPRA_MAX_ROBOTS) -> TimeLaw:
    """Time-optimal shared ``s(t)`` of a group of robots (one path, 2 joints per robot).

    Parameters
    ----------
    path : SmoothPath
    robots : (k,) robot indices of the group
    max_speed, max_accel : (2,) per-axis limits (alpha, beta), deg/s and deg/s^2
    grid_steps : longest interval between gridpoints where a joint curves, plan steps
    backend : one of :data:`rfp_twin.planners.postprocess.timing.BACKENDS`: "toppra" (the library) or
        "numba" (the kernel); both solve the same discretised problem on the same grid
    limit_margin : the limits are applied times this factor (rounding head-room)
    moving_range : ``path.moving_range()``, if already computed (saves time per group)
    span : see :func:`rfp_twin.planners.postprocess.timing.grid.group_grid`
    sd_cap : upper bound on ds/dt where no joint moves, steps/s
    straight_steps : longest interval of a cruise where every joint moves linearly
        [default :data:`rfp_twin.planners.postprocess.timing.grid.STRAIGHT_STEPS`] (see
        :func:`rfp_twin.planners.postprocess.timing.grid.group_grid`)
    fallback : with ``backend="toppra"``, time the group with the kernel when the
        library finds no solution (the law's ``solver`` is then "fallback"); False
        raises :class:`rfp_twin.models.errors.PlanningError` instead
    toppra_max_robots : with ``backend="toppra"``, larger groups are timed by the kernel
        (solver "numba-large"); None = no limit

    Returns
    -------
    TimeLaw, starting and ending at rest (a static law if the group never moves); its
    ``solver`` says which solver computed it.
    """
    solve_law = get_backend(backend)            # SpecError for an unknown name
    if not (np.isfinite(grid_steps) and grid_steps > 0):
        raise field_error(SpecError, "grid_steps", grid_steps, "> 0 steps", "time_group")
    if straight_steps is not None and not (np.isfinite(straight_steps) and straight_steps > 0):
        raise field_error(SpecError, "straight_steps", straight_steps, "> 0 steps", "time_group")
    if not (np.isfinite(sd_cap) and sd_cap > 0):
        raise field_error(SpecError, "sd_cap", sd_cap, "> 0 steps/s", "time_group")
    robots = np.atleast_1d(np.asarray(robots, dtype=np.int64))
    k = robots.size
    vmax = np.tile(np.asarray(max_speed, dtype=np.float64) * limit_margin, k)
    amax = np.tile(np.asarray(max_accel, dtype=np.float64) * limit_margin, k)
    grid = group_grid(path, robots, grid_steps, moving_range, span, straight_steps,
                      limits=(vmax, amax, sd_cap))
    if grid.size < 2:
        return TimeLaw.static(float(grid[0]))
    law = _solve(path, robots, grid, vmax, amax, sd_cap, backend, solve_law, fallback,
                 toppra_max_robots)
    for _ in range(_MAX_REFINE):
        stuck = _stopped_inside(law, path, robots, amax)
        if stuck.size == 0:
            break
        # halve the interval crossed at rest and both of its neighbours
        grid = law.s
        lo = np.maximum(stuck - 1, 0)
        hi = np.minimum(stuck + 2, grid.size - 1)
        edges = np.unique(np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)]))
        grid = np.union1d(grid, 0.5 * (grid[edges] + grid[edges + 1]))
        law = _solve(path, robots, grid, vmax, amax, sd_cap, backend, solve_law, fallback,
                     toppra_max_robots)
    return law


#: Rounds of grid refinement around a law's stops where the path moves.
_MAX_REFINE = 8
#: ds/dt (plan steps/s) below which both ends of an interval count as crawling.
CRAWL_SD = 1.0


def _stopped_inside(law: TimeLaw, path: SmoothPath, robots: np.ndarray,
                    amax: np.ndarray) -> np.ndarray:
    """Intervals (their first gridpoint) crossed far slower than from rest to rest.

    With ``x = sd^2`` linear on each interval, TOPP-RA's greedy forward pass can push a
    gridpoint to the top of its controllable set from which the only admissible next
    value is ``x = 0``; when the gridpoint after that must also be at rest (the end),
    the interval between them is crossed at (nearly) zero speed: in infinite time with
    the kernel, minutes with the library, where a finer grid takes a fraction of a
    second (a robot of a Markov fold that ends its motion on the last interval). An interval
    whose joints move at most ``d`` deg is flagged when it takes more than three times
    ``2 sqrt(d / a)``, the time from rest to rest over it."""
    if law.s.size < 2:
        return np.zeros(0, dtype=np.int64)
    # only intervals crawled at both ends can be such (a real stop has one end at speed)
    crawl = np.flatnonzero(np.maximum(law.sd[:-1], law.sd[1:]) < CRAWL_SD)
    if crawl.size == 0:
        return crawl
    q0 = path.evaluate(law.s[crawl], robots, 0).reshape(crawl.size, -1)
    q1 = path.evaluate(law.s[crawl + 1], robots, 0).reshape(crawl.size, -1)
    d = np.abs(q1 - q0)
    rest_to_rest = 2.0 * np.sqrt(d / amax[None, :]).max(axis=1)
    dt = law.t[crawl + 1] - law.t[crawl]
    return crawl[(dt > 3.0 * rest_to_rest + 1e-6) & (d.max(axis=1) > 1e-9)]


def _solve(path: SmoothPath, robots: np.ndarray, grid: np.ndarray, vmax, amax, sd_cap: float,
           backend: str, solve_law, fallback: bool, toppra_max_robots) -> TimeLaw:
    """The law of the group on ``grid`` by ``backend`` (see :func:`time_group`)."""
    k = robots.size
    qd = np.ascontiguousarray(path.evaluate(grid, robots, 1).reshape(grid.size, 2 * k))
    mid = 0.5 * (grid[1:] + grid[:-1])
    qdd = np.ascontiguousarray(path.evaluate(mid, robots, 2).reshape(mid.size, 2 * k))
    problem = TimingProblem(grid, qd, qdd, vmax, amax, float(sd_cap))
    if backend == "toppra" and toppra_max_robots is not None and k > toppra_max_robots:
        return replace(numba_kernel.solve_law(problem), solver="numba-large")
    law = solve_law(problem)
    if law is not None:
        return law
    if not fallback:
        raise PlanningError(f"{backend}: no parametrisation of the group of robots "
                            f"{robots.tolist()}; allowed: fallback=True or backend='numba'")
    return replace(numba_kernel.solve_law(problem), solver="fallback")
