"""A trajectory's angles at many times for every robot at once (the simulators' commands).

:class:`TrajectoryTable` holds a :class:`rfp_twin.models.trajectory.Trajectory` as CSR
arrays per axis; :meth:`TrajectoryTable.sample_into` writes the piecewise-linear angles of
every robot at a sorted grid of times into a (T, n, 2) array in one compiled pass, with a
per-robot time warp ``tau = min(t, stuck_at) * scale`` (the faults of
:mod:`rfp_twin.twin.sim.faults`). Angles outside a robot's breakpoints hold the first / last
value, as :func:`numpy.interp` does; the result equals ``numpy.interp`` robot by robot
(which cost ~2 s a simulated second at 12,852 robots, called per robot and axis).

Units: times in s, angles in deg. Shapes: n robots of the layout, T times.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from rfp_twin.models.trajectory import Trajectory

__all__ = ["TrajectoryTable"]


class TrajectoryTable:
    """``trajectory`` as CSR arrays: for axis ``ax``, robot j's breakpoints are
    ``times[ax][ptr[ax][j]:ptr[ax][j + 1]]`` (s) and ``angles[ax][...]`` (deg); ``rows``
    (n_traj,) int64 is the layout index of each trajectory robot."""

    def __init__(self, trajectory: Trajectory, rows: np.ndarray) -> None:
        self.rows = np.ascontiguousarray(rows, dtype=np.int64)
        self.ptr, self.times, self.angles = [], [], []
        for ax in range(2):
            counts = np.array([len(t) for t in trajectory.times[ax]], dtype=np.int64)
            ptr = np.zeros(counts.size + 1, dtype=np.int64)
            np.cumsum(counts, out=ptr[1:])
            self.ptr.append(ptr)
            self.times.append(_concat(trajectory.times[ax]))
            self.angles.append(_concat(trajectory.angles[ax]))

    def sample_into(self, out: np.ndarray, times: np.ndarray, stuck_at: np.ndarray | None = None,
                    scale: np.ndarray | None = None) -> None:
        """Write every trajectory robot's angles at ``times`` (T,) s (any order) into
        ``out`` (T, n, 2) deg (its other robots untouched). With ``stuck_at`` and ``scale``
        (n,) (layout order) robot k is sampled at ``min(t, stuck_at[k]) * scale[k]``."""
        times = np.ascontiguousarray(times, dtype=np.float64)
        if times.size > 1 and np.any(np.diff(times) < 0):
            order = np.argsort(times, kind="stable")
            part = out[order]
            self.sample_into(part, times[order], stuck_at, scale)
            out[order] = part
            return
        warped = stuck_at is not None
        if not warped:
            stuck_at = scale = np.zeros(0)
        for ax in range(2):
            _sample_axis(out, times, self.ptr[ax], self.times[ax], self.angles[ax], self.rows, ax,
                         warped, np.asarray(stuck_at, dtype=np.float64),
                         np.asarray(scale, dtype=np.float64))


def _concat(parts) -> np.ndarray:
    return np.concatenate([np.asarray(p, dtype=np.float64) for p in parts]) if len(parts) \
        else np.zeros(0)


@njit(cache=True)
def _sample_axis(out, times, ptr, tt, yy, rows, ax, warped, stuck_at, scale):
    """One axis of :meth:`TrajectoryTable.sample_into`: a merge walk per robot (the
    sample times, warped or not, are non-decreasing)."""
    n_t = times.shape[0]
    for j in range(rows.shape[0]):
        k = rows[j]
        lo = ptr[j]
        hi = ptr[j + 1]
        a = lo                     # tt[a] <= tau < tt[a + 1] once inside
        for r in range(n_t):
            tau = times[r]
            if warped:
                tau = min(tau, stuck_at[k]) * scale[k]
            if tau <= tt[lo]:
                out[r, k, ax] = yy[lo]
                continue
            if tau >= tt[hi - 1]:
                out[r, k, ax] = yy[hi - 1]
                continue
            while a + 1 < hi and tt[a + 1] <= tau:
                a += 1
            b = a + 1
            out[r, k, ax] = yy[a] + (yy[b] - yy[a]) * ((tau - tt[a]) / (tt[b] - tt[a]))
