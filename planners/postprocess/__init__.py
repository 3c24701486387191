"""From a stepwise plan to firmware-ready trajectories, re-verified (Sayres 2021 Sect. 6).

:func:`postprocess` pre-simplifies, smooths, groups, times, samples, simplifies and
re-verifies a plan (the steps are described in :mod:`rfp_twin.planners.postprocess.pipeline`).
One job per module:

- :mod:`.pipeline`: :func:`postprocess`, the driver loop, its defaults and arguments;
- :mod:`.groups`: one group timed, sampled and simplified; the groups assembled;
- :mod:`.verification`: the clearance ledger over rounds, which robots to re-check, the
  repair of a failed round (merge groups, tighten robots);
- :mod:`.report`: :class:`PostprocessReport` and :class:`TimedPath`.

Units: mm, degrees, seconds, plan steps.
"""
from rfp_twin.planners.postprocess.pipeline import (ALIGNMENTS, DEFAULT_BUDGET_MM, DEFAULT_INTERACTION_MM,
                                           DEFAULT_MAX_POINTS, DEFAULT_PRESIMPLIFY_DEG,
                                           DEFAULT_TOLERANCE_DEG, Verifier, postprocess)
from rfp_twin.planners.postprocess.report import PostprocessReport, TimedPath

__all__ = ["PostprocessReport", "Verifier", "TimedPath", "postprocess", "DEFAULT_BUDGET_MM",
           "DEFAULT_TOLERANCE_DEG", "DEFAULT_PRESIMPLIFY_DEG", "DEFAULT_INTERACTION_MM",
           "DEFAULT_MAX_POINTS", "ALIGNMENTS"]
