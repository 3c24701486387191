"""Probe arms (MIRADAS, Sabater et al. 2018): prioritized state-time planning on roadmaps.

:func:`plan_probe_arms` plans every arm of a :class:`~rfp_twin.models.kinds.ProbeArmKind`
bench from start to goal poses (Algorithm 1 with the roadmap planner of
:mod:`rfp_twin.planners.roadmap`); :class:`ProbePlanSettings` holds the paper's
parameters; :class:`ProbePlan` the result in the form of Tables 1-2;
:func:`random_target_set` and :func:`typical_scenario` draw target sets. Units: deg,
mm, s.
"""
from rfp_twin.planners.roadmap.probe.prioritized import (SUPPORTED_KINDS, plan_probe_arms,
                                                 priority_order, travel_times)
from rfp_twin.planners.roadmap.probe.report import ArmRow, ProbePlan
from rfp_twin.planners.roadmap.probe.settings import PRIORITIES, RECOVERING, ProbePlanSettings
from rfp_twin.planners.roadmap.probe.targets import random_target_set, typical_scenario
from rfp_twin.planners.roadmap.probe.world import ObstacleTime, pose_gaps

__all__ = ["PRIORITIES", "RECOVERING", "SUPPORTED_KINDS", "ArmRow", "ObstacleTime", "ProbePlan",
           "ProbePlanSettings", "plan_probe_arms", "pose_gaps", "priority_order",
           "random_target_set", "travel_times", "typical_scenario"]
