"""An assignment on disk: ``assignment.csv`` and ``report.json`` in one folder, atomically.

``assignment.csv`` has one row per robot (layout order): ``robot_id``, ``target_id``
(blank when parked), ``alpha_deg``, ``beta_deg`` (model angles: the planner's targets;
``rfp-twin plan --targets assignment.csv`` plans them), ``kind`` (science / sky /
standard / parked), ``arm`` (right / left / parked), ``robot_fiber`` (boss / apogee / the
generic fiber / parked), ``x_mm``, ``y_mm`` (the target in the planning frame, blank
when parked) and ``priority``. ``report.json`` holds the figures of
:func:`assignment_report`.
"""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from rfp_twin.models.catalogue import KINDS
from rfp_twin.models.files import atomic_folder
from rfp_twin.twin.run_dir import check_output_folder

ASSIGNMENT_CSV = "assignment.csv"
REPORT_JSON = "report.json"
ARM_NAMES = {0: "right", 1: "left", -1: "parked"}


def assignment_csv(assignment, catalogue, generic_fiber: bool) -> str:
    """The text of ``assignment.csv`` (module docstring)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["robot_id", "target_id", "alpha_deg", "beta_deg", "kind", "arm", "robot_fiber",
                "x_mm", "y_mm", "priority"])
    slots = ("fiber", "fiber") if generic_fiber else ("boss", "apogee")
    for i, rid in enumerate(assignment.robot_ids.tolist()):
        t = int(assignment.target[i])
        a, b = assignment.angles[i]
        if t < 0:
            w.writerow([rid, "", f"{a:.6f}", f"{b:.6f}", "parked", "parked", "parked", "", "",
                        ""])
            continue
        x, y = catalogue.xy[t]
        w.writerow([rid, int(catalogue.ids[t]), f"{a:.6f}", f"{b:.6f}",
                    KINDS[int(catalogue.kind[t])], ARM_NAMES[int(assignment.arm[i])],
                    slots[int(assignment.slot[i])], f"{x:.4f}", f"{y:.4f}",
                    f"{float(catalogue.priority[t]):g}"])
    return buf.getvalue()


def assignment_report(assignment, catalogue, *, settings, layout_name: str, buffer_mm: float,
                      margin_mm: float, telescope: str | None) -> dict:
    """The figures of an assignment as a JSON-ready dict."""
    counts = assignment.counts()
    available = catalogue.counts()
    science = catalogue.kind == 0
    taken = np.zeros(catalogue.n_targets, dtype=bool)
    taken[assignment.target[assignment.target >= 0]] = True
    return {
        "layout": layout_name, "n_robots": int(assignment.robot_ids.size),
        "buffer_mm": float(buffer_mm), "margin_mm": float(margin_mm),
        "telescope": telescope,
        "catalogue": {"source": catalogue.source, "n_targets": catalogue.n_targets,
                      **{f"n_{k}": v for k, v in available.items()}},
        "solver": assignment.solver, "status": assignment.status,
        "objective": assignment.objective, "bound": assignment.bound, "gap": assignment.gap,
        "assigned": assignment.n_assigned, "counts": counts,
        "science_completeness": (float(taken[science].sum() / science.sum())
                                 if science.any() else None),
        "settings": {"solver": settings.solver, "time_limit_s": settings.time_limit_s,
                     "arms": list(settings.arms), "quotas": vars(settings.quotas)},
        "stats": assignment.stats,
    }


def write_assignment(out: Path, files: dict[str, str], overwrite: bool = False) -> Path:
    """Write ``files`` {name: text} into folder ``out`` atomically (a temp folder renamed;
    an existing ``out`` only with ``overwrite``)."""
    out = Path(out)
    check_output_folder(out, overwrite)
    with atomic_folder(out) as tmp:
        for name, text in files.items():
            (tmp / name).write_text(text, encoding="utf-8")
    return out


def report_json(report: dict) -> str:
    def default(obj):
        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        raise TypeError(type(obj).__name__)
    return json.dumps(report, indent=2, default=default)
