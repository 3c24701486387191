"""Kinematics of a piecewise-linear axis, as the firmware executes it.

The firmware interpolates linearly between (angle, time) points, so the product is
piecewise linear. :func:`pl_kinematics` defines its velocity as the slope of each
segment and its acceleration at each breakpoint as the three-point value

    a_k = 2 (m_k - m_{k-1}) / (t_{k+1} - t_{k-1}),

(``m_k`` the slope after breakpoint ``k``): the slope change spread over the two
half-segments around the breakpoint, i.e. the acceleration of the parabola through
three consecutive breakpoints. The axis rests before its first and after its last
breakpoint, so ``a_0 = 2 m_0 / (t_1 - t_0)`` and ``a_K = -2 m_{K-1} / (t_K -
t_{K-1})``. Both are weighted averages of the true velocity / acceleration of any C1
curve through the breakpoints; so breakpoints sampled exactly from a trajectory within
the limits (any subset of them) have slopes and three-point accelerations within the
limits.

Units: degrees, seconds; ``t`` and ``y`` are (K+1,) float64 arrays.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.kernel_cache import DELIVERY, warm_up

__all__ = ["pl_kinematics"]


@njit(cache=True)
def pl_kinematics(t, y):
    """Largest |slope| and |three-point acceleration| of one piecewise-linear axis.

    See the module docstring: slope ``m_k = dy / dt`` per segment; acceleration at
    breakpoint ``k`` ``2 (m_k - m_{k-1}) / (t_{k+1} - t_{k-1})`` with the axis at rest
    before the first and after the last breakpoint. Returns (vmax, amax); a zero-length
    segment with a change of angle gives inf.
    """
    n = t.size
    if n < 2:
        return 0.0, 0.0
    vm = 0.0
    am = 0.0
    prev_m = 0.0
    prev_h = 0.0
    for k in range(n - 1):
        h = t[k + 1] - t[k]
        dy = y[k + 1] - y[k]
        if h > 0.0:
            m = dy / h
        elif dy == 0.0:
            continue
        else:
            return np.inf, np.inf
        if abs(m) > vm:
            vm = abs(m)
        span = prev_h + h
        a = 2.0 * abs(m - prev_m) / span
        if a > am:
            am = a
        prev_m = m
        prev_h = h
    if prev_h > 0.0:
        a = 2.0 * abs(prev_m) / prev_h
        if a > am:
            am = a
    return vm, am


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, pl_kinematics)
