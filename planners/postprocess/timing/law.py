"""The time law ``s(t)`` of one group: a path parameter with piecewise-constant ``sdd``.

A :class:`TimeLaw` holds the gridpoints ``s_0 < ... < s_N`` (plan steps), the path
speed ``sd`` at each (steps/s), a constant ``sdd`` on each interval (steps/s^2) and the
time of each gridpoint (s). Between gridpoints ``s(t) = s_i + sd_i tau + sdd_i tau^2 /
2``; with ``x = sd^2`` linear in ``s`` on an interval, the time to cross it is ``2 ds /
(sd_i + sd_{i+1})`` (:func:`law_times`).

Units: plan steps, seconds.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from rfp_twin.models.kernel_cache import DELIVERY, warm_up

__all__ = ["TimeLaw", "law_times"]


@dataclass(frozen=True)
class TimeLaw:
    """``s(t)`` of one group: constant ``sdd`` between gridpoints.

    Attributes
    ----------
    s : (N+1,) gridpoints, plan steps (increasing)
    sd : (N+1,) ds/dt at the gridpoints, steps/s (0 at both ends)
    sdd : (N,) d2s/dt2 on each interval, steps/s^2
    t : (N+1,) time of each gridpoint, s (t[0] = 0)
    solver : what computed it: "numba" (the kernel), "toppra" (the library), "fallback"
        (the kernel, after the library found no solution), "numba-large" (the kernel, for
        a group too large for the library, :data:`rfp_twin.planners.postprocess.timing.TOPPRA_MAX_ROBOTS`) or
        "static" (nothing moves)
    """

    s: np.ndarray
    sd: np.ndarray
    sdd: np.ndarray
    t: np.ndarray
    solver: str = "numba"

    @property
    def duration(self) -> float:
        return float(self.t[-1]) if self.t.size else 0.0

    def s_at(self, times) -> np.ndarray:
        """Path parameter at the given times (held outside [0, duration])."""
        times = np.ascontiguousarray(np.atleast_1d(np.asarray(times, dtype=np.float64)))
        out = np.empty(times.size)
        s_at_times(self.s, self.sd, self.sdd, self.t, times, out)
        return out

    def scaled(self, c: float) -> TimeLaw:
        """The same motion ``c`` times slower (c >= 1): velocities / c, accelerations / c^2."""
        return TimeLaw(self.s, self.sd / c, self.sdd / (c * c), self.t * c, self.solver)

    @classmethod
    def static(cls, s0: float) -> TimeLaw:
        return cls(np.array([s0]), np.zeros(1), np.zeros(0), np.zeros(1), "static")


@njit(cache=True)
def s_at_times(s, sd, sdd, t, times, out):
    """``out[j] = s(times[j])`` for the law with gridpoints ``s``, ``sd`` (ds/dt), ``sdd``
    (constant on each interval) reached at times ``t`` (s)."""
    n = s.size
    for j in range(times.size):
        tj = times[j]
        if n == 1 or tj <= t[0]:
            out[j] = s[0]
            continue
        if tj >= t[n - 1]:
            out[j] = s[n - 1]
            continue
        # the interval [t[lo], t[lo + 1]) holding tj (the last one for a NaN tj)
        lo = min(np.searchsorted(t, tj, side="right") - 1, n - 2)
        tau = tj - t[lo]
        v = s[lo] + sd[lo] * tau + 0.5 * sdd[lo] * tau * tau
        out[j] = min(max(v, s[lo]), s[lo + 1])


@njit(cache=True)
def law_times(s, x):
    """(N+1,) time of each gridpoint, s: ``x = sd^2`` (N+1,) linear in ``s`` (N+1,) between them.

    An interval with ``sd = 0`` at both ends takes forever (inf); one of zero length none.
    """
    n = s.size
    t = np.zeros(n)
    for i in range(n - 1):
        den = math.sqrt(max(x[i], 0.0)) + math.sqrt(max(x[i + 1], 0.0))
        ds = s[i + 1] - s[i]
        if ds <= 0.0:
            t[i + 1] = t[i]
        elif den > 0.0:
            t[i + 1] = t[i] + 2.0 * ds / den
        else:
            t[i + 1] = np.inf
    return t



# called from Python once the planner has run (loaded ahead from numba's cache)
warm_up(DELIVERY, law_times, s_at_times)
