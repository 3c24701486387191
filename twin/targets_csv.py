"""Targets from a CSV file: one row per robot (robots left out are parked), angles or fiber
positions.

Columns: ``robot_id`` and one of

- ``alpha_deg,beta_deg``: model angles;
- ``x_mm,y_mm``: a fiber's position in the layout's (planning) frame;
- ``x_wok_mm,y_wok_mm``: a fiber's position in the wok frame, as astronomers give it
  (calibrated instruments only; :func:`rfp_twin.models.instrument.wok_to_plane`).

Positions are solved right-armed with each robot's own alpha arm and fiber
(:func:`rfp_twin.models.kinematics.inverse_fiber`). An optional ``fiber`` column names the
fiber of each row (``metrology``, ``boss``, ``apogee``); without it a layout that carries
fibers uses the metrology fiber and other layouts the spec's fiber (``beta_length_mm``).
A robot has at most one row; a robot the file leaves out gets its parking pose (the
spec's fold, turned into the robot's travel range), which the planner treats as its
target, as a real configuration leaves robots without a target. A file that names a
robot twice, names an unknown robot, holds NaN, names a fiber the robot does not carry or
a position out of its reach is refused with the file, line and field.
"""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from rfp_twin.models.array import ArrayGeometry
from rfp_twin.models.errors import TargetError
from rfp_twin.models.geometry.dimensions import SDSS_V_DEFAULTS
from rfp_twin.models.kinematics import inverse, inverse_fiber
from rfp_twin.models.layout.columns import FIBER_COLUMNS, FIBERS, fit_to_limits, robot_fibers
from rfp_twin.planners.assignment import parking_angles

ANGLE_COLUMNS = ("alpha_deg", "beta_deg")
XY_COLUMNS = ("x_mm", "y_mm")
WOK_COLUMNS = ("x_wok_mm", "y_wok_mm")
#: Nominal SDSS-V fibers in the beta-arm frame, mm (coordio), for layouts without fiber columns.
NOMINAL_FIBERS = {name: (x, y) for name, x, y in SDSS_V_DEFAULTS["fibers"]}


def read_rows(path: Path, noun: str) -> list[dict]:
    """The rows of CSV file ``path`` as dicts; TargetError when it is missing (``noun``:
    what the file holds, e.g. "target")."""
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            return list(csv.DictReader(fh))
    except FileNotFoundError:
        raise TargetError(f"{path}: {noun}s file not found") from None


def robot_values(path: Path, rows: list[dict], geom: ArrayGeometry, columns: tuple[str, ...],
                 noun: str) -> tuple[np.ndarray, np.ndarray]:
    """``(values (n_robots, len(columns)), line (n_robots,))`` in layout order from ``rows``
    (one per robot at most: ``robot_id`` and the numbers of ``columns``); a robot without
    a row has NaN values and line 0. TargetError naming the file line for a bad number, an
    unknown robot, a second row or NaN/inf (``noun``: what a row holds)."""
    index = {int(r): k for k, r in enumerate(geom.robot_ids)}
    vals = np.full((geom.n_robots, len(columns)), np.nan)
    line_of = np.zeros(geom.n_robots, dtype=np.int64)
    for line, row in enumerate(rows, start=2):
        try:
            rid = int(row["robot_id"])
            v = [float(row[k]) for k in columns]
        except (TypeError, ValueError):
            raise TargetError(f"{path}:{line}: robot_id must be an integer and "
                              f"{', '.join(columns)} numbers") from None
        if rid not in index:
            raise TargetError(f"{path}:{line}: unknown robot id {rid}; allowed: the robots of "
                              f"layout {geom.layout.name!r} (ids {int(geom.robot_ids.min())}.."
                              f"{int(geom.robot_ids.max())})")
        if line_of[index[rid]]:
            raise TargetError(f"{path}:{line}: robot {rid} has a second {noun} row (first on "
                              f"line {int(line_of[index[rid]])}); allowed: one row per robot")
        if not np.all(np.isfinite(v)):
            raise TargetError(f"{path}:{line}: robot {rid}: NaN/inf {noun}; allowed: finite "
                              "numbers")
        vals[index[rid]] = v
        line_of[index[rid]] = line
    return vals, line_of


