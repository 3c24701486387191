"""Layout: where the robot and fiducial bases sit on the focal plane.

Units: millimetres. A layout holds ``n`` positions: integer ids ``(n,)``, base
coordinates ``xy`` ``(n, 2)`` in mm, and a kind ``(n,)`` per position, ``'robot'`` or
``'fiducial'``. Robot-only arrays (``robot_ids``, ``robot_xy``) and fiducial-only arrays
(``fiducial_ids``, ``fiducial_xy``) keep the layout order; a "robot index" is an index
into the robot arrays and a "fiducial index" one into the fiducial arrays.

Constructors: :meth:`Layout.hex_grid` / :meth:`Layout.hex_grid_positions` (centred hex
grids, rows along +x like the SDSS-V focal plane), :meth:`Layout.sdss_v_grid` (the
547-position all-robot grid of Sayres 2021), :meth:`Layout.sdss_v_fps` (the real SDSS-V
layout, ``models/data/sdss-v-fps.csv``) and :meth:`Layout.from_csv`.

Neighbour queries (Sayres 2021 Eq. 4): two robots can collide only if their bases are
within ``reach = 2 (l_alpha + l_beta + buffer)``; :meth:`Layout.neighbour_pairs`,
:meth:`Layout.neighbour_csr` and :meth:`Layout.robot_fiducial_csr` list them.

A malformed layout raises :class:`models.errors.LayoutError`; an id the layout does not
contain raises :class:`models.errors.UnknownRobotError`. Messages are one line and name
the file/line, field and the allowed values.
"""
from __future__ import annotations

import csv
import math
import os
import tempfile
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from models.errors import LayoutError, UnknownRobotError

#: Allowed values of the ``kind`` column.
KINDS = ("robot", "fiducial")
#: Columns every layout CSV must have, in the order :meth:`Layout.to_csv` writes them.
REQUIRED_COLUMNS = ("id", "x_mm", "y_mm", "kind")
#: Rings of the Sayres 2021 all-robot grid (1 + 3*13*14 = 547 positions).
SDSS_V_RINGS = 13
#: Tolerance added to neighbour reaches so that ``distance == reach`` counts, mm.
REACH_TOL_MM = 1e-9
_SQRT3_2 = math.sqrt(3.0) / 2.0


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def hex_count(n_rings: int) -> int:
    """Positions of a centred hex grid with ``n_rings`` rings: ``1 + 3 r (r + 1)``."""
    return 1 + 3 * n_rings * (n_rings + 1)


def hex_rings(n_positions: int) -> int | None:
    """Rings of a centred hex grid with ``n_positions`` positions, or None if none fits."""
    if n_positions < 1:
        return None
    r = int(round((math.sqrt(12 * n_positions - 3) - 3) / 6))
    return r if hex_count(r) == n_positions else None


def hex_axial(n_rings: int) -> np.ndarray:
    """Axial lattice coordinates ``(q, r)`` of a centred hex grid, ``(n, 2)`` int64.

    Sorted by row ``r`` then ``q`` (i.e. by y then x of :func:`hex_xy`).
    """
    qs, rs = np.meshgrid(np.arange(-n_rings, n_rings + 1), np.arange(-n_rings, n_rings + 1))
    q, r = qs.ravel(), rs.ravel()
    keep = np.abs(q + r) <= n_rings
    qr = np.stack([q[keep], r[keep]], axis=1).astype(np.int64)
    return qr[np.lexsort((qr[:, 0], qr[:, 1]))]


def hex_xy(qr: np.ndarray, pitch_mm: float) -> np.ndarray:
    """Base coordinates, mm, ``(n, 2)``, of axial coordinates ``(n, 2)``.

    Lattice vectors ``(pitch, 0)`` and ``(pitch/2, pitch*sqrt(3)/2)``: rows run along +x.
    """
    q, r = qr[:, 0].astype(np.float64), qr[:, 1].astype(np.float64)
    return np.stack([(q + 0.5 * r) * pitch_mm, r * _SQRT3_2 * pitch_mm], axis=1)


