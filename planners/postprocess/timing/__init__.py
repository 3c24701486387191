"""Time-optimal parametrisation of smoothed plans under per-axis limits (TOPP-RA).

Given smoothed paths ``q_i(s)`` (:mod:`rfp_twin.planners.postprocess.smoothing`, ``s`` in plan steps) this
package chooses the path parameter as a function of time, ``s(t)``, as fast as every
axis' velocity and acceleration limits allow, from rest to rest, per group of robots
that share one ``s(t)``. One job per module:

- :mod:`.grouping`: which robots share one ``s(t)`` (interaction pairs and groups);
- :mod:`.grid`: a group's gridpoints (its knots, ramp zones, coarse cruises);
- :mod:`.kernel`: the numba TOPP-RA kernel (the constraints, Pham & Pham 2018);
- :mod:`.backends`: the solvers of the discretised problem, chosen by name
  (``"toppra"``: the library; ``"numba"``: the kernel);
- :mod:`.group`: :func:`time_group`, one group from path to time law;
- :mod:`.law`: :class:`TimeLaw`, ``s(t)`` with piecewise-constant ``sdd``;
- :mod:`.kinematics`: :func:`pl_kinematics`, the limits of the piecewise-linear product.

Units: degrees, seconds, plan steps.
"""
from rfp_twin.planners.postprocess.timing.backends import BACKENDS, DEFAULT_BACKEND
from rfp_twin.planners.postprocess.timing.grid import STRAIGHT_STEPS, group_grid
from rfp_twin.planners.postprocess.timing.group import TOPPRA_MAX_ROBOTS, time_group
from rfp_twin.planners.postprocess.timing.grouping import interaction_groups, interaction_pairs
from rfp_twin.planners.postprocess.timing.kernel import SD_CAP, law_excess, topp, topp_kernel
from rfp_twin.planners.postprocess.timing.kinematics import pl_kinematics
from rfp_twin.planners.postprocess.timing.law import TimeLaw

__all__ = [
    "BACKENDS",
    "DEFAULT_BACKEND",
    "TOPPRA_MAX_ROBOTS",
    "SD_CAP",
    "STRAIGHT_STEPS",
    "TimeLaw",
    "interaction_pairs",
    "interaction_groups",
    "group_grid",
    "time_group",
    "topp",
    "topp_kernel",
    "law_excess",
    "pl_kinematics",
]
