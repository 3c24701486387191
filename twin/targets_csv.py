"""Targets from a CSV file: one row per robot, angles or fiber positions.

Columns: ``robot_id`` and either ``alpha_deg,beta_deg`` or ``x_mm,y_mm`` (the fiber
position in the focal plane, solved right-armed with inverse kinematics). Every robot
needs exactly one row; a file that names a robot twice, names an unknown robot, leaves
one out or holds NaN is refused with the file, line and field.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.models.kinematics import inverse

ANGLE_COLUMNS = ("alpha_deg", "beta_deg")
XY_COLUMNS = ("x_mm", "y_mm")


def read_targets_csv(path: str | Path, geom: ArrayGeometry) -> np.ndarray:
    """Targets ``(n_robots, 2)`` deg in layout order from a CSV file (module docstring)."""
    path = Path(path)
    spec = geom.spec
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except FileNotFoundError:
        raise TargetError(f"{path}: targets file not found") from None
    if not rows:
        raise TargetError(f"{path}: no target rows")
    cols = set(rows[0])
    by_angles = set(ANGLE_COLUMNS) <= cols
    by_xy = set(XY_COLUMNS) <= cols
    if "robot_id" not in cols or not (by_angles or by_xy):
        raise TargetError(f"{path}: columns {sorted(cols)}; allowed: robot_id with alpha_deg,beta_deg "
                          "or x_mm,y_mm")
    vals = np.full((geom.n_robots, 2), np.nan)
    index = {int(r): k for k, r in enumerate(geom.robot_ids)}
    first_line: dict[int, int] = {}
    keys = ANGLE_COLUMNS if by_angles else XY_COLUMNS
    for line, row in enumerate(rows, start=2):
        try:
            rid = int(row["robot_id"])
            v = [float(row[k]) for k in keys]
        except (TypeError, ValueError):
            raise TargetError(f"{path}:{line}: robot_id must be an integer and {keys} numbers") from None
        if rid not in index:
            raise TargetError(f"{path}:{line}: unknown robot id {rid}; allowed ids: "
                              f"{int(geom.robot_ids.min())}..{int(geom.robot_ids.max())}")
        if rid in first_line:
            raise TargetError(f"{path}:{line}: robot {rid} has a second target row (first on line "
                              f"{first_line[rid]}); allowed: one row per robot")
        first_line[rid] = line
        if not np.all(np.isfinite(v)):
            raise TargetError(f"{path}:{line}: robot {rid}: NaN/inf target; allowed: finite numbers")
        vals[index[rid]] = v
    missing = np.flatnonzero(np.isnan(vals[:, 0]))
    if missing.size:
        raise TargetError(f"{path}: robot {int(geom.robot_ids[missing[0]])} has no target row "
                          f"({missing.size} robot(s) missing)")
    if by_xy:
        vals = inverse(geom.base_xy, vals, spec.alpha_length_mm, spec.beta_length_mm,
                       right_arm=True, ids=geom.robot_ids)
    return vals