def _as_ids(ids, where: str) -> np.ndarray:
    """``ids`` as a flat int64 array; LayoutError if a value is not an integer."""
    arr = np.asarray(ids).reshape(-1)
    if arr.dtype.kind in "iu":
        return arr.astype(np.int64)
    try:
        as_float = arr.astype(np.float64)
    except (TypeError, ValueError):
        as_float = np.full(arr.shape, np.nan)
    bad = np.flatnonzero(~np.isfinite(as_float) | (as_float != np.round(as_float)))
    if len(bad):
        raise LayoutError(f"{where}: field 'id' = {arr[bad[0]].item()!r} is not an integer; "
                          f"allowed: unique integer ids")
    return as_float.astype(np.int64)


def _as_xy(xy, where: str) -> np.ndarray:
    """``xy`` as an (n, 2) float64 array; LayoutError on any other shape."""
    arr = np.array(xy, dtype=np.float64)
    if arr.size == 0:
        return arr.reshape(0, 2)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise LayoutError(f"{where}: field 'xy' has shape {arr.shape}; allowed: (n, 2) mm")
    return arr


def _check_positive(name: str, value, where: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v > 0):
        raise LayoutError(f"{where}: field '{name}' = {value!r}; allowed: a finite number > 0 mm")
    return v


def _check_reach(reach_mm) -> float:
    try:
        v = float(reach_mm)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v >= 0):
        raise LayoutError(f"field 'reach_mm' = {reach_mm!r}; allowed: a finite number >= 0 mm")
    return v


def _closest_violation(xy: np.ndarray, min_separation_mm: float) -> tuple[int, int, float] | None:
    """The closest pair ``(i, j, distance)`` of bases nearer than the minimum, or None."""
    if min_separation_mm <= 0 or len(xy) < 2:
        return None
    pairs = cKDTree(xy).query_pairs(r=min_separation_mm, output_type="ndarray")
    if len(pairs) == 0:
        return None
    d = np.hypot(*(xy[pairs[:, 0]] - xy[pairs[:, 1]]).T)
    k = int(np.argmin(d))
    if d[k] >= min_separation_mm:
        return None
    i, j = sorted((int(pairs[k, 0]), int(pairs[k, 1])))
    return i, j, float(d[k])