def read_targets_csv(path: str | Path, geom: ArrayGeometry) -> np.ndarray:
    """Targets ``(n_robots, 2)`` deg in layout order from a CSV file (module docstring)."""
    path = Path(path)
    spec = geom.spec
    rows = read_rows(path, "target")
    cols = set(rows[0]) if rows else set()
    if not rows:
        raise TargetError(f"{path}: no target rows")
    # angles win over positions when a file has both (an assignment.csv carries both)
    by_angles = set(ANGLE_COLUMNS) <= cols
    by_wok = set(WOK_COLUMNS) <= cols and not by_angles
    by_xy = (set(XY_COLUMNS) <= cols or by_wok) and not by_angles
    if "robot_id" not in cols or not (by_angles or by_xy):
        raise TargetError(f"{path}: columns {sorted(cols)}; allowed: robot_id with alpha_deg,beta_deg "
                          "or x_mm,y_mm or x_wok_mm,y_wok_mm")
    if by_wok and "hole_id" not in geom.layout.extra:
        raise TargetError(f"{path}: columns x_wok_mm,y_wok_mm on layout {geom.layout.name!r}; "
                          "allowed: wok positions on a calibrated instrument (sdss-v-apo, "
                          "sdss-v-lco, sdss-v-curved, a calibration folder), else x_mm,y_mm")
    keys = ANGLE_COLUMNS if by_angles else (WOK_COLUMNS if by_wok else XY_COLUMNS)
    vals, line_of = robot_values(path, rows, geom, keys, "target")
    fiber_of = np.full(geom.n_robots, "", dtype=object)
    index = {int(r): k for k, r in enumerate(geom.robot_ids)}
    for line, row in enumerate(rows, start=2):
        fiber = (row.get("fiber") or "").strip().lower()
        if fiber and fiber not in FIBERS:
            raise TargetError(f"{path}:{line}: robot {int(row['robot_id'])}: field 'fiber' = "
                              f"{row['fiber']!r}; allowed: {', '.join(FIBERS)}")
        fiber_of[index[int(row["robot_id"])]] = fiber
    missing = np.isnan(vals[:, 0])
    if not by_xy:
        vals[missing] = parking_angles(geom)[missing]
        return vals
    named = ~missing
    if by_wok:
        from rfp_twin.models.instrument import wok_to_plane
        vals = wok_to_plane(vals)
    has_fibers = any(c in geom.layout.extra for c in FIBER_COLUMNS["metrology"])
    rows = np.flatnonzero(named)
    if not has_fibers and not np.any(fiber_of != ""):
        solved = inverse(geom.base_xy[rows], vals[rows], spec.alpha_length_mm,
                         spec.beta_length_mm, right_arm=True, ids=geom.robot_ids[rows])
    else:
        solved = _solve_fibers(path, geom, vals, fiber_of, line_of, rows)
    angles = parking_angles(geom)
    angles[rows] = _into_limits(path, geom, solved, line_of, rows)
    return angles


def _into_limits(path: Path, geom: ArrayGeometry, angles: np.ndarray,
                 line_of: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``angles`` (r, 2) deg of robots ``rows`` (r,) with alpha turned into each robot's
    travel range; a pose whose beta falls outside the robot's range (encoder offsets shift
    it) is out of its reach: TargetError naming the file line, the robot and the range."""
    fitted, inside = fit_to_limits(angles, geom.limits[rows])
    if not inside.all():
        r = int(np.flatnonzero(~inside)[0])
        k = int(rows[r])
        lo, hi = geom.limits[k, 2:4]
        raise TargetError(f"{path}:{int(line_of[k])}: robot {int(geom.robot_ids[k])}: the target "
                          f"needs beta = {fitted[r, 1]:.4f} deg; allowed: [{lo:g}, {hi:g}] deg "
                          "(its travel range in model angles, shifted by its encoder offsets)")
    return fitted


def _solve_fibers(path: Path, geom: ArrayGeometry, xy: np.ndarray, fiber_of: np.ndarray,
                  line_of: np.ndarray, named: np.ndarray) -> np.ndarray:
    """Model angles (r, 2) deg of robots ``named`` (r,) putting each row's fiber (metrology
    where blank) on ``xy`` (n, 2) mm, with each robot's own alpha arm and fibers; errors
    name the file line."""
    fibers = robot_fibers(geom.layout, NOMINAL_FIBERS)
    out = np.empty_like(xy)
    chosen = np.zeros(xy.shape[0], dtype=bool)
    chosen[named] = True
    for f, fiber in enumerate(FIBERS):
        rows = np.flatnonzero(chosen & ((fiber_of == fiber)
                                        | ((fiber_of == "") & (fiber == "metrology"))))
        if rows.size == 0:
            continue
        try:
            out[rows] = inverse_fiber(geom.base_xy[rows], xy[rows], geom.alpha_len[rows],
                                      fibers[rows, f], ids=geom.robot_ids[rows], fiber=fiber)
        except TargetError as exc:
            k = rows[getattr(exc, "index", 0)]
            raise TargetError(f"{path}:{int(line_of[k])}: field 'fiber' = {fiber!r}: {exc}") from None
    return out[named]
