"""The ``numba`` timing backend: the kernel of :mod:`rfp_twin.planners.postprocess.timing.kernel`.

It always finds a law (the controllable sets contain ``x = 0``), about 0.3 ms per group
of an SDSS-V fold. Units: plan steps, degrees, seconds.
"""
from __future__ import annotations

from rfp_twin.planners.postprocess.timing.backends import TimingProblem
from rfp_twin.planners.postprocess.timing.kernel import topp
from rfp_twin.planners.postprocess.timing.law import TimeLaw

__all__ = ["solve_law"]


def solve_law(problem: TimingProblem) -> TimeLaw:
    """The kernel's time-optimal law of ``problem`` (``solver == "numba"``)."""
    return topp(problem.grid, problem.qd, problem.qdd, problem.vmax, problem.amax,
                sd_cap=problem.sd_cap)
