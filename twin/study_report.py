"""Study reports (the old import path): see :mod:`twin.studies.report`.

``from twin.study_report import write_report`` keeps working for callers written before
the studies became the :mod:`twin.studies` package.
"""
from __future__ import annotations

from twin.studies.figures import FIGURES
from twin.studies.groups import Group, load_groups
from twin.studies.paper import PAPER_FIG10, PAPER_FIG11, PAPER_FOLD, PAPER_TABLE3
from twin.studies.report import Report, write_report

__all__ = ["Report", "write_report", "load_groups", "Group", "PAPER_FIG10", "PAPER_FIG11",
           "PAPER_FOLD", "PAPER_TABLE3", "FIGURES"]
