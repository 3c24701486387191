"""An instrument's own trajectory file (jaeger / kaiju JSON) read against a layout.

SDSS-V's control software sends, and saves, every trajectory as JSON in one of two forms:

* the bare form ``{"<positioner id>": {"alpha": [[deg, s], ...], "beta": [[deg, s], ...]}}``
  (kaiju's ``getPathPair`` output, our ``trajectories*.json``);
* jaeger's trajectory dump: an object whose ``"trajectory"`` key holds the bare form, beside
  other keys (``start_time``, ``success``, ``extra``, ...) and ``"initial_positions"``:
  ``{"<positioner id>": [alpha, beta]}``, the encoder angles every robot reported before
  the move (``null`` for a robot that did not answer).

A positioner's entry may carry more keys than ``alpha`` and ``beta``; they are ignored.
Angles are ENCODER angles by default (what the firmware is sent): each robot's model angle
is ``encoder + offset`` with the ``alpha_offset_deg`` / ``beta_offset_deg`` of its layout
row (:mod:`rfp_twin.models.layout.columns`; a layout without offsets: model = encoder).
``angles="model"`` reads the file as model angles (our ``trajectories.json``).

Robots of the layout that the trajectory does not move are held at their initial
positions when the file gives them (a jaeger dump), else they are absent from the
returned trajectory (the checkers then leave them out and say so).

Every bad input raises :class:`rfp_twin.models.errors.TrajectoryError` with one line
naming the file, the positioner and the field, and what is allowed: malformed JSON, a
positioner id that is not a robot of the layout (or ids of another instrument), a missing
axis, a point that is not ``[deg, s]``, NaN / infinity, time going backwards, an angle
jump at one instant, an angle outside the robot's travel range.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rfp_twin.models.errors import TrajectoryError
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import robot_column, robot_joint_limits
from rfp_twin.models.robot import RobotSpec
from rfp_twin.models.trajectory import AXES, Trajectory

#: Frames a file's angles may be read in.
ANGLE_FRAMES = ("encoder", "model")
#: jaeger's dump keys: the trajectory, and the robots' encoder angles before the move.
DUMP_TRAJECTORY_KEY = "trajectory"
DUMP_INITIAL_KEY = "initial_positions"


@dataclass(frozen=True)
class TrajectoryFile:
    """A trajectory file read against a layout.

    Attributes
    ----------
    path : Path
    trajectory : Trajectory
        Model angles (deg, s): the moving robots, then the robots held at their initial
        positions (one breakpoint at t = 0).
    angles : str
        ``"encoder"`` or ``"model"``: the frame the file was read in.
    moved_ids : (k,) int64
        Positioners the file moves.
    held_ids : (h,) int64
        Robots of the layout held at their initial positions (jaeger dump).
    absent_ids : (a,) int64
        Robots of the layout neither moved nor held: not in the returned trajectory.
    """

    path: Path
    trajectory: Trajectory
    angles: str
    moved_ids: np.ndarray
    held_ids: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    absent_ids: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))

    def summary(self) -> dict:
        """What was read, for a report: file, frame and robot counts."""
        return {"trajectory_file": str(self.path), "angles": self.angles,
                "n_moved": int(self.moved_ids.size), "n_held": int(self.held_ids.size),
                "absent_ids": [int(v) for v in self.absent_ids]}


def _no_duplicates(pairs: list) -> dict:
    """``object_pairs_hook`` of :func:`json.loads`: a key given twice is an error."""
    out: dict = {}
    for k, v in pairs:
        if k in out:
            raise _DuplicateKey(k)
        out[k] = v
    return out


class _DuplicateKey(ValueError):
    pass


def read_json(path: Path):
    """The parsed JSON of ``path`` (NaN / Infinity literals allowed: checked later)."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise TrajectoryError(f"{path}: file not found; allowed: a trajectory JSON file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise TrajectoryError(f"{path}: cannot be read ({exc}); allowed: a UTF-8 JSON "
                              "file") from None
    try:
        return json.loads(text, object_pairs_hook=_no_duplicates)
    except _DuplicateKey as exc:
        raise TrajectoryError(f"{path}: key {exc.args[0]!r} appears twice; allowed: each "
                              "positioner and key once") from None
    except json.JSONDecodeError as exc:
        raise TrajectoryError(f"{path}: malformed JSON at line {exc.lineno} column "
                              f"{exc.colno}: {exc.msg}; allowed: a JSON object "
                              '{"<positioner id>": {"alpha": [[deg, s], ...], '
                              '"beta": [[deg, s], ...]}}') from None


