"""The numba TOPP-RA kernel: the time-optimal ``x = sd^2`` of one path on a grid.

Problem (every joint ``k`` of the group's path ``q(s)``, ``s`` in plan steps)::

    |q'_k(s) sd| <= v_k,      |q'_k(s) sdd + q''_k(s) sd^2| <= a_k

with ``sd = ds/dt``, ``sdd = d2s/dt2``, starting and ending at rest.

TOPP-RA (Pham & Pham 2018, the algorithm of the ``toppra`` library) on gridpoints
``s_0 < ... < s_N`` with ``x = sd^2`` and a constant ``u = sdd`` on each interval, so
``x`` is linear in ``s`` there. A backward pass computes the controllable sets
``[0, X_i]`` (largest ``x_i`` from which the end can still be reached at rest), a
forward pass takes the largest admissible ``u`` at every gridpoint.

The gridpoints include every knot of the group's smoothed paths
(:func:`rfp_twin.planners.postprocess.timing.group_grid`). With the running-average smoothing ``q''`` is then
constant on each interval and ``q'`` linear, and the joint acceleration ``q' u + q'' x``
is *linear* in ``s`` on the interval: constraining it at both ends of the interval (the
"interpolation" discretisation) bounds it everywhere. The velocity ``|q' sd|`` is
bounded on the interval by ``max|q'| * sqrt(max x)`` over its two ends, so ``x_i`` is
limited with the largest ``|q'|`` of the adjacent gridpoints. The continuous ``s(t)``
therefore respects both limits exactly (up to rounding; the callers apply the limits
with a factor ``limit_margin``).

:func:`topp_kernel` solves it (about 0.3 ms per group of an SDSS-V fold),
:func:`topp` wraps it into a :class:`rfp_twin.planners.postprocess.timing.TimeLaw`, and :func:`law_excess`
measures how far any ``x`` (e.g. the ``toppra`` library's) exceeds the same
constraints.

Arrays: ``delta`` (N,) interval lengths, steps; ``qd`` (N+1, J) ``q'`` at the
gridpoints, deg/step; ``qdd`` (N, J) ``q''`` on each interval, deg/step^2; ``vmax``,
``amax`` (J,) deg/s and deg/s^2.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rfp_twin.models.kernel_cache import DELIVERY, warm_up
from rfp_twin.planners.postprocess.timing.law import TimeLaw, law_times

__all__ = ["SD_CAP", "QD_EPS", "topp_kernel", "topp", "law_excess"]

#: Cap on sd (plan steps / s) where no joint of a group moves; such stretches then take
#: a negligible time.
SD_CAP = 1.0e5
#: Joint path speeds |q'| below this (deg/step) count as zero.
QD_EPS = 1e-12


@njit(cache=True)
def _x_direct(i, delta, qd, qdd, amax, V):
    """Upper bound on x_i from constraints whose u-coefficient vanishes: |q'' x| <= a."""
    xm = V
    J = qd.shape[1]
    d2 = 2.0 * delta[i]
    for k in range(J):
        b = abs(qdd[i, k])
        if b > 0.0 and (abs(qd[i, k]) <= QD_EPS or abs(qd[i + 1, k] + d2 * qdd[i, k]) <= QD_EPS):
            xm = min(xm, amax[k] / b)
    return xm


@njit(cache=True)
def _active(i, x, x_next, delta, qd, qdd, amax):
    """Largest lower and smallest upper bound on u at x, with their slopes d/dx.

    Every bound is linear in x; returns (lo, dlo, hi, dhi). Constraints with a vanishing
    u-coefficient are bounds on x alone (see :func:`_x_direct`) and are skipped here.
    """
    d2 = 2.0 * delta[i]
    lo = -x / d2
    dlo = -1.0 / d2
    hi = (x_next - x) / d2
    dhi = -1.0 / d2
    J = qd.shape[1]
    for k in range(J):
        beta = qdd[i, k]
        a = amax[k]
        for side in range(2):
            alpha = qd[i, k] if side == 0 else qd[i + 1, k] + d2 * beta
            if abs(alpha) <= QD_EPS:
                continue
            r = -beta / alpha
            p1 = -a / alpha
            p2 = a / alpha
            if alpha < 0.0:
                p1, p2 = p2, p1
            v1 = p1 + r * x
            v2 = p2 + r * x
            if v1 > lo:
                lo = v1
                dlo = r
            if v2 < hi:
                hi = v2
                dhi = r
    return lo, dlo, hi, dhi


@njit(cache=True)
def _max_x(i, xm, x_next, delta, qd, qdd, amax):
    """Largest x in [0, xm] with an admissible u (the upper end of the controllable set).

    The gap ``hi(x) - lo(x)`` is concave and piecewise linear (min of linear minus max
    of linear) and >= 0 at x = 0, so Newton's method from ``xm`` moves monotonically
    down to its largest root, in a few steps; bisection is the fallback.
    """
    x = xm
    for _ in range(50):
        lo, dlo, hi, dhi = _active(i, x, x_next, delta, qd, qdd, amax)
        gap = hi - lo
        if gap >= 0.0:
            return x
        slope = dhi - dlo
        if slope >= 0.0:
            break
        xn = x - gap / slope
        if not (xn < x):
            break
        x = max(xn, 0.0)
        if x == 0.0:
            return 0.0
    # fallback (rounding at a kink): bisection between 0 (admissible) and x
    a = 0.0
    b = x
    for _ in range(80):
        mid = 0.5 * (a + b)
        lo, _, hi, _ = _active(i, mid, x_next, delta, qd, qdd, amax)
        if hi >= lo:
            a = mid
        else:
            b = mid
        if b - a <= 1e-13 * xm:
            break
    return a


@njit(cache=True)
def topp_kernel(delta, qd, qdd, vmax, amax, sd_cap):
    """TOPP-RA on N intervals with per-joint box limits; start and end at rest.

    Parameters
    ----------
    delta : (N,) interval lengths, steps (> 0)
    qd : (N+1, J) q' at the gridpoints, deg/step
    qdd : (N, J) q'' on each interval (constant), deg/step^2
    vmax, amax : (J,) limits, deg/s and deg/s^2
    sd_cap : upper bound on sd where no joint moves, steps/s

    Returns
    -------
    x : (N+1,) sd^2 ; u : (N,) sdd ; X : (N+1,) controllable upper bounds
    """
    N = delta.size
    J = qd.shape[1]
    V = np.empty(N + 1)
    for i in range(N + 1):
        best = sd_cap * sd_cap
        for k in range(J):
            m = qd[i, k] * qd[i, k]
            if i > 0:
                m = max(m, qd[i - 1, k] * qd[i - 1, k])
            if i < N:
                m = max(m, qd[i + 1, k] * qd[i + 1, k])
            if m > QD_EPS * QD_EPS:
                best = min(best, vmax[k] * vmax[k] / m)
        V[i] = best
    X = np.zeros(N + 1)
    X[N] = 0.0
    for i in range(N - 1, -1, -1):
        xm = _x_direct(i, delta, qd, qdd, amax, V[i])
        X[i] = _max_x(i, xm, X[i + 1], delta, qd, qdd, amax)
    x = np.zeros(N + 1)
    u = np.zeros(N)
    for i in range(N):
        lo, _, hi, _ = _active(i, x[i], X[i + 1], delta, qd, qdd, amax)
        ui = hi if hi >= lo else lo
        xn = x[i] + 2.0 * delta[i] * ui
        if xn > X[i + 1]:
            xn = X[i + 1]
        if xn < 0.0:
            xn = 0.0
        u[i] = (xn - x[i]) / (2.0 * delta[i])
        x[i + 1] = xn
    return x, u, X


def topp(grid, qd, qdd, vmax, amax, *, sd_cap: float = SD_CAP) -> TimeLaw:
    """Time-optimal law on ``grid`` for path derivatives ``qd`` (N+1, J), ``qdd`` (N, J)."""
    grid = np.ascontiguousarray(grid, dtype=np.float64)
    if grid.size < 2:
        return TimeLaw.static(float(grid[0]) if grid.size else 0.0)
    delta = np.diff(grid)
    x, u, _ = topp_kernel(delta, np.ascontiguousarray(qd, dtype=np.float64),
                          np.ascontiguousarray(qdd, dtype=np.float64),
                          np.ascontiguousarray(vmax, dtype=np.float64),
                          np.ascontiguousarray(amax, dtype=np.float64), float(sd_cap))
    t = law_times(grid, x)
    return TimeLaw(grid, np.sqrt(np.maximum(x, 0.0)), u, t)


@njit(cache=True)
def law_excess(delta, qd, qdd, vmax, amax, x, sd_cap):
    """How far ``x`` (N+1,) exceeds the discretised constraints: (r_v, r_a) >= 0.

    ``r_v``: largest ``sqrt(x_i) max|q'_k| / v_k`` (the kernel's velocity bound, ``q'``
    over gridpoints ``i - 1 .. i + 1``) and ``sqrt(x_i) / sd_cap``; ``r_a``: largest
    ``|q'_k u_i + q''_k x| / a_k`` at both ends of every interval, ``u_i = (x_{i+1} -
    x_i) / (2 delta_i)``. Values <= 1 satisfy the constraints. Arrays as
    :func:`topp_kernel`.
    """
    N = delta.size
    J = qd.shape[1]
    rv = 0.0
    ra = 0.0
    for i in range(N + 1):
        xi = max(x[i], 0.0)
        rv = max(rv, math.sqrt(xi) / sd_cap)
        for k in range(J):
            m = abs(qd[i, k])
            if i > 0:
                m = max(m, abs(qd[i - 1, k]))
            if i < N:
                m = max(m, abs(qd[i + 1, k]))
            if m > QD_EPS:
                rv = max(rv, math.sqrt(xi) * m / vmax[k])
    for i in range(N):
        u = (x[i + 1] - x[i]) / (2.0 * delta[i])
        for k in range(J):
            a0 = abs(qd[i, k] * u + qdd[i, k] * x[i]) / amax[k]
            a1 = abs(qd[i + 1, k] * u + qdd[i, k] * x[i + 1]) / amax[k]
            ra = max(ra, a0, a1)
    return rv, ra


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, topp_kernel)
