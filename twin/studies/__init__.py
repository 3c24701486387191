"""Design studies: grids of simulated reconfigurations, run on Dask, stored as Parquet.

Instrument teams choose pitch, arm lengths and collision buffers from thousands of
simulated reconfigurations (Sayres et al. 2021 Sect. 5). One module per job:

- :mod:`~rfp_twin.twin.studies.spec`: the study file's format, :class:`Study`, grid points, trials
- :mod:`~rfp_twin.twin.studies.parse`: study TOML -> validated :class:`Study`; the shipped studies
- :mod:`~rfp_twin.twin.studies.resolve`: one grid point: preset defaults, design axes
  (arm ratio, pitch / reach, rafts), checks
- :mod:`~rfp_twin.twin.studies.coverage`: coverage per design geometry, measured once
- :mod:`~rfp_twin.twin.studies.runner`: one trial -> one row (the :mod:`rfp_twin.twin.pipeline` on a point)
- :mod:`~rfp_twin.twin.studies.cluster`: Dask cluster or scheduler address, batches, the task loop
- :mod:`~rfp_twin.twin.studies.store`: Parquet rows, the writer lock, the resume scan, the
  consolidation of a finished study into ``results/trials.parquet``
- :mod:`~rfp_twin.twin.studies.run`: :func:`run_study`, resume and summary
- :mod:`~rfp_twin.twin.studies.report` (with ``groups``, ``figures``, ``paper``): markdown and
  figures in the style of Sayres 2021 Figs. 10-18
- :mod:`~rfp_twin.twin.studies.frontier` (with ``frontier_plot``): design studies'
  coverage x feasibility table, Pareto frontiers and figure
- :mod:`~rfp_twin.twin.studies.yield_options`: the yield axes (catalogue kind, density,
  exposure), declared once; :mod:`~rfp_twin.twin.studies.yield_trial`: a catalogue trial
  through the plannable loop -> completeness, targets per pointing and per hour;
  :mod:`~rfp_twin.twin.studies.yield_report` (with ``yield_plot``): the yield table,
  completeness against density per design, the yield frontier

Example::

    summary = run_study(load_study("sim1-small"), "out/studies/sim1-small", workers=2)
    table = read_results("out/studies/sim1-small")   # one pyarrow row per trial
    # a finished study is one file: pyarrow.parquet.read_table("out/studies/sim1-small/results")
"""
from __future__ import annotations

from rfp_twin.twin.studies.cluster import machine_workers
from rfp_twin.twin.studies.coverage import COVERAGE_FILE, read_coverage, update_coverage
from rfp_twin.twin.studies.parse import list_studies, load_study, parse_study, study_path
from rfp_twin.twin.studies.run import RunSummary, run_study
from rfp_twin.twin.studies.runner import run_trial
from rfp_twin.twin.studies.spec import (GRID_KEYS, PARAM_COLUMNS, STUDY_KEYS, Study, StudyError,
                               StudyPoint, Trial)
from rfp_twin.twin.studies.yield_options import YieldOptions
from rfp_twin.twin.studies.yield_report import YieldPoint, yield_points
from rfp_twin.twin.studies.store import (COMPACT_PREFIX, CONSOLIDATED, RESULTS, SCHEMA, STUDY_COPY,
                                         compact_results, consolidate_results, default_out_dir,
                                         done_keys, read_results, results_dir, write_row)

__all__ = [
    "StudyError", "Study", "StudyPoint", "Trial", "RunSummary", "SCHEMA", "GRID_KEYS",
    "STUDY_KEYS", "list_studies", "study_path", "load_study", "parse_study", "run_trial",
    "run_study", "read_results", "done_keys", "write_row", "compact_results",
    "results_dir", "default_out_dir", "machine_workers", "PARAM_COLUMNS", "RESULTS",
    "STUDY_COPY", "COMPACT_PREFIX", "CONSOLIDATED", "consolidate_results", "COVERAGE_FILE",
    "read_coverage", "update_coverage", "YieldOptions", "YieldPoint", "yield_points",
]
