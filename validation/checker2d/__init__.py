"""Independent dense 2D collision check of a :class:`rfp_twin.models.trajectory.Trajectory`.

Checks every robot-robot and robot-obstacle (fiducial, guide-camera edge) pair that can
touch against the capsule model of Sayres et al. 2021 (Eq. 3), each robot with its own
alpha arm, segment and buffer from the layout's columns, with a bound between samples
so that no collision, however brief, can slip through (mm, deg, s at the public
boundary).

Modules
-------
report
    :class:`Collision`, :class:`CheckReport`.
speeds
    Point-speed bounds of the collision segment, :func:`coarse_grid`.
kernel
    The numba kernel: coarse grid, bisection, interval bound, collision runs.
check
    :func:`check_trajectory`: candidate pairs (k-d tree), kernel inputs, the report.
merge
    :func:`merge_reports`: a full check and later re-checks of some pairs as one report.

Independence: this package imports ``models`` (robot, layout and its columns, errors,
the trajectory data type) and :mod:`rfp_twin.validation.numerics` (its own segment distance), never
``planners`` nor the planner's distance code :mod:`rfp_twin.models.geometry2d`.
"""
from rfp_twin.validation.checker2d.check import check_trajectory
from rfp_twin.validation.checker2d.merge import merge_reports
from rfp_twin.validation.checker2d.report import CheckReport, Collision
from rfp_twin.validation.checker2d.speeds import coarse_grid, speed_bounds_mm_s
from rfp_twin.validation.numerics import segment_distance_np

__all__ = [
    "Collision",
    "CheckReport",
    "check_trajectory",
    "merge_reports",
    "segment_distance_np",
    "speed_bounds_mm_s",
    "coarse_grid",
]
