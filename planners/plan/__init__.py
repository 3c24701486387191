"""A plan and how it is made: the inputs, the result, and the stepwise driver.

Modules
-------
result
    :class:`Plan`, per-robot stepwise paths on a common step clock (CSR breakpoints) and
    each robot's status; :func:`build_paths` (kernel breakpoints -> CSR paths).
targets, offline
    Random targets (mutually clear, within each robot's limits) and the checks of given
    ones; robots that never move (:func:`apply_offline`).
settings
    :class:`PlannerSettings`, the parameters of one stepwise planning job.
runs
    :func:`run_once`, one planner run of the whole array (GC/MC kernel or roadmap pass).
reconfigure
    :func:`plan_reconfiguration`, the driver: checked inputs, a run per round, the
    deadlock strategies of :mod:`rfp_twin.planners.deadlocks`, the Plan and its metrics.

``plan_reconfiguration`` and ``run_once`` load on first use (the driver imports the
deadlock strategies, which import this package).

Units: angles in deg, lengths in mm, time in planner steps.
"""
from __future__ import annotations

from rfp_twin.models.lazy import lazy_exports
from rfp_twin.planners.plan.offline import apply_offline
from rfp_twin.planners.plan.result import (DEADLOCKED, OFFLINE, REACHED, REPLACED, STATUSES, Plan,
                                           build_paths)
from rfp_twin.planners.plan.settings import ALGORITHMS, DIRECTIONS, RESOLVERS, PlannerSettings
from rfp_twin.planners.plan.targets import check_angles, check_targets, random_targets

_LAZY = {"plan_reconfiguration": "rfp_twin.planners.plan.reconfigure",
         "run_once": "rfp_twin.planners.plan.runs"}

__all__ = sorted(["ALGORITHMS", "DEADLOCKED", "DIRECTIONS", "OFFLINE", "REACHED", "REPLACED",
                  "RESOLVERS", "STATUSES", "Plan", "PlannerSettings", "apply_offline",
                  "build_paths", "check_angles", "check_targets", "random_targets", *_LAZY])

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
