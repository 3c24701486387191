"""A plan's breakpoints against each robot's joint limits, before post-processing.

A plan may sit outside the limits by rounding only (:data:`LIMIT_ROUNDING_DEG`); that is
clipped, as post-processing clips its samples. A plan that really leaves the limits (a
field planner without alpha stops, say) is refused with an error naming the robot
(:func:`within_limits`). One compiled pass over the breakpoints finds both (~1M
breakpoints of a Markov plan on the 500-robot SDSS-V layout: ~3 ms, where numpy's
temporaries took ~40 ms).

Units: degrees. Limits are (n, 2, 2) arrays: robot, axis (alpha, beta), lo/hi.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from numba import njit

from rfp_twin.models.errors import SpecError, field_error
from rfp_twin.models.kernel_cache import DELIVERY, warm_up
from rfp_twin.planners.plan import Plan

__all__ = ["LIMIT_ROUNDING_DEG", "within_limits"]

LIMIT_ROUNDING_DEG = 1e-9
"""How far a plan may sit outside the joint limits and still count as inside (rounding), deg."""


@njit(cache=True)
def _scan(ptr, angles, limits, rounding):
    """First breakpoint beyond the limits by more than ``rounding`` on each axis (-1 for
    none), and whether any breakpoint is outside them at all: (bad (2,), outside)."""
    bad = np.full(2, -1, dtype=np.int64)
    outside = False
    for i in range(ptr.size - 1):
        for k in range(ptr[i], ptr[i + 1]):
            for ax in range(2):
                a = angles[k, ax]
                lo = limits[i, ax, 0]
                hi = limits[i, ax, 1]
                if a < lo or a > hi:
                    outside = True
                    if bad[ax] < 0 and (a < lo - rounding or a > hi + rounding):
                        bad[ax] = k
    return bad, outside


def within_limits(plan: Plan, limits: np.ndarray) -> Plan:
    """The plan with its breakpoints clipped to each robot's joint limits ``limits``
    (n, 2, 2) deg; the plan itself when none is outside them. SpecError naming the axis,
    the value, the limits and the robot when one is outside by more than
    :data:`LIMIT_ROUNDING_DEG`."""
    ptr = np.asarray(plan.path_ptr, dtype=np.int64)
    angles = np.ascontiguousarray(plan.path_angles, dtype=np.float64)
    limits = np.ascontiguousarray(limits, dtype=np.float64)
    bad, outside = _scan(ptr, angles, limits, LIMIT_ROUNDING_DEG)
    for ax, name in enumerate(("alpha", "beta")):
        k = int(bad[ax])
        if k >= 0:
            robot = int(np.searchsorted(ptr, k, side="right") - 1)
            lo, hi = limits[robot, ax]
            raise field_error(SpecError, f"plan {name}", f"{angles[k, ax]:.4f} deg",
                              f"[{lo:g}, {hi:g}] deg (the robot's {name} limits)",
                              f"postprocess, robot {int(plan.robot_ids[robot])}")
    if not outside:
        return plan
    owner = np.repeat(np.arange(plan.n_robots), np.diff(ptr))
    lim = limits[owner]                                   # (breakpoints, 2, 2)
    return replace(plan, path_angles=np.clip(plan.path_angles, lim[:, :, 0], lim[:, :, 1]))


# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, _scan)
