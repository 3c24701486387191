"""From configurations to collision-free, timed trajectories (imports ``models`` only).

The public API, each name loaded from its module on first use (numba compiles or loads
its cache then, not at ``import planners``). Units: mm, deg, s; configurations are
``(n_robots, 2)`` arrays of (alpha, beta) in deg.

Stepwise planning (Sayres et al. 2021): :class:`PlannerSettings`,
:func:`plan_reconfiguration`, :data:`ALGORITHMS`, :data:`DIRECTIONS`, :data:`RESOLVERS`,
:func:`max_displacement`; the result :class:`Plan` and its robot statuses.
Targets and offline robots: :func:`random_targets`, :func:`check_targets`,
:func:`check_angles`, :func:`apply_offline`. Deadlocks: :class:`SearchResolveSettings`
(state-time search after Sabater 2018), :class:`RoadmapSettings`.
Potential fields (Makarem 2014, Macktoobian 2019): :class:`ApfSettings`,
:class:`CapfSettings`, :func:`plan_apf`, :func:`plan_apf_reconfiguration`,
:func:`apf_target_margin_mm`.
Post-processing: :func:`postprocess` (smooth, time, simplify, re-verify with the verifier
it is handed), :class:`PostprocessReport`, :data:`BACKENDS`, :data:`DEFAULT_BACKEND`.
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
