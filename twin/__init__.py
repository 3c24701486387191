"""The running twin: the one pipeline, simulation, rendering, recording, studies, the CLI.

Public API (imported on first use, so that ``rfp-twin --help`` stays fast)::

    from twin import Reconfiguration, PlanOptions
    outcome = Reconfiguration.from_names("sdss-v", buffer_mm=2.0).run(seed=1)
    outcome.write("out/run1")

- :class:`Reconfiguration`, :class:`PlanOptions`, :func:`plan_random` (:mod:`twin.pipeline`):
  targets -> plan -> post-process -> independent 2D check; :class:`Outcome`
  (:mod:`twin.outcome`): summary and run folder; :func:`load_run` (:mod:`twin.run_dir`).
- The MuJoCo twin: :func:`simulate` (:mod:`twin.sim`), :func:`render_run`
  (:mod:`twin.render`), :func:`record_run` (:mod:`twin.record`).
- Studies: :func:`load_study`, :func:`run_study` (:mod:`twin.studies`).
"""
from __future__ import annotations

from models.lazy import lazy_exports

_EXPORTS = {
    "Reconfiguration": "twin.pipeline", "PlanOptions": "twin.pipeline",
    "plan_random": "twin.pipeline", "Outcome": "twin.outcome", "load_run": "twin.run_dir",
    "write_run": "twin.run_dir", "simulate": "twin.sim",
    "render_run": "twin.render", "record_run": "twin.record", "load_study": "twin.studies",
    "run_study": "twin.studies",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
