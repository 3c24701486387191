"""The stepwise Greedy (GC) and Markov (MC) planners of Sayres 2021 Sect. 4.

Every robot moves by at most ``step_deg`` per axis and step, robot by robot, under the
step rule (Eqs. 6-7); its path comes back as breakpoints on the step clock.

Modules
-------
moves
    The step-rule margin MD (:func:`max_displacement`, Eq. 7; :func:`array_max_displacement`
    for an array whose robots have their own geometry) and the kernel's scalar helpers
    (one candidate move, trig rotation by whole steps, segment reach, obstacle distance).
kernel
    :func:`run_stepwise`, the numba kernel: GC and MC on raw arrays, each robot with its
    own alpha arm, collision segment and buffer, each obstacle (point or segment) with its
    own keep-out radius (its step loop; the helpers it inlines are in ``candidates``,
    ``neighbours``, ``mc_choice`` and ``state``).
candidates, neighbours, mc_choice, state
    The kernel's helpers: a robot's nine candidates and the step rule; its neighbours
    (short lists, free windows, Eq. 10, the Eq. 9 energy); the Markov choice; the
    kernel's state.
run
    :func:`run_array`: the kernel on an :class:`rfp_twin.models.array.ArrayGeometry`, with
    breakpoint buffers sized for the most the kernel can write (grown on overflow above
    MAX_EVENTS); its outcome is a :class:`StepRun`.

Units: angles in deg, lengths in mm, time in planner steps.
"""
from rfp_twin.planners.stepwise.kernel import ENERGY_CUTOFF_MM, NEAR_HORIZON, run_stepwise
from rfp_twin.planners.stepwise.moves import (ANGLE_EPS, DEG, array_max_displacement,
                                              max_displacement)
from rfp_twin.planners.stepwise.run import StepRun, run_array

__all__ = ["ANGLE_EPS", "DEG", "ENERGY_CUTOFF_MM", "NEAR_HORIZON", "StepRun",
           "array_max_displacement", "max_displacement", "run_array", "run_stepwise"]