def _entries(path: Path, data) -> tuple[dict, dict]:
    """``(trajectory entries, initial positions)`` of a bare or jaeger-dump object."""
    shape = ('an object {"<positioner id>": {"alpha": [[deg, s], ...], "beta": [[deg, s], '
             '...]}} or a jaeger dump with a "trajectory" key')
    if not isinstance(data, dict):
        raise TrajectoryError(f"{path}: top level is a JSON {type(data).__name__}; "
                              f"allowed: {shape}")
    initial: dict = {}
    if DUMP_TRAJECTORY_KEY in data:
        initial = data.get(DUMP_INITIAL_KEY) or {}
        if not isinstance(initial, dict):
            raise TrajectoryError(f"{path}: field '{DUMP_INITIAL_KEY}' is a JSON "
                                  f"{type(initial).__name__}; allowed: an object "
                                  '{"<positioner id>": [alpha, beta]}')
        data = data[DUMP_TRAJECTORY_KEY]
        if not isinstance(data, dict):
            raise TrajectoryError(f"{path}: field '{DUMP_TRAJECTORY_KEY}' is a JSON "
                                  f"{type(data).__name__}; allowed: {shape}")
    if not data:
        raise TrajectoryError(f"{path}: no positioner; allowed: {shape}")
    return data, initial


def _positioner_id(path: Path, key: str) -> int:
    try:
        return int(key)
    except ValueError:
        raise TrajectoryError(f"{path}: key {key!r} is not a positioner id; allowed: integer "
                              "positioner ids (or a jaeger dump with a \"trajectory\" key)") from None


