"""Which robot kinds each planner supports, in one place.

GC/MC (greedy, markov; Sayres 2021), MDP2 (SDSS-V's production generator) and the potential fields (apf, capf; Makarem 2014,
Macktoobian 2019) are written for alpha/beta positioners; the prioritized state-time
search on roadmaps (roadmap; Sabater 2018) reaches the robot only through
``forbidden(q)`` and ``collides(q, t)`` and runs on every kind (alpha/beta arrays through
:mod:`rfp_twin.planners.roadmap.alpha_beta.array`, probe arms through :mod:`rfp_twin.planners.roadmap.probe`).
"""
from __future__ import annotations

from rfp_twin.models.kinds import ALPHA_BETA, MIRADAS_PROBE, require_kind

#: Planner name -> robot kinds it plans.
PLANNER_KINDS = {
    "greedy": (ALPHA_BETA,),
    "markov": (ALPHA_BETA,),
    "mdp2": (ALPHA_BETA,),
    "roadmap": (ALPHA_BETA, MIRADAS_PROBE),
    "apf": (ALPHA_BETA,),
    "capf": (ALPHA_BETA,),
}


def require_planner_kind(algorithm: str, kind: str) -> None:
    """Raise :class:`~rfp_twin.models.errors.KindError` (one line naming the planner and
    the kind) unless planner ``algorithm`` supports robot kind ``kind``."""
    require_kind(kind, PLANNER_KINDS.get(algorithm, ()), f"planner {algorithm!r}")
