"""The running twin: the one pipeline, simulation, rendering, recording, studies, the CLI.

Public API (imported on first use, so that ``rfp-twin --help`` stays fast)::

    from rfp_twin.twin import Reconfiguration, PlanOptions
    outcome = Reconfiguration.from_names("sdss-v", buffer_mm=2.0).run(seed=1)
    outcome.write("out/run1")

- :class:`Reconfiguration`, :class:`PlanOptions`, :func:`plan_random` (:mod:`rfp_twin.twin.pipeline`):
  targets -> plan -> post-process -> independent 2D check; :class:`Outcome`
  (:mod:`rfp_twin.twin.outcome`): summary and run folder; :func:`load_run` (:mod:`rfp_twin.twin.run_dir`).
- The MuJoCo twin: :func:`simulate` (:mod:`rfp_twin.twin.sim`), :func:`render_run`
  (:mod:`rfp_twin.twin.render`), :func:`record_run` (:mod:`rfp_twin.twin.record`).
- Studies: :func:`load_study`, :func:`run_study` (:mod:`rfp_twin.twin.studies`).
"""
from __future__ import annotations

from rfp_twin.models.lazy import lazy_exports

_EXPORTS = {
    "Reconfiguration": "rfp_twin.twin.pipeline", "PlanOptions": "rfp_twin.twin.pipeline",
    "plan_random": "rfp_twin.twin.pipeline", "Outcome": "rfp_twin.twin.outcome", "load_run": "rfp_twin.twin.run_dir",
    "write_run": "rfp_twin.twin.run_dir", "simulate": "rfp_twin.twin.sim",
    "render_run": "rfp_twin.twin.render", "record_run": "rfp_twin.twin.record", "load_study": "rfp_twin.twin.studies",
    "run_study": "rfp_twin.twin.studies",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
