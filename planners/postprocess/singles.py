"""One-robot groups timed, sampled and simplified in one compiled call, on two threads.

Most groups of a post-processed plan are one robot (492 of 500 on a Markov fold of the
SDSS-V layout at 2.0 mm). :func:`rfp_twin.planners.postprocess.groups.time_and_simplify`
does each in ~15 kernel calls with numpy between them, ~0.7 ms a robot, a quarter of it
Python. :func:`time_singles` does the same arithmetic for many robots in one kernel
(:func:`_time_singles`) that releases the GIL, and splits the robots between two threads:
the same :class:`~rfp_twin.planners.postprocess.groups.TimedGroup` values bit for bit
(the same operations in the same order; a test compares every array).

What the kernel does per robot, as the per-group path does with the ``numba`` backend:
the grid (:func:`rfp_twin.planners.postprocess.timing.grid.knot_grid`, as ``group_grid``: the knots
over the moving span, curved intervals cut at ``grid_steps``, straight ones by their ramp zones), the
TOPP-RA law (:func:`rfp_twin.planners.postprocess.timing.kernel.topp_kernel`, limits times
``limit_margin``), samples every ``sample_s`` seconds clipped to the joint limits, RDP on
both axes (:func:`rfp_twin.planners.postprocess.simplify.simplify_columns`) and the uniform slow-down
that keeps the piecewise-linear result within the limits. A robot the kernel cannot
finish alone is marked and left to the per-group path: one that never moves (a static
law) and one whose law crawls across an interval (the per-group path then refines the
grid, :func:`rfp_twin.planners.postprocess.timing.group._stopped_inside`).

Units: plan steps, degrees, seconds.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.kernel_cache import DELIVERY, warm_up
from rfp_twin.models.second_thread import second_thread
from rfp_twin.planners.postprocess.groups import TimedGroup
from rfp_twin.planners.postprocess.simplify import simplify_columns_kernel
from rfp_twin.planners.postprocess.smoothing import SmoothPath, eval_robot
from rfp_twin.planners.postprocess.timing.grid import STRAIGHT_STEPS, knot_grid
from rfp_twin.planners.postprocess.timing.group import CRAWL_SD, LIMIT_MARGIN
from rfp_twin.planners.postprocess.timing.kernel import SD_CAP, topp_kernel
from rfp_twin.planners.postprocess.timing.kinematics import pl_kinematics
from rfp_twin.planners.postprocess.timing.law import TimeLaw, s_at_times, law_times

__all__ = ["time_singles"]

#: Robots below which one thread does them all (a second thread costs ~0.1 ms).
_SPLIT_ROBOTS = 16
#: Status of a robot in the kernel's output.
_DONE, _LEFT = 0, 1

def _grown(a, need):
    """``a`` or a copy at least twice as long, its first ``len(a)`` rows kept."""
    if need <= a.shape[0]:
        return a
    b = np.empty((max(need, 2 * a.shape[0]),) + a.shape[1:], dtype=a.dtype)
    b[:a.shape[0]] = a
    return b


_grown = njit(cache=True, nogil=True)(_grown)


@njit(cache=True, nogil=True)
def _time_singles(ptr, knots, coef, robots, s_range, vmax, amax, vlim, alim, sd_cap,
                  grid_steps, straight, sample_s, tol, max_points, limits):
    """Time, sample and simplify each robot of ``robots`` (m,) as a one-robot group.

    ``s_range`` (n, 2) moving ranges; ``vmax``, ``amax`` (2,) the limits the law keeps
    (spec times the margin); ``vlim``, ``alim`` (2,) the spec's, for the slow-down;
    ``tol`` (n,) RDP tolerance per robot; ``limits`` (n, 2, 2) joint limits.
    Returns the status (m,) and CSR arrays: law (ptr (m+1,), s, sd, t; ptr (m+1,), sdd),
    samples (ptr (m+1,), t, Y (., 2), keep (., 2)), the tolerances used (m, 2) and the
    slow-down scale (m,)."""
    m = robots.size
    status = np.full(m, _DONE, dtype=np.int64)
    law_ptr = np.zeros(m + 1, dtype=np.int64)
    u_ptr = np.zeros(m + 1, dtype=np.int64)
    smp_ptr = np.zeros(m + 1, dtype=np.int64)
    law_s = np.empty(1024)
    law_sd = np.empty(1024)
    law_t = np.empty(1024)
    law_u = np.empty(1024)
    smp_t = np.empty(1024)
    smp_y = np.empty((1024, 2))
    smp_keep = np.empty((1024, 2), dtype=np.bool_)
    tol_used = np.zeros((m, 2))
    scale = np.ones(m)
    buf = np.empty(2)
    for r in range(m):
        i = robots[r]
        law_ptr[r + 1] = law_ptr[r]
        u_ptr[r + 1] = u_ptr[r]
        smp_ptr[r + 1] = smp_ptr[r]
        s_a = s_range[i, 0]
        s_b = s_range[i, 1]
        if not s_b > s_a:
            status[r] = _LEFT                   # a static law: the per-group path
            continue
        grid = knot_grid(ptr, knots, coef, robots[r:r + 1], s_a, s_b, grid_steps, straight,
                         straight > grid_steps, vmax, amax, sd_cap)
        G = grid.size
        qd = np.empty((G, 2))
        for j in range(G):
            eval_robot(ptr, knots, coef, i, grid[j], 1, buf)
            qd[j, 0] = buf[0]
            qd[j, 1] = buf[1]
        qdd = np.empty((G - 1, 2))
        for j in range(G - 1):
            eval_robot(ptr, knots, coef, i, 0.5 * (grid[j + 1] + grid[j]), 2, buf)
            qdd[j, 0] = buf[0]
            qdd[j, 1] = buf[1]
        delta = np.diff(grid)
        x, u, _ = topp_kernel(delta, qd, qdd, vmax, amax, sd_cap)
        t_law = law_times(grid, x)
        sd = np.sqrt(np.maximum(x, 0.0))
        crawl = False
        for j in range(G - 1):
            if max(sd[j], sd[j + 1]) < CRAWL_SD:
                crawl = True
                break
        T = t_law[G - 1]
        if crawl or not (T > 0.0 and T < np.inf):
            status[r] = _LEFT                   # the per-group path refines the grid
            continue
        n = int(math.floor(T / sample_s))
        last = n * sample_s
        S = n + 2 if T - last > 1e-9 * max(1.0, T) else n + 1
        t = np.empty(S)
        for j in range(n + 1):
            t[j] = j * sample_s
        t[S - 1] = T
        s = np.empty(S)
        s_at_times(grid, sd, u, t_law, t, s)
        Y = np.empty((S, 2))
        for j in range(S):
            eval_robot(ptr, knots, coef, i, s[j], 0, buf)
            for ax in range(2):
                v = buf[ax]
                lo = limits[i, ax, 0]
                hi = limits[i, ax, 1]
                if v < lo:
                    v = lo
                if v > hi:
                    v = hi
                Y[j, ax] = v
        tols = np.empty(2)
        tols[0] = tol[i]
        tols[1] = tol[i]
        keep = np.empty((S, 2), dtype=np.bool_)
        used = np.empty(2)
        simplify_columns_kernel(t, Y, tols, max_points, keep, used)
        ratio = 1.0
        for c in range(2):
            cnt = 0
            for j in range(S):
                if keep[j, c]:
                    cnt += 1
            tk = np.empty(cnt)
            yk = np.empty(cnt)
            q = 0
            for j in range(S):
                if keep[j, c]:
                    tk[q] = t[j]
                    yk[q] = Y[j, c]
                    q += 1
            vm, am = pl_kinematics(tk, yk)
            ratio = max(ratio, vm / vlim[c], math.sqrt(am / alim[c]))
        scale[r] = ratio * (1.0 + 1e-9) if ratio > 1.0 else 1.0
        tol_used[r, 0] = used[0]
        tol_used[r, 1] = used[1]
        a = law_ptr[r]
        law_s = _grown(law_s, a + G)
        law_sd = _grown(law_sd, a + G)
        law_t = _grown(law_t, a + G)
        e = u_ptr[r]
        law_u = _grown(law_u, e + G - 1)
        law_s[a:a + G] = grid
        law_sd[a:a + G] = sd
        law_t[a:a + G] = t_law
        law_u[e:e + G - 1] = u
        law_ptr[r + 1] = a + G
        u_ptr[r + 1] = e + G - 1
        b = smp_ptr[r]
        smp_t = _grown(smp_t, b + S)
        smp_y = _grown(smp_y, b + S)
        smp_keep = _grown(smp_keep, b + S)
        smp_t[b:b + S] = t
        smp_y[b:b + S] = Y
        smp_keep[b:b + S] = keep
        smp_ptr[r + 1] = b + S
    return (status, law_ptr, law_s, law_sd, law_t, u_ptr, law_u, smp_ptr, smp_t, smp_y,
            smp_keep, tol_used, scale)


def _unpack(out, robots: np.ndarray, found: dict) -> None:
    (status, law_ptr, law_s, law_sd, law_t, u_ptr, law_u, smp_ptr, smp_t, smp_y, smp_keep,
     tol_used, scale) = out
    for r in np.flatnonzero(status == _DONE):
        a, b = law_ptr[r], law_ptr[r + 1]
        c, d = smp_ptr[r], smp_ptr[r + 1]
        law = TimeLaw(law_s[a:b], law_sd[a:b], law_u[u_ptr[r]:u_ptr[r + 1]], law_t[a:b])
        found[int(robots[r])] = TimedGroup(robots[r:r + 1], law, float(scale[r]), smp_t[c:d],
                                           smp_y[c:d], smp_keep[c:d], tol_used[r])


def time_singles(path: SmoothPath, robots: np.ndarray, vmax, amax, tol_robot: np.ndarray, *,
                 grid_steps: float, sample_s: float, max_points: int, moving_range: np.ndarray,
                 limits: np.ndarray, limit_margin: float = LIMIT_MARGIN,
                 sd_cap: float = SD_CAP) -> dict[int, TimedGroup]:
    """The :class:`TimedGroup` of each robot of ``robots`` (m,) as a one-robot group, as
    :func:`rfp_twin.planners.postprocess.groups.time_and_simplify` gives it with the
    ``numba`` backend; robots it leaves to that function (static, or a law that crawls
    across an interval) are missing from the returned {robot index: TimedGroup}.

    ``vmax``, ``amax`` (2,) axis limits, deg/s and deg/s^2; ``tol_robot`` (n,) RDP
    tolerance per robot (> 0), deg; ``moving_range`` (n, 2) ``path.moving_range()``;
    ``limits`` (n, 2, 2) joint limits (robot, axis, lo/hi), deg; the other keywords as
    ``time_and_simplify``.
    """
    robots = np.ascontiguousarray(robots, dtype=np.int64)
    tol_robot = np.ascontiguousarray(tol_robot, dtype=np.float64)
    if int(max_points) < 2 or not np.all(np.isfinite(tol_robot[robots]) & (tol_robot[robots] > 0)):
        return {}                       # the per-group path raises the error
    vlim = np.ascontiguousarray(vmax, dtype=np.float64)
    alim = np.ascontiguousarray(amax, dtype=np.float64)
    args = (path.ptr, path.knots, path.coef)
    rest = (np.ascontiguousarray(moving_range, dtype=np.float64), vlim * limit_margin,
            alim * limit_margin, vlim, alim, float(sd_cap), float(grid_steps),
            float(STRAIGHT_STEPS), float(sample_s),
            tol_robot, int(max_points),
            np.ascontiguousarray(limits, dtype=np.float64))
    found: dict[int, TimedGroup] = {}
    if robots.size < _SPLIT_ROBOTS:
        _unpack(_time_singles(*args, robots, *rest), robots, found)
        return found
    half = robots.size // 2
    first, second = robots[:half].copy(), robots[half:].copy()
    other = second_thread().submit(_time_singles, *args, second, *rest)
    _unpack(_time_singles(*args, first, *rest), first, found)
    _unpack(other.result(), second, found)
    return found


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, _time_singles)