def _csr_from_lists(lists, n_rows: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR ``(ptr (n_rows+1,), idx)`` int64 from one sorted index list per row."""
    lengths = np.fromiter((len(x) for x in lists), dtype=np.int64, count=n_rows)
    ptr = np.zeros(n_rows + 1, dtype=np.int64)
    np.cumsum(lengths, out=ptr[1:])
    idx = np.fromiter((j for x in lists for j in sorted(x)), dtype=np.int64, count=int(ptr[-1]))
    return ptr, idx


@dataclass(frozen=True, eq=False)
class Layout:
    """Positions of robots and fiducials on the focal plane.

    Attributes
    ----------
    ids : (n,) int64
        Unique position ids.
    xy : (n, 2) float64
        Base centres, mm.
    kinds : (n,) object
        Python str ``'robot'`` or ``'fiducial'`` (object dtype, so no truncation).
    name : str
        Label used in messages.
    extra : dict[str, (n,) ndarray]
        Other per-position columns (kept verbatim as strings when read from CSV).

    The arrays are made read-only. Construction checks shapes, unique ids, finite
    coordinates and kinds; :meth:`validate` adds the base-separation check.
    """

    ids: np.ndarray
    xy: np.ndarray
    kinds: np.ndarray
    name: str = "layout"
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "ids", _readonly(_as_ids(self.ids, self.name)))
        set_(self, "xy", _readonly(_as_xy(self.xy, self.name)))
        set_(self, "kinds", _readonly(np.array([str(k) for k in np.ravel(self.kinds)],
                                                dtype=object)))
        set_(self, "extra", {str(k): _readonly(np.array(v).reshape(-1))
                             for k, v in self.extra.items()})
        self._check_structure()

    # -- validation ---------------------------------------------------------
    def _check_structure(self) -> None:
        n, where = len(self.ids), self.name
        if n == 0:
            raise LayoutError(f"{where}: empty layout; allowed: at least one position")
        for label, arr in (("xy", self.xy), ("kinds", self.kinds), *self.extra.items()):
            if len(arr) != n:
                raise LayoutError(f"{where}: field '{label}' has {len(arr)} rows; "
                                  f"allowed: {n} (one per id)")
        uniq, counts = np.unique(self.ids, return_counts=True)
        if (counts > 1).any():
            raise LayoutError(f"{where}: field 'id' = {int(uniq[counts > 1][0])} is a "
                              f"duplicate id; allowed: unique integer ids")
        bad = np.flatnonzero(~np.isfinite(self.xy).all(axis=1))
        if len(bad):
            raise LayoutError(f"{where}: id {int(self.ids[bad[0]])} has coordinates "
                              f"{self.xy[bad[0]].tolist()}; allowed: finite numbers in mm "
                              f"(no NaN/inf)")
        unknown = np.flatnonzero(~np.isin(self.kinds, KINDS))
        if len(unknown):
            raise LayoutError(f"{where}: id {int(self.ids[unknown[0]])} field 'kind' = "
                              f"{str(self.kinds[unknown[0]])!r} is an unknown kind; "
                              f"allowed: {', '.join(KINDS)}")

    def validate(self, min_separation_mm: float = 1.0) -> Layout:
        """Check the layout; bases must be at least ``min_separation_mm`` mm apart.

        Structure (shapes, unique ids, finite xy, kinds) is checked at construction;
        this adds the overlap check (skipped when ``min_separation_mm <= 0``).

        Returns
        -------
        Layout
            ``self``, for chaining.

        Raises
        ------
        LayoutError
            Naming both ids and their distance.
        """
        self._check_structure()
        hit = _closest_violation(self.xy, float(min_separation_mm))
        if hit is not None:
            i, j, d = hit
            raise LayoutError(f"{self.name}: bases of ids {int(self.ids[i])} and "
                              f"{int(self.ids[j])} overlap ({d:.4f} mm apart); "
                              f"allowed: >= {min_separation_mm} mm (min_separation_mm)")
        return self

    # -- robot / fiducial views ---------------------------------------------
    @cached_property
    def robot_mask(self) -> np.ndarray:
        """(n,) bool, True where the position is a robot."""
        return _readonly(self.kinds == "robot")

    @cached_property
    def robot_ids(self) -> np.ndarray:
        """(n_robots,) int64 ids of the robots, layout order."""
        return _readonly(self.ids[self.robot_mask])

    @cached_property
    def robot_xy(self) -> np.ndarray:
        """(n_robots, 2) float64 robot base centres, mm."""
        return _readonly(self.xy[self.robot_mask])

    @cached_property
    def fiducial_ids(self) -> np.ndarray:
        """(n_fiducials,) int64 ids of the fiducials, layout order."""
        return _readonly(self.ids[~self.robot_mask])

    @cached_property
    def fiducial_xy(self) -> np.ndarray:
        """(n_fiducials, 2) float64 fiducial centres, mm."""
        return _readonly(self.xy[~self.robot_mask])

    @property
    def n_robots(self) -> int:
        """Number of robots."""
        return int(self.robot_mask.sum())

    @property
    def n_fiducials(self) -> int:
        """Number of fiducials."""
        return len(self.ids) - self.n_robots

    @cached_property
    def _robot_order(self) -> np.ndarray:
        return np.argsort(self.robot_ids, kind="stable")

    def _unknown_robot(self, robot_id) -> UnknownRobotError:
        if robot_id in set(self.fiducial_ids.tolist()):
            what = "is a fiducial, not a robot"
        else:
            what = "is not in the layout"
        if self.n_robots:
            allowed = (f"one of the {self.n_robots} robot ids in "
                       f"{int(self.robot_ids.min())}..{int(self.robot_ids.max())}")
        else:
            allowed = "none (layout has no robots)"
        return UnknownRobotError(f"{self.name}: robot id {robot_id!r} {what}; allowed: {allowed}")

    def _as_id_array(self, ids) -> np.ndarray:
        """``ids`` as a flat int64 array; UnknownRobotError on a non-integer value."""
        arr = np.asarray(ids).reshape(-1)
        if arr.dtype.kind in "iu":
            return arr.astype(np.int64)
        for v in arr.tolist():
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and float(v).is_integer()):
                raise self._unknown_robot(v)
        return arr.astype(np.int64)

    def robot_indices(self, ids) -> np.ndarray:
        """Robot indices (into the robot arrays) of robot ids.

        Parameters
        ----------
        ids : (k,) int array-like

        Returns
        -------
        (k,) int64

        Raises
        ------
        UnknownRobotError
            Naming the first id that is not a robot of this layout.
        """
        ids = self._as_id_array(ids)
        order = self._robot_order
        sorted_ids = self.robot_ids[order]
        pos = np.clip(np.searchsorted(sorted_ids, ids), 0, max(len(sorted_ids) - 1, 0))
        found = (sorted_ids[pos] == ids) if len(sorted_ids) else np.zeros(ids.shape, bool)
        if not found.all():
            raise self._unknown_robot(int(ids[~found][0]))
        return order[pos].astype(np.int64)

    def robot_index(self, robot_id: int) -> int:
        """Robot index (into the robot arrays) of one robot id.

        Raises
        ------
        UnknownRobotError
            Naming the id and the valid robot id range.
        """
        if isinstance(robot_id, (bool, np.bool_)) or not isinstance(robot_id, (int, np.integer)):
            raise self._unknown_robot(robot_id)
        return int(self.robot_indices([robot_id])[0])

    # -- neighbours (Sayres 2021 Eq. 4) --------------------------------------
    def neighbour_pairs(self, reach_mm: float) -> np.ndarray:
        """Robot pairs whose bases are within ``reach_mm`` mm.

        Parameters
        ----------
        reach_mm : float
            Base distance within which two robots can touch, mm; Sayres 2021 Eq. 4 uses
            ``2 (l_alpha + l_beta + buffer)``. Distances ``<= reach_mm`` count.

        Returns
        -------
        (n_pairs, 2) int64
            Robot indices ``(i, j)``, ``i < j``, sorted by ``i`` then ``j``.
        """
        reach = _check_reach(reach_mm)
        if self.n_robots < 2:
            return np.empty((0, 2), dtype=np.int64)
        pairs = cKDTree(self.robot_xy).query_pairs(r=reach + REACH_TOL_MM, output_type="ndarray")
        pairs = np.sort(pairs.astype(np.int64).reshape(-1, 2), axis=1)
        return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]

    def neighbour_csr(self, reach_mm: float) -> tuple[np.ndarray, np.ndarray]:
        """Symmetric robot adjacency within ``reach_mm`` mm, CSR.

        Returns
        -------
        ptr : (n_robots + 1,) int64
        idx : (2 * n_pairs,) int64
            Neighbours of robot ``i`` are ``idx[ptr[i]:ptr[i + 1]]`` (robot indices,
            ascending, ``i`` itself excluded).
        """
        pairs = self.neighbour_pairs(reach_mm)
        rows = np.concatenate([pairs[:, 0], pairs[:, 1]])
        cols = np.concatenate([pairs[:, 1], pairs[:, 0]])
        order = np.lexsort((cols, rows))
        ptr = np.zeros(self.n_robots + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows, minlength=self.n_robots), out=ptr[1:])
        return ptr, cols[order].astype(np.int64)

    def robot_fiducial_csr(self, reach_mm: float) -> tuple[np.ndarray, np.ndarray]:
        """Fiducials within ``reach_mm`` mm of each robot base, CSR.

        Returns
        -------
        ptr : (n_robots + 1,) int64
        idx : (n_links,) int64
            Fiducial indices (into ``fiducial_xy``) near robot ``i`` are
            ``idx[ptr[i]:ptr[i + 1]]``, ascending.
        """
        reach = _check_reach(reach_mm)
        if self.n_robots == 0 or self.n_fiducials == 0:
            return np.zeros(self.n_robots + 1, dtype=np.int64), np.empty(0, dtype=np.int64)
        lists = cKDTree(self.fiducial_xy).query_ball_point(self.robot_xy, r=reach + REACH_TOL_MM)
        return _csr_from_lists(lists, self.n_robots)

    # -- constructors -------------------------------------------------------
    @classmethod
    def hex_grid(cls, n_rings: int, pitch_mm: float, name: str | None = None) -> Layout:
        """Centred hex grid of robots, ``1 + 3 r (r + 1)`` positions for ``r`` rings.

        Rows run along +x, ``pitch_mm`` apart within a row; the second lattice vector is
        at 60 deg. The centre position is at (0, 0). Ids are 0..n-1 sorted by y then x.

        Parameters
        ----------
        n_rings : int >= 0
        pitch_mm : float > 0
            Base-to-base distance of nearest neighbours, mm.
        name : str, optional
            Default ``"hex-<n>"``.
        """
        where = name or "hex_grid"
        if isinstance(n_rings, bool) or not isinstance(n_rings, (int, np.integer)) or n_rings < 0:
            raise LayoutError(f"{where}: field 'n_rings' = {n_rings!r}; allowed: an integer >= 0")
        pitch = _check_positive("pitch_mm", pitch_mm, where)
        xy = hex_xy(hex_axial(int(n_rings)), pitch)
        n = len(xy)
        return cls(np.arange(n, dtype=np.int64), xy, ["robot"] * n,
                   name or f"hex-{n}").validate(0.0)

    @classmethod
    def hex_grid_positions(cls, n_positions: int, pitch_mm: float,
                           name: str | None = None) -> Layout:
        """Centred hex grid with ``n_positions`` robots (see :meth:`hex_grid`).

        Raises
        ------
        LayoutError
            If ``n_positions`` is not a centred hexagonal number; lists the nearest ones.
        """
        rings = hex_rings(int(n_positions)) if isinstance(n_positions, (int, np.integer)) else None
        if rings is None:
            raise LayoutError(f"field 'n_positions' = {n_positions!r} is not a centred hex "
                              f"count; allowed: 1 + 3r(r+1), nearest "
                              f"{', '.join(map(str, _nearest_hex_counts(n_positions)))}")
        return cls.hex_grid(rings, pitch_mm, name)

    @classmethod
    def sdss_v_grid(cls, pitch_mm: float = 22.4, fiducial_ids=()) -> Layout:
        """The all-robot 547-position (13-ring) grid of Sayres 2021.

        Parameters
        ----------
        pitch_mm : float
            Grid pitch, mm (22.4 for SDSS-V).
        fiducial_ids : iterable of int
            Ids (0..546) that are fiducials instead of robots.

        Raises
        ------
        UnknownRobotError
            If a fiducial id is not a position of the grid.
        """
        grid = cls.hex_grid(SDSS_V_RINGS, pitch_mm, name="sdss-v-grid")
        fid = np.asarray(list(fiducial_ids)).reshape(-1)
        kinds = np.array(grid.kinds)
        kinds[grid.robot_indices(fid)] = "fiducial"  # all positions are robots here
        return cls(grid.ids, grid.xy, kinds, grid.name).validate(0.0)

    @classmethod
    def sdss_v_fps(cls) -> Layout:
        """The real SDSS-V focal plane: 500 robots and 60 fiducials (42 intra-array,
        18 outer ring), from the packaged ``models/data/sdss-v-fps.csv``.

        Extra columns ``row``, ``col``, ``assignment`` (strings; outer ring row ``-99``).
        """
        ref = resources.files("models.data").joinpath("sdss-v-fps.csv")
        with resources.as_file(ref) as path:
            return cls.from_csv(path, name="sdss-v-fps")

    @classmethod
    def from_csv(cls, path: str | os.PathLike, min_separation_mm: float = 1.0,
                 name: str | None = None) -> Layout:
        """Read a layout CSV with columns ``id,x_mm,y_mm,kind`` (+ any extra columns).

        Extra columns are kept verbatim as ``(n,)`` str arrays in :attr:`extra`.

        Parameters
        ----------
        path : path-like
        min_separation_mm : float
            Smallest allowed base-to-base distance, mm.
        name : str, optional
            Default: the file name without suffix.

        Raises
        ------
        LayoutError
            Missing file or column, bad/duplicate id, non-finite coordinate, unknown
            kind, overlapping bases, empty layout; names the file, line and field.
        """
        path = Path(path)
        rows, columns = _read_rows(path)
        ids, xy, kinds, lines = _parse_rows(rows, path)
        extra = {c: np.array([r[c] for r, _ in rows], dtype=str)
                 for c in columns if c not in REQUIRED_COLUMNS}
        hit = _closest_violation(xy, float(min_separation_mm))
        if hit is not None:
            i, j, d = hit
            raise LayoutError(f"{path}:{lines[i]},{lines[j]}: bases of ids {ids[i]} and "
                              f"{ids[j]} overlap ({d:.4f} mm apart); allowed: >= "
                              f"{min_separation_mm} mm (min_separation_mm)")
        return cls(ids, xy, kinds, name or path.stem, extra).validate(0.0)

    def to_csv(self, path: str | os.PathLike) -> None:
        """Write ``id,x_mm,y_mm,kind`` + extra columns; atomic (temp file + rename).

        Coordinates are written with ``repr`` so they read back bit-identical. On any
        failure the target is left untouched and the temp file removed.
        """
        path = Path(path)
        header = [*REQUIRED_COLUMNS, *self.extra]
        try:
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        except OSError as exc:
            raise LayoutError(f"{path}: cannot write ({exc.strerror}); "
                              f"allowed: a path in an existing, writable directory") from exc
        try:
            with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
                writer = csv.writer(fh, lineterminator="\n")
                writer.writerow(header)
                for k in range(len(self.ids)):
                    writer.writerow(self._csv_row(k))
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    def _csv_row(self, k: int) -> list[str]:
        """Row ``k`` as CSV strings, in :meth:`to_csv` column order."""
        x, y = self.xy[k]
        return [str(int(self.ids[k])), repr(float(x)), repr(float(y)), str(self.kinds[k]),
                *(str(v[k]) for v in self.extra.values())]

    def __repr__(self) -> str:
        return (f"Layout(name={self.name!r}, n={len(self.ids)}, robots={self.n_robots}, "
                f"fiducials={self.n_fiducials})")


def _nearest_hex_counts(n) -> list[int]:
    """The centred hex counts just below and above ``n`` (one if ``n`` < 1)."""
    try:
        x = float(n)
    except (TypeError, ValueError):
        x = 1.0
    r = 0
    while hex_count(r + 1) <= x:
        r += 1
    return sorted({hex_count(r), hex_count(r + 1)}) if x >= 1 else [1]


def _read_rows(path: Path) -> tuple[list[tuple[dict, int]], list[str]]:
    """Data rows ``(row dict, line number)`` and the column names of a layout CSV."""
    if not path.is_file():
        raise LayoutError(f"{path}: file not found; allowed: path to an existing layout CSV")
    with path.open(newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh, skipinitialspace=True)
        columns = [c.strip() for c in (reader.fieldnames or [])]
        reader.fieldnames = columns
        missing = [c for c in REQUIRED_COLUMNS if c not in columns]
        if missing:
            raise LayoutError(f"{path}:1: missing column(s) {', '.join(missing)}; "
                              f"required: {','.join(REQUIRED_COLUMNS)}")
        rows = [(row, reader.line_num) for row in reader]
    for row, line in rows:
        if None in row or any(v is None for v in row.values()):
            raise LayoutError(f"{path}:{line}: wrong number of fields; "
                              f"allowed: {len(columns)} ({','.join(columns)})")
    if not rows:
        raise LayoutError(f"{path}: empty layout (no data rows); allowed: at least one row")
    return rows, columns


def _parse_rows(rows, path: Path):
    """Validated ``ids (n,), xy (n, 2), kinds (n,), lines`` of the data rows."""
    ids, xy, kinds, lines, first_line = [], [], [], [], {}
    for row, line in rows:
        where = f"{path}:{line}"
        rid = _parse_id(row["id"], where)
        if rid in first_line:
            raise LayoutError(f"{where}: field 'id' = {rid} is a duplicate id (first on line "
                              f"{first_line[rid]}); allowed: unique integer ids")
        first_line[rid] = line
        kind = row["kind"].strip()
        if kind not in KINDS:
            raise LayoutError(f"{where}: field 'kind' = {kind!r} is an unknown kind; "
                              f"allowed: {', '.join(KINDS)}")
        ids.append(rid)
        xy.append((_parse_mm(row, "x_mm", where), _parse_mm(row, "y_mm", where)))
        kinds.append(kind)
        lines.append(line)
    return (np.array(ids, dtype=np.int64), np.array(xy, dtype=np.float64).reshape(-1, 2),
            kinds, lines)


def _parse_id(text: str, where: str) -> int:
    try:
        return int(text.strip())
    except ValueError:
        raise LayoutError(f"{where}: field 'id' = {text!r} is not an integer; "
                          f"allowed: unique integer ids") from None


def _parse_mm(row: dict, column: str, where: str) -> float:
    text = row[column]
    try:
        value = float(text)
    except ValueError:
        value = None
    if value is None or not math.isfinite(value):
        raise LayoutError(f"{where}: field '{column}' = {text!r}; allowed: a finite number "
                          f"in mm (not NaN/inf)")
    return value
