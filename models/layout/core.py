"""Layout: where the robot and fiducial bases sit on the focal plane.

Units: millimetres. A layout holds ``n`` positions: integer ids ``(n,)``, base
coordinates ``xy`` ``(n, 2)`` in mm, and a kind ``(n,)`` per position, ``'robot'`` or
``'fiducial'``. Robot-only arrays (``robot_ids``, ``robot_xy``) and fiducial-only arrays
(``fiducial_ids``, ``fiducial_xy``) keep the layout order; a "robot index" is an index
into the robot arrays and a "fiducial index" one into the fiducial arrays.

This module holds the :class:`Layout` type: its checks, robot/fiducial views, id lookup
and the generated grids (:meth:`Layout.hex_grid`, :meth:`Layout.hex_grid_positions`,
:meth:`Layout.sdss_v_grid`, :meth:`Layout.sdss_v_fps`). CSV I/O comes from
:mod:`rfp_twin.models.layout.csv_io`, neighbour lists from :mod:`rfp_twin.models.layout.neighbours`.

A malformed layout raises :class:`rfp_twin.models.errors.LayoutError`; an id the layout does not
contain raises :class:`rfp_twin.models.errors.UnknownRobotError`. Messages are one line and name
the file/line, field and the allowed values.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources

import numpy as np

from rfp_twin.models.errors import LayoutError, UnknownRobotError
from rfp_twin.models.layout.checks import (KINDS, as_ids, as_xy, check_positive, closest_violation,
                                  readonly)
from rfp_twin.models.layout.csv_io import LayoutCsv
from rfp_twin.models.layout.grids import SDSS_V_RINGS, hex_axial, hex_rings, hex_xy, nearest_hex_counts
from rfp_twin.models.layout.neighbours import LayoutNeighbours

#: Package data file of the real SDSS-V focal plane (in ``rfp_twin.models.data``).
SDSS_V_FPS_CSV = "sdss-v-fps.csv"


@dataclass(frozen=True, eq=False)
class Layout(LayoutCsv, LayoutNeighbours):
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
        set_(self, "ids", readonly(as_ids(self.ids, self.name)))
        set_(self, "xy", readonly(as_xy(self.xy, self.name)))
        set_(self, "kinds", readonly(np.array([str(k) for k in np.ravel(self.kinds)],
                                                dtype=object)))
        set_(self, "extra", {str(k): readonly(np.array(v).reshape(-1))
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
        hit = closest_violation(self.xy, float(min_separation_mm))
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
        return readonly(self.kinds == "robot")

    @cached_property
    def robot_ids(self) -> np.ndarray:
        """(n_robots,) int64 ids of the robots, layout order."""
        return readonly(self.ids[self.robot_mask])

    @cached_property
    def robot_xy(self) -> np.ndarray:
        """(n_robots, 2) float64 robot base centres, mm."""
        return readonly(self.xy[self.robot_mask])

    @cached_property
    def fiducial_ids(self) -> np.ndarray:
        """(n_fiducials,) int64 ids of the fiducials, layout order."""
        return readonly(self.ids[~self.robot_mask])

    @cached_property
    def fiducial_xy(self) -> np.ndarray:
        """(n_fiducials, 2) float64 fiducial centres, mm."""
        return readonly(self.xy[~self.robot_mask])

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
        pitch = check_positive("pitch_mm", pitch_mm, where)
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
                              f"{', '.join(map(str, nearest_hex_counts(n_positions)))}")
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
        ref = resources.files("rfp_twin.models.data").joinpath(SDSS_V_FPS_CSV)
        with resources.as_file(ref) as path:
            return cls.from_csv(path, name="sdss-v-fps")

    def __repr__(self) -> str:
        return (f"Layout(name={self.name!r}, n={len(self.ids)}, robots={self.n_robots}, "
                f"fiducials={self.n_fiducials})")
