"""From configurations to collision-free, timed trajectories (imports ``models`` only).

The folders follow the stages a plan goes through:

- ``assignment/``: catalogue -> targets (at most one per robot, final poses clear);
- ``plan/``: what a plan is (:class:`Plan`), its inputs (targets, offline robots,
  :class:`PlannerSettings`) and the driver :func:`plan_reconfiguration`;
- ``stepwise/``: the GC/MC kernels (Sayres et al. 2021) and MDP2;
- ``deadlocks/``: the strategies tried on what a run left stuck, one module each
  behind one ``Resolver`` interface, and their order (``deadlocks/chain.py``);
- ``postprocess/``: smoothing, time-optimal timing and its backends, simplification and
  re-verification (with the verifier it is handed);
- ``roadmap/`` (Sabater et al. 2018: alpha/beta arrays and MIRADAS probe arms) and
  ``fields/`` (APF / CAPF, Makarem 2014, Macktoobian 2019): the other planners.

The public API, each name loaded from its module on first use (numba compiles or loads
its cache then, not at ``import planners``). Units: mm, deg, s; configurations are
``(n_robots, 2)`` arrays of (alpha, beta) in deg.

Stepwise planning: :class:`PlannerSettings`, :func:`plan_reconfiguration`,
:data:`ALGORITHMS`, :data:`DIRECTIONS`, :data:`RESOLVERS`, :func:`max_displacement`; the
result :class:`Plan` and its robot statuses. Targets and offline robots:
:func:`random_targets`, :func:`check_targets`, :func:`check_angles`,
:func:`apply_offline`. Deadlocks: :class:`SearchResolveSettings` (state-time search after
Sabater 2018), :class:`RoadmapSettings`. Potential fields: :class:`ApfSettings`,
:class:`CapfSettings`, :func:`plan_apf`, :func:`plan_apf_reconfiguration`,
:func:`apf_target_margin_mm`. Post-processing: :func:`postprocess`,
:class:`PostprocessReport`, :data:`BACKENDS`, :data:`DEFAULT_BACKEND`.
"""
from __future__ import annotations

from rfp_twin.models.lazy import lazy_exports

_LAZY = {
    **dict.fromkeys(("PlannerSettings", "plan_reconfiguration", "ALGORITHMS", "DIRECTIONS",
                     "RESOLVERS", "Plan", "REACHED", "REPLACED", "DEADLOCKED", "OFFLINE",
                     "STATUSES", "random_targets", "check_targets", "check_angles",
                     "apply_offline"), "rfp_twin.planners.plan"),
    "max_displacement": "rfp_twin.planners.stepwise",
    "array_max_displacement": "rfp_twin.planners.stepwise",
    "SearchResolveSettings": "rfp_twin.planners.roadmap.alpha_beta",
    "RoadmapSettings": "rfp_twin.planners.roadmap",
    **dict.fromkeys(("ApfSettings", "CapfSettings", "plan_apf", "plan_apf_reconfiguration",
                     "apf_target_margin_mm"), "rfp_twin.planners.fields"),
    **dict.fromkeys(("postprocess", "PostprocessReport", "Verifier"), "rfp_twin.planners.postprocess"),
    **dict.fromkeys(("BACKENDS", "DEFAULT_BACKEND"), "rfp_twin.planners.postprocess.timing"),
}

__all__ = sorted(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
