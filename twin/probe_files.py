"""Files of probe-arm runs (MIRADAS, Sabater et al. 2018): targets CSV in, run folder back.

:func:`read_probe_targets` reads a targets CSV for a probe bench: one row per arm,
``arm`` and either ``theta1_deg,theta2_deg`` (motor angles) or ``x_mm,y_mm`` (the tip,
field centre at the origin); arms left out stay at their start (park). Each pose is
checked against the joint ranges and the ZoA (Eq. 4), each tip against the arm's reach.

:func:`load_probe_run` reads back a run folder written by
:func:`rfp_twin.twin.probe_run.write_probe_run` (``plan.json``, ``summary.json``) as a
:class:`LoadedProbeRun`, which the simulator, the renderer, the recorder and the checks
take like a fresh plan. Bad input raises one line naming the file, line or field.
Units: deg, mm, s.
"""
from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import RfpError, TargetError, TrajectoryError
from rfp_twin.models.kinds.base import MIRADAS_PROBE

#: Files of a probe run folder.
PLAN_JSON = "plan.json"
SUMMARY_JSON = "summary.json"
ANGLE_COLUMNS = ("theta1_deg", "theta2_deg")
XY_COLUMNS = ("x_mm", "y_mm")


def read_probe_targets(path: str | Path, kind, start: np.ndarray) -> np.ndarray:
    """(n_arms, 2) deg: the goal poses of targets CSV ``path`` (see the module docstring);
    tips are turned into the pose reached soonest from ``start`` (n_arms, 2) deg."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise TargetError(f"{path}: cannot read ({exc.strerror}); allowed: a targets CSV "
                          "file") from None
    reader = csv.DictReader(text.splitlines())
    cols = set(reader.fieldnames or ())
    mode = ANGLE_COLUMNS if set(ANGLE_COLUMNS) <= cols else XY_COLUMNS if set(XY_COLUMNS) <= cols \
        else None
    if "arm" not in cols or mode is None:
        raise TargetError(f"{path}: columns {sorted(cols)}; allowed: arm and theta1_deg,"
                          "theta2_deg or x_mm,y_mm")
    goal = np.array(start, dtype=np.float64)
    tips = np.full((kind.n_arms, 2), np.nan)
    seen: set[int] = set()
    for line, row in enumerate(reader, start=2):
        try:
            arm = int(row["arm"])
            values = [float(row[c]) for c in mode]
        except (TypeError, ValueError):
            raise TargetError(f"{path}:{line}: arm {row.get('arm')!r}, {mode[0]} "
                              f"{row.get(mode[0])!r}, {mode[1]} {row.get(mode[1])!r}; allowed: "
                              "an integer arm and two numbers") from None
        if not 0 <= arm < kind.n_arms or arm in seen:
            raise TargetError(f"{path}:{line}: arm {arm}; allowed: each of 0..{kind.n_arms - 1} "
                              "at most once")
        if not np.all(np.isfinite(values)):
            raise TargetError(f"{path}:{line}: arm {arm}: {values}; allowed: finite numbers")
        seen.add(arm)
        if mode == ANGLE_COLUMNS:
            goal[arm] = values
        else:
            tips[arm] = values
    if mode == XY_COLUMNS:
        try:
            goal = kind.poses_for_tips(tips, goal)
        except TargetError as exc:
            raise TargetError(f"{path}: {exc}") from None
    try:
        kind.check_poses(goal, "target")
    except TargetError as exc:
        raise TargetError(f"{path}: {exc}") from None
    return goal


@dataclass
class LoadedProbeRun:
    """A probe run folder read back: the bench and each arm's breakpoints.

    Attributes
    ----------
    kind : ProbeArmKind (the preset the run was planned with, its number of arms)
    breakpoints : {arm: (times (k,) s, configs (k, 2) deg)}
    summary : dict, the run's summary.json
    folder : Path
    """

    kind: object
    breakpoints: dict
    summary: dict
    folder: Path

    @property
    def start(self) -> np.ndarray:
        """(n_arms, 2) deg, every arm's first pose."""
        return np.array([self.breakpoints[i][1][0] for i in range(self.kind.n_arms)])

    @property
    def makespan_s(self) -> float:
        """Arrival of the last arm, s."""
        return max(float(t[-1]) for t, _ in self.breakpoints.values())

    def at(self, t: np.ndarray) -> np.ndarray:
        """(len(t), n_arms, 2) poses at times ``t`` s (held after each arm's end)."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        out = np.empty((t.size, self.kind.n_arms, 2))
        for i, (times, q) in self.breakpoints.items():
            for k in range(2):
                out[:, i, k] = np.interp(t, times, q[:, k])
        return out


def is_probe_run(path: str | Path) -> bool:
    """Is ``path`` a folder holding a probe-arm run (its summary names the kind)?"""
    summary = Path(path) / SUMMARY_JSON
    if not summary.is_file():
        return False
    try:
        return json.loads(summary.read_text(encoding="utf-8")).get("kind") == MIRADAS_PROBE
    except (OSError, ValueError, AttributeError):
        return False


def load_probe_run(folder: str | Path) -> LoadedProbeRun:
    """Read a probe run folder (:func:`rfp_twin.twin.probe_run.write_probe_run`)."""
    from rfp_twin.models.kinds import ProbeArmKind, load_kind

    folder = Path(folder)
    try:
        summary = json.loads((folder / SUMMARY_JSON).read_text(encoding="utf-8"))
        plan = json.loads((folder / PLAN_JSON).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise RfpError(f"{folder}: not a readable probe run ({exc}); allowed: a folder written "
                       "by `rfp-twin plan --preset miradas-probe`") from None
    if summary.get("kind") != MIRADAS_PROBE:
        raise RfpError(f"{folder}/{SUMMARY_JSON}: field 'kind' = {summary.get('kind')!r}; "
                       f"allowed: {MIRADAS_PROBE!r}")
    preset = str(summary.get("preset", "miradas-probe"))
    kind = load_kind(preset.removeprefix("preset "))      # a preset's source reads "preset NAME"
    if len(plan) != kind.n_arms:
        kind = ProbeArmKind(kind.spec.with_overrides(n_arms=len(plan)))
    breakpoints = {}
    for i in range(kind.n_arms):
        try:
            axes = plan[str(i)]
            t1 = np.asarray(axes["theta1"], dtype=np.float64)
            t2 = np.asarray(axes["theta2"], dtype=np.float64)
            if t1.ndim != 2 or t1.shape[1] != 2 or t1.shape != t2.shape or \
                    not np.allclose(t1[:, 1], t2[:, 1]):
                raise ValueError("theta1 and theta2 need the same [[deg, s], ...] times")
        except (KeyError, TypeError, ValueError) as exc:
            raise TrajectoryError(f"{folder}/{PLAN_JSON}: arm {i}: {exc}; allowed: every arm "
                                  "0..n-1 with theta1 and theta2 as [[deg, s], ...]") from None
        breakpoints[i] = (t1[:, 1].copy(), np.column_stack([t1[:, 0], t2[:, 0]]))
    return LoadedProbeRun(kind, breakpoints, summary, folder)
