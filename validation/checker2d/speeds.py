"""Speed bounds of the 2D collision segment and the coarse grid they set (mm/s, s).

*Speed bound.* Robot ``i``'s collision segment is ``P_i(r, t) = b_i + l_alpha (cos a,
sin a) + r (cos(a + b), sin(a + b))``, ``r`` in ``[segment_start_mm,
spec.segment_end(buffer)]``. Differentiating (angles in radians)::

    dP/dt = l_alpha a' n(a) + r (a' + b') n(a + b),   |n| = 1
    |dP/dt| <= l_alpha |a'| + r_max (|a'| + |b'|) =: V_i

``r_max = max(|segment_start|, |segment_end|)``. The trajectory is piecewise linear, so
on any time window ``|a'|`` and ``|b'|`` are at most the largest slope ``A_i`` / ``B_i``
of the breakpoint segments that overlap the window (zero outside a robot's time range,
where it holds its first/last angle). So every material point of the collision segment
moves at most ``V_i = l_alpha A_i + r_max (A_i + B_i)`` mm/s. The bound comes from the
trajectory itself, not from the spec speed. A jump (two breakpoints at the same time
with different angles) has no finite bound and is rejected with
:class:`rfp_twin.models.errors.TrajectoryError`.

*Lipschitz distance.* Let ``(r*, q*)`` be the closest material points at time ``t'``.
Then ``D(t) <= |P_i(r*, t) - P_j(q*, t)| <= D(t') + (V_i + V_j) |t - t'|``, and the same
with ``t, t'`` swapped: ``D`` is Lipschitz with ``L = V_i + V_j`` (``V_j = 0`` for a
fiducial). :mod:`rfp_twin.validation.checker2d.kernel` turns this into the interval bound.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.robot import RobotSpec
from rfp_twin.models.trajectory import Trajectory
from rfp_twin.validation.checker2d.kernel import n_intervals
from rfp_twin.validation.numerics import axis_csr, checked_float, peak_and_travel, time_span


def arm_geometry(spec: RobotSpec, buffer_mm: float) -> tuple[float, float, float, float]:
    """(l_alpha, segment start, segment end, r_max) in mm."""
    s0 = float(spec.segment_start_mm)
    s1 = float(spec.segment_end(buffer_mm))
    return float(spec.alpha_length_mm), s0, s1, max(abs(s0), abs(s1))


def checked_buffer(buffer_mm) -> float:
    """``buffer_mm`` as a float, or a :class:`rfp_twin.models.errors.SpecError` (finite, > 0)."""
    return checked_float(buffer_mm, "buffer_mm", "a finite number > 0 mm", "check_trajectory")


def robot_speeds(la: float, rmax: float, alpha_csr, beta_csr, span: float):
    """Per-robot (max, mean) point-speed bounds of the collision segment, mm/s.

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
                      *, mean: bool = False) -> np.ndarray:
    """Per-robot bound on the point speed of the collision segment, mm/s.

    ``V_i = l_alpha A_i + r_max (A_i + B_i)`` with ``A_i`` / ``B_i`` the largest
    |slope| of robot ``i``'s alpha / beta breakpoints in rad/s. With ``mean=True``
    the mean |slope| over the checked span instead (what sets the coarse grid).

    Returns
    -------
    (n_robots,) float64, mm/s, in trajectory order.
    """
    buffer_mm = checked_buffer(buffer_mm)
    la, _, _, rmax = arm_geometry(spec, buffer_mm)
    if traj.n_robots == 0:
        return np.zeros(0)
    pa, ta, _, ra = axis_csr(traj, 0)
    pb, tb, _, rb = axis_csr(traj, 1)
    t_lo, t_hi = time_span(traj)
    vmax, vmean = robot_speeds(la, rmax, (pa, ta, ra), (pb, tb, rb), t_hi - t_lo)
    return vmean if mean else vmax


def coarse_grid(traj: Trajectory, spec: RobotSpec, buffer_mm: float, robot_a: int,
                robot_b: int | None = None, *, resolution_s: float = 1e-5) -> np.ndarray:
    """The coarse sample times :func:`check_trajectory` starts from for one pair.

    Parameters
    ----------
    traj, spec, buffer_mm
        As for :func:`rfp_twin.validation.checker2d.check_trajectory`.
    robot_a, robot_b : int
        Robot ids; ``robot_b=None`` for a robot-fiducial pair.

    Returns
    -------
    (n + 1,) float64, s: uniform on the checked span, both ends included, spacing
    ``<= 2 buffer / (Vmean_a + Vmean_b)``.
    """
    vmean = speed_bounds_mm_s(traj, spec, buffer_mm, mean=True)
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