def _axis_points(path: Path, pid: int, name: str, entry) -> tuple[np.ndarray, np.ndarray]:
    """``(times, angles)`` (k,) float64 of one axis of a positioner, checked."""
    where = f"{path}: positioner {pid}"
    if not isinstance(entry, dict):
        raise TrajectoryError(f"{where}: entry is a JSON {type(entry).__name__}; allowed: an "
                              'object {"alpha": [[deg, s], ...], "beta": [[deg, s], ...]}')
    if name not in entry:
        raise TrajectoryError(f"{where}: field '{name}' is missing; allowed: both 'alpha' and "
                              "'beta', each a list of [deg, s] points")
    points = entry[name]
    if not isinstance(points, list) or not points:
        raise TrajectoryError(f"{where}: field '{name}' = {_short(points)}; allowed: a "
                              "non-empty list of [deg, s] points")
    for k, p in enumerate(points):
        if (not isinstance(p, list) or len(p) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in p)):
            raise TrajectoryError(f"{where}: field '{name}' point {k} = {_short(p)}; allowed: "
                                  "[deg, s], two numbers")
    arr = np.asarray(points, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
    if bad.size:
        k = int(bad[0])
        raise TrajectoryError(f"{where}: field '{name}' point {k} = {_short(points[k])}; "
                              "allowed: finite numbers [deg, s]")
    deg, t = arr[:, 0], arr[:, 1]
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise TrajectoryError(f"{where}: field '{name}' time goes backwards at point {k}: "
                              f"{t[k]:g} s after {t[k - 1]:g} s; allowed: non-decreasing times")
    jump = np.flatnonzero((np.diff(t) == 0) & (np.diff(deg) != 0))
    if jump.size:
        k = int(jump[0]) + 1
        raise TrajectoryError(f"{where}: field '{name}' jumps from {deg[k - 1]:g} to "
                              f"{deg[k]:g} deg at t = {t[k]:g} s (point {k}); allowed: a "
                              "later time for a new angle")
    return t, deg


def _short(value) -> str:
    text = json.dumps(value) if not isinstance(value, float) else repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _check_ids(path: Path, ids: np.ndarray, layout: Layout) -> None:
    """Every positioner of the file must be a robot of the layout; a file most of whose
    ids are not is said to be of another instrument (named when a built-in one matches)."""
    robots = np.asarray(layout.robot_ids, dtype=np.int64)
    unknown = ids[~np.isin(ids, robots)]
    if not unknown.size:
        return
    span = f"{robots.size} robots, ids {int(robots.min())}..{int(robots.max())}" if robots.size \
        else "no robot"
    if unknown.size * 2 > ids.size:
        other = _matching_instrument(ids, layout.name)
        hint = (f"its ids are those of {other}" if other
                else "a trajectory of another instrument?")
        raise TrajectoryError(f"{path}: {unknown.size} of its {ids.size} positioner ids (e.g. "
                              f"{int(unknown[0])}) are not robots of {layout.name}: {hint}; "
                              f"allowed: positioners of {layout.name} ({span})")
    raise TrajectoryError(f"{path}: positioner {int(unknown[0])} is not a robot of "
                          f"{layout.name}; allowed: a positioner of {layout.name} ({span})")


def _matching_instrument(ids: np.ndarray, current: str) -> str | None:
    """The built-in instrument (other than ``current``) whose robots include every id."""
    from rfp_twin.models.instrument import INSTRUMENTS, calibration_folder, read_calibration

    for name in INSTRUMENTS:
        if name == current:
            continue
        try:
            robots = read_calibration(calibration_folder(name)).robot_ids
        except Exception:         # a damaged package: no hint, the error still stands
            continue
        if np.isin(ids, robots).all():
            return name
    return None


def angle_offsets_of(layout: Layout) -> np.ndarray:
    """(n_robots, 2) encoder zero offsets (alpha, beta) deg, layout order; zeros when the
    layout carries none (model = encoder + offset)."""
    return np.column_stack([robot_column(layout, "alpha_offset_deg", 0.0),
                            robot_column(layout, "beta_offset_deg", 0.0)])


def read_trajectory_file(path: str | Path, spec: RobotSpec, layout: Layout,
                         angles: str = "encoder") -> TrajectoryFile:
    """Read and check a jaeger / kaiju trajectory file against ``layout``.

    Parameters
    ----------
    path : the JSON file (bare form or jaeger dump, see the module docstring)
    spec : RobotSpec
        Joint limits (the firmware's, encoder deg) of every robot.
    layout : Layout
        The instrument: robot ids, each robot's angle offsets.
    angles : ``"encoder"`` (default: the file holds what the firmware is sent) or
        ``"model"``.

    Returns
    -------
    TrajectoryFile

    Raises
    ------
    TrajectoryError
        One line naming the file, the positioner and the field (module docstring).
    """
    path = Path(path)
    if angles not in ANGLE_FRAMES:
        raise TrajectoryError(f"--angles {angles!r}; allowed: {' | '.join(ANGLE_FRAMES)}")
    entries, initial = _entries(path, read_json(path))
    ids = np.array([_positioner_id(path, k) for k in entries], dtype=np.int64)
    _check_ids(path, ids, layout)

    rows = layout.robot_indices(ids)
    offsets = angle_offsets_of(layout) if angles == "encoder" else np.zeros((layout.n_robots, 2))
    limits = robot_joint_limits(spec, layout)        # model deg
    frame = "encoder" if angles == "encoder" else "model"
    times: tuple[list, list] = ([], [])
    model: tuple[list, list] = ([], [])
    for i, (key, entry) in enumerate(entries.items()):
        pid, r = int(ids[i]), int(rows[i])
        for ax, name in enumerate(AXES):
            t, deg = _axis_points(path, pid, name, entry)
            m = deg + offsets[r, ax]
            lo, hi = limits[r, 2 * ax], limits[r, 2 * ax + 1]
            out = np.flatnonzero((m < lo) | (m > hi))
            if out.size:
                k = int(out[0])
                off = offsets[r, ax]
                raise TrajectoryError(
                    f"{path}: positioner {pid}: field '{name}' = {deg[k]:g} deg ({frame}) at "
                    f"t = {t[k]:g} s (point {k}); allowed: [{lo - off:g}, {hi - off:g}] deg "
                    f"({frame})")
            times[ax].append(t)
            model[ax].append(m)

    held = _held_robots(path, initial, ids, layout, offsets, limits, frame)
    for pid, r, pose in held:
        for ax in range(2):
            times[ax].append(np.zeros(1))
            model[ax].append(np.array([pose[ax]]))
    held_ids = np.array([h[0] for h in held], dtype=np.int64)
    all_ids = np.concatenate([ids, held_ids])
    absent = np.setdiff1d(np.asarray(layout.robot_ids, dtype=np.int64), all_ids)
    traj = Trajectory(all_ids, (tuple(times[0]), tuple(times[1])),
                      (tuple(model[0]), tuple(model[1])))
    return TrajectoryFile(path=path, trajectory=traj, angles=angles, moved_ids=ids,
                          held_ids=held_ids, absent_ids=absent)


def _held_robots(path: Path, initial: dict, moved: np.ndarray, layout: Layout,
                 offsets: np.ndarray, limits: np.ndarray, frame: str) -> list:
    """``[(id, layout row, (alpha, beta) model deg)]`` of layout robots that the dump's
    initial positions place and the trajectory does not move; robots of the initial
    positions that are not in the layout, or with a ``null`` angle, are skipped (jaeger
    lists disabled robots there too)."""
    out = []
    robots = set(np.asarray(layout.robot_ids, dtype=np.int64).tolist())
    moving = set(moved.tolist())
    for key, pose in initial.items():
        pid = _positioner_id(path, key)
        if pid in moving or pid not in robots:
            continue
        if pose is None or (isinstance(pose, list) and any(v is None for v in pose)):
            continue
        if (not isinstance(pose, list) or len(pose) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                           and math.isfinite(v) for v in pose)):
            raise TrajectoryError(f"{path}: positioner {pid}: field '{DUMP_INITIAL_KEY}' = "
                                  f"{_short(pose)}; allowed: [alpha, beta] deg, finite, or null")
        r = int(layout.robot_indices([pid])[0])
        m = (float(pose[0]) + offsets[r, 0], float(pose[1]) + offsets[r, 1])
        for ax, name in enumerate(AXES):
            lo, hi = limits[r, 2 * ax], limits[r, 2 * ax + 1]
            if not lo <= m[ax] <= hi:
                off = offsets[r, ax]
                raise TrajectoryError(
                    f"{path}: positioner {pid}: field '{DUMP_INITIAL_KEY}' {name} = "
                    f"{pose[ax]:g} deg ({frame}); allowed: [{lo - off:g}, {hi - off:g}] deg "
                    f"({frame})")
        out.append((pid, r, m))
    return out
