"""Speed bounds of the 2D collision segment and the coarse grid they set (mm/s, s).

*Speed bound.* Robot ``i``'s collision segment is ``P_i(r, t) = b_i + l_i (cos a,
sin a) + r (cos(a + b), sin(a + b))``, ``r`` in ``[s0_i, s1_i]``, with the robot's own
alpha arm length ``l_i`` and segment (:func:`robot_arms`: the spec's values unless the
layout carries per-robot columns). Differentiating (angles in radians)::

    dP/dt = l_i a' n(a) + r (a' + b') n(a + b),   |n| = 1
    |dP/dt| <= l_i |a'| + r_max (|a'| + |b'|) =: V_i

``r_max = max(|s0_i|, |s1_i|)``. The trajectory is piecewise linear, so
on any time window ``|a'|`` and ``|b'|`` are at most the largest slope ``A_i`` / ``B_i``
of the breakpoint segments that overlap the window (zero outside a robot's time range,
where it holds its first/last angle). So every material point of the collision segment
moves at most ``V_i = l_i A_i + r_max (A_i + B_i)`` mm/s. The bound comes from the
trajectory itself, not from the spec speed. A jump (two breakpoints at the same time
with different angles) has no finite bound and is rejected with
:class:`rfp_twin.models.errors.TrajectoryError`.

*Lipschitz distance.* Let ``(r*, q*)`` be the closest material points at time ``t'``.
Then ``D(t) <= |P_i(r*, t) - P_j(q*, t)| <= D(t') + (V_i + V_j) |t - t'|``, and the same
with ``t, t'`` swapped: ``D`` is Lipschitz with ``L = V_i + V_j`` (``V_j = 0`` for a
fiducial or any other static obstacle). :mod:`rfp_twin.validation.checker2d.kernel` turns
this into the interval bound.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import robot_collision_arrays
from rfp_twin.models.robot import RobotSpec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.checker2d.kernel import n_intervals
from rfp_twin.validation.numerics import axis_csr, checked_float, peak_and_travel, time_span


def robot_arms(spec: RobotSpec, layout: Layout | None, ids, buffer_mm: float):
    """Each checked robot's own 2D collision body, in the order of ``ids`` (robot ids).

    Returns ``(l_alpha, s0, s1, r_max, buffer)``, five (n,) float64 arrays in mm: alpha
    arm length, start and end of the beta collision segment, ``max(|s0|, |s1|)`` and the
    collision buffer. With a ``layout`` they come from its per-robot columns
    (:func:`rfp_twin.models.layout.columns.robot_collision_arrays`, the spec's values
    where blank); with ``layout=None`` every robot has the spec's values at ``buffer_mm``.
    """
    n = len(ids)
    if layout is None:
        la, s0, s1, buf = (np.full(n, float(v)) for v in (
            spec.alpha_length_mm, spec.segment_start_mm, spec.segment_end(buffer_mm), buffer_mm))
    else:
        rows = layout.robot_indices(np.asarray(ids, dtype=np.int64)) if n else \
            np.zeros(0, dtype=np.int64)
        la, s0, s1, buf = (np.asarray(a, dtype=np.float64)[rows]
                           for a in robot_collision_arrays(spec, layout, buffer_mm))
    return la, s0, s1, np.maximum(np.abs(s0), np.abs(s1)), buf


def checked_buffer(buffer_mm) -> float:
    """``buffer_mm`` as a float, or a :class:`rfp_twin.models.errors.SpecError` (finite, > 0)."""
    return checked_float(buffer_mm, "buffer_mm", "a finite number > 0 mm", "check_trajectory")


def robot_speeds(la, rmax, alpha_csr, beta_csr, span: float):
    """Per-robot (max, mean) point-speed bounds of the collision segment, mm/s.

    ``la``, ``rmax``: (n,) mm, each robot's alpha arm length and ``r_max`` (or scalars,
    the same for every robot).
    Max: ``l_alpha A + r_max (A + B)`` with the largest |slope| per axis (rad/s).
    Mean: the same with the mean |slope| over the checked span (travel / span).
    ``alpha_csr`` / ``beta_csr``: ``(ptr, times, rate)`` of :func:`axis_csr`.
    """
    out = []
    for ptr, tt, rate in (alpha_csr, beta_csr):
        peak, travel = peak_and_travel(ptr, tt, rate)
        out.append((peak, travel / span if span > 0 else np.zeros(len(ptr) - 1)))
    (a_max, a_mean), (b_max, b_mean) = out
    return la * a_max + rmax * (a_max + b_max), la * a_mean + rmax * (a_mean + b_mean)


def speed_bounds_mm_s(traj: Trajectory, spec: RobotSpec, buffer_mm: float,
                      *, mean: bool = False, layout: Layout | None = None) -> np.ndarray:
    """Per-robot bound on the point speed of the collision segment, mm/s.

    ``V_i = l_i A_i + r_max,i (A_i + B_i)`` with ``A_i`` / ``B_i`` the largest
    |slope| of robot ``i``'s alpha / beta breakpoints in rad/s. With ``mean=True``
    the mean |slope| over the checked span instead (what sets the coarse grid).
    ``layout``: take each robot's own alpha arm and segment from it
    (:func:`robot_arms`); None: the spec's for every robot.

    Returns
    -------
    (n_robots,) float64, mm/s, in trajectory order.
    """
    buffer_mm = checked_buffer(buffer_mm)
    if traj.n_robots == 0:
        return np.zeros(0)
    la, _, _, rmax, _ = robot_arms(spec, layout, traj.robot_ids, buffer_mm)
    pa, ta, _, ra = axis_csr(traj, 0)
    pb, tb, _, rb = axis_csr(traj, 1)
    t_lo, t_hi = time_span(traj)
    vmax, vmean = robot_speeds(la, rmax, (pa, ta, ra), (pb, tb, rb), t_hi - t_lo)
    return vmean if mean else vmax


def coarse_grid(traj: Trajectory, spec: RobotSpec, buffer_mm: float, robot_a: int,
                robot_b: int | None = None, *, resolution_s: float = 1e-5,
                layout: Layout | None = None) -> np.ndarray:
    """The coarse sample times :func:`check_trajectory` starts from for one pair.

    Parameters
    ----------
    traj, spec, buffer_mm
        As for :func:`rfp_twin.validation.checker2d.check_trajectory`.
    robot_a, robot_b : int
        Robot ids; ``robot_b=None`` for a robot-fiducial pair.
    layout : Layout, optional
        The checked layout, for each robot's own arm (as :func:`speed_bounds_mm_s`).

    Returns
    -------
    (n + 1,) float64, s: uniform on the checked span, both ends included, spacing
    ``<= 2 buffer / (Vmean_a + Vmean_b)``.
    """
    vmean = speed_bounds_mm_s(traj, spec, buffer_mm, mean=True, layout=layout)
    ids = [int(r) for r in traj.robot_ids]
    speed = vmean[ids.index(int(robot_a))]
    if robot_b is not None:
        speed += vmean[ids.index(int(robot_b))]
    t_lo, t_hi = time_span(traj)
    n = int(n_intervals(t_hi - t_lo, float(speed), 2.0 * float(buffer_mm), float(resolution_s)))
    if n == 0:
        return np.array([t_lo])
    grid = t_lo + (t_hi - t_lo) * (np.arange(n + 1) / n)
    grid[-1] = t_hi
    return grid
