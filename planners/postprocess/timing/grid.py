"""The path-parameter grid of one group: its knots, fine where it curves, coarse on cruises.

Every knot of the group's smoothed paths is a gridpoint, so ``q''`` is constant between
gridpoints and the kernel's interval constraints are exact
(:mod:`rfp_twin.planners.postprocess.timing.kernel`). Intervals where a joint curves are cut at
``grid_steps`` (4 plan steps by default). Straight intervals, where every joint moves
linearly, are cut coarsely: fine only in the *ramp zones* near their ends, where the
time-optimal law can accelerate or brake, and at :data:`STRAIGHT_STEPS` in between
(:func:`group_grid`): 2.8-2.9x fewer gridpoints on SDSS-V plans at the same fold time.

Units: plan steps; limits in deg/s, deg/s^2, steps/s. Grids are (N+1,) increasing
float64 arrays of ``s``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.kernel_cache import DELIVERY, warm_up
from rfp_twin.planners.postprocess.smoothing import SmoothPath, eval_robot
from rfp_twin.planners.postprocess.timing.kernel import QD_EPS

__all__ = ["STRAIGHT_STEPS", "group_grid", "knot_grid"]

#: Longest grid interval where every joint of a group moves linearly (cruise, or no
#: joint moving), plan steps (:func:`group_grid`).
STRAIGHT_STEPS = 128.0
#: Parts per ramp zone of a straight interval (:func:`group_grid`).
_RAMP_PARTS = 16.0


def group_grid(path: SmoothPath, robots: np.ndarray, grid_steps: float,
               moving_range: np.ndarray | None = None, span=(None, None),
               straight_steps: float | None = None, limits=None) -> np.ndarray:
    """Gridpoints of a group: its knots over the span where it moves, subdivided.

    Every knot of every robot of the group inside the moving span is a gridpoint (so
    ``q''`` is constant between gridpoints). An interval where some joint of the group
    curves (``q'' != 0``) is cut into equal parts no longer than ``grid_steps``.

    An interval where every joint moves linearly is cut more coarsely if ``limits`` are
    given: there the joints' constraints are constant, ``|u| <= U = min a_k / |q'_k|``
    and ``x <= X = min(sd_cap^2, v_k^2 / q'_k^2)``, so the time-optimal law accelerates
    at a constant ``u`` (``x`` linear in ``s``, exact on any grid), cruises at ``X`` and
    brakes, and its corners lie within ``D = X / (2 U)`` of the interval's ends (the
    distance in which it reaches its cruise from rest). Those two zones are cut into
    parts no longer than ``clip(D / 16, grid_steps, straight_steps)``, the cruise
    between them into parts no longer than ``straight_steps`` [default
    :data:`STRAIGHT_STEPS`]; an interval where no joint moves into parts no longer than
    ``straight_steps``. That keeps the ramps' corners on a fine grid (a law within a
    few 1e-4 of the fine grid's duration) with a few times fewer gridpoints.

    Parameters
    ----------
    path : SmoothPath
    robots : (k,) robot indices
    grid_steps, straight_steps : plan steps (``straight_steps`` at least ``grid_steps``)
    moving_range : ``path.moving_range()``, if already computed
    span : (lo, hi): extend the grid down to ``lo`` / up to ``hi`` (None: the moving
        span's end)
    limits : None (every interval cut at ``grid_steps``), or (vmax (2k,), amax (2k,),
        sd_cap): the joint limits (deg/s, deg/s^2) and the cap on sd (steps/s)

    Returns
    -------
    (N+1,) increasing s, plan steps; one point if nothing moves.
    """
    rng = (path.moving_range() if moving_range is None else moving_range)[robots]
    moving = rng[:, 1] > rng[:, 0]
    if not moving.any():
        return np.array([0.0])
    s_a = float(rng[moving, 0].min())
    s_b = float(rng[moving, 1].max())
    if span[0] is not None:
        s_a = min(s_a, float(span[0]))
    if span[1] is not None:
        s_b = max(s_b, float(span[1]))
    straight = STRAIGHT_STEPS if straight_steps is None else max(float(straight_steps), grid_steps)
    zoned = limits is not None and straight > grid_steps
    none = np.zeros(2 * robots.size)
    vmax, amax, sd_cap = limits if zoned else (none, none, 0.0)
    return knot_grid(path.ptr, path.knots, path.coef, np.ascontiguousarray(robots, dtype=np.int64),
                     s_a, s_b, float(grid_steps), float(straight), zoned,
                     np.asarray(vmax, dtype=np.float64), np.asarray(amax, dtype=np.float64),
                     float(sd_cap))


@njit(cache=True, nogil=True)
def knot_grid(ptr, knots, coef, robots, s_a, s_b, grid_steps, straight, zoned, vmax, amax,
              sd_cap):
    """The grid of :func:`group_grid` once its span [s_a, s_b] is known: the knots of the
    ``robots`` (k,) of the smoothed path (CSR ``ptr``, ``knots``, ``coef``) in the span,
    cut by :func:`_subdivide`; with ``zoned``, straight intervals by their ramp zones
    (``vmax``, ``amax`` (2k,), ``sd_cap`` as ``limits``), else every one at ``grid_steps``."""
    m = 2
    for r in range(robots.size):
        m += ptr[robots[r] + 1] - ptr[robots[r]]
    cand = np.empty(m)
    m = 0
    for r in range(robots.size):
        for j in range(ptr[robots[r]], ptr[robots[r] + 1]):
            v = knots[j]
            if v >= s_a and v <= s_b:
                cand[m] = v
                m += 1
    cand[m] = s_a
    cand[m + 1] = s_b
    k = np.unique(cand[:m + 2])
    keep = np.empty(k.size, dtype=np.bool_)
    keep[0] = True
    for j in range(1, k.size):
        keep[j] = (k[j] - k[j - 1]) > 1e-9
    k = k[keep]
    k[-1] = s_b
    if k.size < 2:
        out = np.empty(2)
        out[0] = s_a
        out[1] = s_b
        return out
    n = k.size - 1
    if not zoned:
        return _subdivide(k, np.ones(n, dtype=np.bool_), np.zeros(n), grid_steps, straight)
    curved = np.zeros(n, dtype=np.bool_)
    qd = np.empty((n, 2 * robots.size))
    buf = np.empty(2)
    for j in range(n):
        mid = 0.5 * (k[j + 1] + k[j])
        for r in range(robots.size):
            eval_robot(ptr, knots, coef, robots[r], mid, 2, buf)
            if buf[0] != 0.0 or buf[1] != 0.0:
                curved[j] = True
            eval_robot(ptr, knots, coef, robots[r], mid, 1, buf)
            qd[j, 2 * r] = abs(buf[0])
            qd[j, 2 * r + 1] = abs(buf[1])
    return _subdivide(k, curved, _ramp_zone(qd, vmax, amax, sd_cap), grid_steps, straight)


@njit(cache=True)
def _ramp_zone(qd, vmax, amax, sd_cap):
    """Per interval (rows of |q'| (M, J), joints moving linearly): D = X / (2 U), steps."""
    M, J = qd.shape
    out = np.zeros(M)
    for i in range(M):
        X = sd_cap * sd_cap
        U = np.inf
        for k in range(J):
            q = qd[i, k]
            if q > QD_EPS:
                X = min(X, vmax[k] * vmax[k] / (q * q))
                U = min(U, amax[k] / q)
        out[i] = X / (2.0 * U) if U < np.inf else 0.0
    return out


@njit(cache=True)
def _subdivide(k, curved, zone, grid_steps, straight_steps):
    """Cut knot intervals: curved ones at ``grid_steps``, straight ones by ramp zones."""
    n = k.size - 1
    out = np.empty(1 + 8 * n + int(np.sum(np.ceil(np.diff(k) / grid_steps))))
    out[0] = k[0]
    m = 1
    for i in range(n):
        a = k[i]
        b = k[i + 1]
        L = b - a
        if curved[i]:
            cuts = (a, b, b, b)
            steps = (grid_steps, 1.0, 1.0, 1.0)
        else:
            D = zone[i]
            h = min(max(D / _RAMP_PARTS, grid_steps), straight_steps)
            if D <= 0.0:
                cuts = (a, b, b, b)
                steps = (straight_steps, 1.0, 1.0, 1.0)
            elif 2.0 * D >= L:
                cuts = (a, b, b, b)
                steps = (h, 1.0, 1.0, 1.0)
            else:
                cuts = (a, a + D, b - D, b)
                steps = (h, straight_steps, h, 1.0)
        for z in range(3):
            lo = cuts[z]
            hi = cuts[z + 1]
            if hi <= lo:
                continue
            parts = max(1, int(math.ceil((hi - lo) / steps[z])))
            for p in range(1, parts + 1):
                out[m] = lo + (hi - lo) * p / parts
                m += 1
        out[m - 1] = b
    return out[:m]


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, knot_grid)
