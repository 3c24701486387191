"""Ramer-Douglas-Peucker simplification of (time, angle) paths (Sayres 2021 Sect. 6).

The robot firmware takes at most 1024 (angle, time) points per axis and interpolates
linearly between them. A timed path sampled densely is reduced here to a subset of its
own samples such that linear interpolation between the kept samples stays within an
angular tolerance of every dropped sample.

The deviation is measured *vertically* (angle at the same time), not perpendicular to
the chord as in the textbook RDP: what matters for collisions is where the arm is at a
given instant. The result keeps the first and last samples, and only original samples,
so the kinematic bounds of :func:`rfp_twin.planners.postprocess.timing.pl_kinematics` carry over from the
dense trajectory to the simplified one.

If the tolerance would need more than ``max_points`` points, the tolerance of that axis
is raised by factors of 1.5 until it fits, and the raised value is reported.

:func:`simplify_plan` applies the same reduction to a stepwise plan before smoothing
(both axes of a robot together, deviation at equal plan step): a Markov plan has a
breakpoint nearly every step, one-step wiggles the smoothing window averages away
anyway, and every breakpoint costs knots in the smoothed path and gridpoints in the
time law.

All heavy work is numba ``@njit(cache=True)``; units are seconds and degrees.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.kernel_cache import DELIVERY, warm_up

__all__ = ["rdp_mask", "simplify_axis", "simplify_columns", "max_deviation", "simplify_plan"]

#: Factor by which a tolerance is raised when the point budget is exceeded.
_RAISE = 1.5


@njit(cache=True)
def _rdp(t, y, tol, keep, axis_form):
    """RDP on (t, y): sets ``keep`` (n,) and returns the number of kept points.

    A sample's deviation is the largest vertical distance, over the columns of ``y``
    (n, m), to the chord between the kept samples around it; the sample of largest
    deviation is kept while that exceeds ``tol`` (the first one at a tie). The chord's
    value at ``t_k`` is computed as ``y_i + dy (t_k - t_i) / dt`` with ``axis_form``
    (:func:`rdp_mask`), else as ``y_i + f dy`` with ``f = (t_k - t_i) / dt``
    (:func:`simplify_plan`): the two roundings keep different samples at exact ties, and
    results published with each depend on it.
    """
    n = t.size
    keep[:] = False
    if n == 0:
        return 0
    keep[0] = True
    keep[n - 1] = True
    if n <= 2:
        return n
    stack = np.empty((n, 2), dtype=np.int64)
    stack[0, 0] = 0
    stack[0, 1] = n - 1
    top = 1
    count = 2
    while top > 0:
        top -= 1
        i = stack[top, 0]
        j = stack[top, 1]
        if j - i < 2:
            continue
        dt = t[j] - t[i]
        best = -1.0
        idx = -1
        for k in range(i + 1, j):
            f = 0.0 if axis_form or not dt > 0.0 else (t[k] - t[i]) / dt
            d = 0.0
            for c in range(y.shape[1]):
                dy = y[j, c] - y[i, c]
                if not axis_form:
                    yk = y[i, c] + f * dy
                elif dt > 0.0:
                    yk = y[i, c] + dy * (t[k] - t[i]) / dt
                else:
                    yk = y[i, c]
                d = max(d, abs(y[k, c] - yk))
            if d > best:
                best = d
                idx = k
        if best > tol:
            keep[idx] = True
            count += 1
            stack[top, 0] = i
            stack[top, 1] = idx
            stack[top + 1, 0] = idx
            stack[top + 1, 1] = j
            top += 2
    return count


@njit(cache=True)
def rdp_mask(t, y, tol, keep):
    """RDP on one axis: sets ``keep`` (n,) and returns the number of kept points.

    Parameters
    ----------
    t : (n,) float64, non-decreasing times
    y : (n,) float64, angles
    tol : float >= 0, largest allowed vertical deviation of a dropped sample
    keep : (n,) bool, output
    """
    y2 = np.ascontiguousarray(y).reshape((y.size, 1))
    return _rdp(t, y2, tol, keep, True)


@njit(cache=True)
def simplify_columns_kernel(t, Y, tol, max_points, keep, tol_used):
    """The kernel of :func:`simplify_columns`, writing into ``keep`` (S, J) bool and
    ``tol_used`` (J,); each column's tolerance grows by :data:`_RAISE` until at most
    ``max_points`` are kept."""
    for c in range(Y.shape[1]):
        y = np.ascontiguousarray(Y[:, c])
        tc = tol[c]
        col = np.empty(t.size, dtype=np.bool_)
        while True:
            cnt = rdp_mask(t, y, tc, col)
            if cnt <= max_points:
                break
            tc *= _RAISE
        keep[:, c] = col
        tol_used[c] = tc


def simplify_axis(t, y, tol: float, max_points: int = 1024):
    """Simplify one axis: returns (t_kept, y_kept, tolerance_used)."""
    t = np.ascontiguousarray(t, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    keep, used = simplify_columns(t, y[:, None], np.array([tol]), max_points)
    return t[keep[:, 0]], y[keep[:, 0]], float(used[0])


def simplify_columns(t, Y, tol, max_points: int = 1024):
    """Simplify several axes sampled at the same times.

    Parameters
    ----------
    t : (S,) times, s
    Y : (S, J) angles, deg
    tol : float or (J,) tolerance per column, deg (> 0)
    max_points : int >= 2, largest number of kept points per column

    Returns
    -------
    keep : (S, J) bool
    tol_used : (J,) tolerance each column needed to fit ``max_points``
    """
    t = np.ascontiguousarray(t, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    if Y.ndim != 2 or Y.shape[0] != t.size:
        raise ValueError("Y must be (len(t), J)")
    tol = np.broadcast_to(np.asarray(tol, dtype=np.float64), (Y.shape[1],)).copy()
    if not np.all(np.isfinite(tol)) or np.any(tol <= 0):
        raise field_error(SpecError, "tolerance_deg", tol.tolist(), "finite values > 0 deg",
                          "simplify")
    if int(max_points) < 2:
        raise field_error(SpecError, "max_points", max_points, ">= 2", "simplify")
    keep = np.empty(Y.shape, dtype=np.bool_)
    used = np.empty(Y.shape[1])
    simplify_columns_kernel(t, np.ascontiguousarray(Y), tol, int(max_points), keep, used)
    return keep, used


def max_deviation(t_dense, y_dense, t_kept, y_kept) -> float:
    """Largest |linear interpolation of the kept points - dense samples|, deg."""
    return float(np.max(np.abs(np.interp(t_dense, t_kept, y_kept) - y_dense))) if len(t_dense) else 0.0


# =====================================================================================
# Stepwise plans
# =====================================================================================
@njit(cache=True)
def _simplify_plan(ptr, steps, angles, tol, keep):
    for i in range(ptr.size - 1):
        a = ptr[i]
        b = ptr[i + 1]
        if tol[i] > 0.0:
            _rdp(steps[a:b], angles[a:b], tol[i], keep[a:b], False)
        else:
            keep[a:b] = True


def simplify_plan(plan, tol_deg):
    """The plan with each robot's breakpoints reduced by RDP, both axes together.

    A breakpoint is dropped when linear interpolation (on the step clock) between the
    kept ones stays within ``tol_deg`` of it on both axes, so the reduced path is within
    ``tol_deg`` of the plan at every step (both are piecewise linear with the kept
    breakpoints among the plan's). The first and last breakpoint of every robot are
    kept: start and end configurations are exact.

    Parameters
    ----------
    plan : rfp_twin.planners.plan.Plan
    tol_deg : float or (n,) per robot, deg (>= 0; 0 keeps every breakpoint)

    Returns
    -------
    Plan with the same robots, steps and metadata, fewer breakpoints.
    """
    from dataclasses import replace

    n = plan.n_robots
    tol = np.broadcast_to(np.asarray(tol_deg, dtype=np.float64), (n,)).copy()
    if not np.all(np.isfinite(tol)) or np.any(tol < 0):
        raise field_error(SpecError, "presimplify_deg", tol_deg, "finite values >= 0 deg",
                          "simplify_plan")
    ptr = np.ascontiguousarray(plan.path_ptr, dtype=np.int64)
    steps = np.ascontiguousarray(plan.path_step, dtype=np.float64)
    angles = np.ascontiguousarray(plan.path_angles, dtype=np.float64)
    keep = np.empty(steps.size, dtype=np.bool_)
    _simplify_plan(ptr, steps, angles, tol, keep)
    new_ptr = np.concatenate([[0], np.cumsum(keep, dtype=np.int64)])[ptr]
    return replace(plan, path_ptr=new_ptr, path_step=plan.path_step[keep],
                   path_angles=plan.path_angles[keep])


def direction_reversals(ptr: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """How often each robot's path turns back on an axis: (n,) int64.

    ptr : (n + 1,) CSR offsets of each robot's breakpoints; angles : (m, 2) deg. A
    reversal is a sign change of the motion between successive breakpoints on either
    axis (waits, zero motion, neither start nor end one). Greedy paths have a few;
    Markov random walks and the robots of a deadlock re-run hundreds.
    """
    ptr = np.asarray(ptr, dtype=np.int64)
    n = ptr.size - 1
    m = int(ptr[-1]) if n > 0 else 0
    if m < 3:
        return np.zeros(n, dtype=np.int64)
    return _reversals(ptr, np.ascontiguousarray(np.asarray(angles, dtype=np.float64)[:m]))


@njit(cache=True)
def _reversals(ptr, angles):
    """:func:`direction_reversals` in one pass: per robot and axis, the sign of each
    increment (``np.sign``: NaN stays NaN and differs from every sign), zero increments
    skipped, and a turn wherever it differs from the last non-zero one."""
    n = ptr.size - 1
    turns = np.zeros(n, dtype=np.int64)
    for i in range(n):
        for ax in range(2):
            last = 0.0
            for k in range(ptr[i], ptr[i + 1] - 1):
                sg = np.sign(angles[k + 1, ax] - angles[k, ax])
                if sg == 0.0:
                    continue
                if last != 0.0 and sg != last:
                    turns[i] += 1
                last = sg
    return turns


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, _reversals, _simplify_plan, simplify_columns_kernel)
