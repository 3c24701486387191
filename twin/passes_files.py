"""The folder a passes run writes (``rfp-twin plan --catalogue ... --passes K``), atomically.

Files
-----
summary.json   the command, the catalogue, one row per pass (assigned, kept, rounds,
               completeness of the pass and cumulative by priority, the reconfiguration's
               firmware-ready time, how it was made, the 2D check) and the final completeness
passes.csv     the same rows, one line per pass
observed.csv   target_id, pass, robot_id: each exposure of a science target (one row per
               target and pass; a target needing n exposures has up to n rows)
passN/         a run folder per pass (:mod:`rfp_twin.twin.run_dir`): its
               ``trajectories.json`` is the pass's reconfiguration, from the fold (pass 1) or
               from the previous pass's poses; ``trajectories_to_fold.json`` the same motion
               played backwards; ``assignment.csv`` the pass's assignment

The whole folder is assembled under a temporary name and renamed into place when complete
(:func:`rfp_twin.models.files.atomic_folder`).
"""
from __future__ import annotations

import csv
import io
import json
import sys
from pathlib import Path

import numpy as np

from rfp_twin.models.catalogue import Catalogue
from rfp_twin.models.files import atomic_folder
from rfp_twin.twin.assignment_files import assignment_csv
from rfp_twin.twin.passes import VIA_FOLD, Pass
from rfp_twin.twin.run_dir import check_output_folder, write_run

SUMMARY = "summary.json"
PASSES_CSV = "passes.csv"
OBSERVED_CSV = "observed.csv"
#: passes.csv columns (keys of :meth:`rfp_twin.twin.passes.Pass.row`).
COLUMNS = ("pass", "start", "motion", "available_science", "assigned", "kept",
           "observed_science", "completed_science", "lost", "rounds", "completeness",
           "cumulative", "cumulative_within_reach", "reconfiguration_s", "via_fold_s",
           "check2d_ok")


def pass_folder(k: int) -> str:
    return f"pass{k}"


def _json(obj) -> str:
    def default(v):
        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, np.ndarray):
            return v.tolist()
        raise TypeError(f"not JSON serialisable: {type(v).__name__}")
    return json.dumps(obj, indent=2, default=default)


def passes_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow(["" if r.get(c) is None else (f"{r[c]:.6g}" if isinstance(r[c], float) else r[c])
                    for c in COLUMNS])
    return buf.getvalue()


def observed_csv(catalogue: Catalogue, done: list[Pass]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["target_id", "pass", "robot_id"])
    for p in done:
        a = p.run.assignment
        robot_of = {int(t): int(r) for t, r in zip(a.target_ids, a.robot_ids) if t >= 0}
        for t in p.observed:
            w.writerow([int(t), p.index, robot_of[int(t)]])
    return buf.getvalue()


def write_passes(out: Path, catalogue: Catalogue, done: list[Pass], summary: dict, *,
                 layout: str = "", overwrite: bool = False) -> Path:
    """Write the passes folder at ``out`` (module docstring); ``summary`` is
    :func:`rfp_twin.twin.passes.passes_summary`'s, to which the command is added."""
    out = Path(out)
    check_output_folder(out, overwrite)
    summary = {"command": " ".join(["rfp-twin"] + sys.argv[1:]), **summary}
    with atomic_folder(out) as tmp:
        for p, row in zip(done, summary["passes"]):
            rc = p.motion.reconfiguration
            s = p.motion.summary(layout=layout)
            s.update({"pass": row, "assignment": p.run.summary(p.run_catalogue)})
            if p.mode == VIA_FOLD:
                s["trajectories"] = ("firmware-ready: the previous pass's unfold played "
                                     "backwards, then this pass's unfold")
            generic = not any(c in rc.layout.extra for c in ("boss_x_mm", "apogee_x_mm"))
            m = p.motion
            write_run(tmp / pass_folder(p.index), spec=rc.spec, layout=rc.layout, plan=m.plan,
                      trajectory=m.trajectory, summary=s, check2d=s["check2d"],
                      extra={"assignment.csv": assignment_csv(p.run.assignment,
                                                              p.run_catalogue, generic)})
        (tmp / SUMMARY).write_text(_json(summary), encoding="utf-8")
        (tmp / PASSES_CSV).write_text(passes_csv(summary["passes"]), encoding="utf-8")
        (tmp / OBSERVED_CSV).write_text(observed_csv(catalogue, done), encoding="utf-8")
    return out
