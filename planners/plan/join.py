"""Two plans played one after the other: :func:`join_plans`.

A reconfiguration between two arbitrary configurations A and B can always be made of two
plans the stepwise planners are good at: A -> fold (a fold, the reverse of a plan to A)
and fold -> B (an unfold). Joined on one step clock they are one plan from A to B, which
post-processing times as a whole and the 2D checker verifies like any other. Each robot
waits at the joint until the first plan's last step, so no robot starts unfolding while
another is still folding.

Units: angles in deg, time in planner steps.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rfp_twin.models.errors import PlanningError
from rfp_twin.planners.plan.result import Plan

#: Largest difference, deg, between the first plan's end and the second plan's start.
JOINT_TOLERANCE_DEG = 1e-9


def join_plans(first: Plan, second: Plan) -> Plan:
    """``first`` then ``second`` (both in the executed direction, on the same robots and
    step) as one Plan of ``first.n_steps + second.n_steps`` steps.

    The joined plan serves ``second``'s targets, with its status; its metrics are
    ``second``'s with ``first_steps`` (the joint) and ``first_metrics`` added.

    Raises
    ------
    PlanningError
        The plans move other robots, use another step, or ``first`` does not end where
        ``second`` starts (the robot and the angles named).
    """
    if not np.array_equal(first.robot_ids, second.robot_ids):
        raise PlanningError("join_plans: the two plans move different robots")
    if first.step_deg != second.step_deg or first.step_s != second.step_s:
        raise PlanningError(f"join_plans: steps {first.step_deg} / {second.step_deg} deg; "
                            "allowed: the same step")
    gap = np.abs(first.end() - second.start()).max(axis=1) if first.n_robots else np.zeros(0)
    if gap.size and gap.max() > JOINT_TOLERANCE_DEG:
        k = int(np.argmax(gap))
        raise PlanningError(f"join_plans: robot {int(first.robot_ids[k])} ends the first plan at "
                            f"{first.end()[k].tolist()} deg and starts the second at "
                            f"{second.start()[k].tolist()} deg; allowed: the same pose")
    n = first.n_robots
    c1 = np.diff(first.path_ptr)
    c2 = np.diff(second.path_ptr) - 1                # the second's first point is the joint
    ptr = np.zeros(n + 1, dtype=np.int64)
    ptr[1:] = np.cumsum(c1 + c2)
    robot1 = np.repeat(np.arange(n), c1)
    pos1 = ptr[robot1] + (np.arange(c1.sum()) - first.path_ptr[robot1])
    keep2 = np.ones(second.path_step.size, dtype=bool)
    keep2[second.path_ptr[:-1]] = False
    robot2 = np.repeat(np.arange(n), c2)
    # each point's place among its robot's second-plan points after the joint
    within2 = np.arange(c2.sum()) - np.repeat(np.cumsum(c2) - c2, c2)
    pos2 = ptr[robot2] + c1[robot2] + within2
    steps = np.empty(ptr[-1])
    angles = np.empty((ptr[-1], 2))
    steps[pos1] = first.path_step
    angles[pos1] = first.path_angles
    steps[pos2] = second.path_step[keep2] + first.n_steps
    angles[pos2] = second.path_angles[keep2]
    metrics = {**second.metrics, "first_steps": int(first.n_steps),
               "first_metrics": dict(first.metrics)}
    return replace(second, n_steps=int(first.n_steps + second.n_steps), path_ptr=ptr,
                   path_step=steps, path_angles=angles, metrics=metrics)
