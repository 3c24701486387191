"""From a stepwise plan to firmware-ready trajectories, re-verified (Sayres 2021 Sect. 6).

:func:`postprocess` pre-simplifies, smooths, groups, times, samples, simplifies and
re-verifies a plan (the steps are described in :mod:`rfp_twin.planners.postprocess.pipeline`).
One job per module:

- :mod:`.smoothing`: a plan as a C1 path of one parameter (:class:`SmoothPath`, the
  running average or a spline); :mod:`.smoothing_local`: wider windows only where the
  timing needs them;
- :mod:`.timing`: time-optimal ``s(t)`` per group of interacting robots (TOPP-RA) and its
  backends;
- :mod:`.simplify`: Ramer-Douglas-Peucker simplification under a point budget;
- :mod:`.pipeline`: :func:`postprocess`, the driver loop, its defaults and arguments;
- :mod:`.groups`: one group timed, sampled and simplified; the groups assembled;
  :mod:`.singles`: robots that interact with nobody, timed alone;
- :mod:`.limits`: the plan held within the joint limits;
- :mod:`.verification`: the clearance ledger over rounds, which robots to re-check, the
  repair of a failed round (merge groups, tighten robots);
- :mod:`.report`: :class:`PostprocessReport` and :class:`TimedPath`.

Each name below loads its module on first use, so importing one module of this package
(e.g. :mod:`.simplify`) does not load the others.

Units: mm, degrees, seconds, plan steps.
"""
from __future__ import annotations

from rfp_twin.models.lazy import lazy_exports

_LAZY = {
    **dict.fromkeys(("ALIGNMENTS", "DEFAULT_BUDGET_MM", "DEFAULT_INTERACTION_MM",
                     "DEFAULT_MAX_POINTS", "DEFAULT_PRESIMPLIFY_DEG", "DEFAULT_TOLERANCE_DEG",
                     "Verifier", "postprocess"), "rfp_twin.planners.postprocess.pipeline"),
    **dict.fromkeys(("PostprocessReport", "TimedPath"), "rfp_twin.planners.postprocess.report"),
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
