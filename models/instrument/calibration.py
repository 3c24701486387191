"""A calibration folder of a real SDSS-V instrument, read and checked.

The folder holds the files SDSS-V's control software loads (``sdss/fps_calibrations``):

``wokCoords.csv`` (required)
    One row per hole: ``holeID``, ``holeType`` (``ApogeeBoss``, ``Boss``, ``Fiducial``,
    ``GFA``, ``Empty``), position ``xWok, yWok, zWok`` (mm) and the hole's unit vectors
    ``ix..iz, jx..jz, kx..kz`` (k along the robot's axis; i, j its local x, y).
``positionerTable.csv`` (required)
    One row per robot: ``holeID``, ``positionerID``, ``alphaArmLen`` (mm), fibers in the
    beta-arm frame ``metX, metY, apX, apY, bossX, bossY`` (mm), ``alphaOffset,
    betaOffset`` (deg: where each encoder's zero sits in the model's angles), ``dx, dy``
    (mm: the alpha axis's offset from its hole centre, in the hole's i, j).
``fiducialCoords.csv`` (required)
    ``holeID``, ``id`` (e.g. ``F201752``), ``xWok, yWok, zWok`` (mm).
``fiberAssignments.csv`` (optional)
    ``positionerID`` of every ``Device == Positioner`` row; each must be in the
    positioner table.

``gfaCoords.csv`` holds the guide-camera chip centres; the collision segments of the six
guide cameras are SDSS-V's production constants (:data:`GFA_SEGMENTS_WOK`), the same at
both sites. Everything is in the wok frame (mm, deg); :mod:`rfp_twin.models.instrument.layout`
turns it into a planning layout.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfp_twin.models.instrument.tables import CalibrationError, Table

#: Hole types that carry a robot, and the fibers each carries (besides metrology).
ROBOT_HOLE_TYPES = {"ApogeeBoss": ("boss", "apogee"), "Boss": ("boss",)}
HOLE_TYPES = ("ApogeeBoss", "Boss", "Fiducial", "GFA", "Empty")

#: The six guide cameras as collision segments in the wok x, y (mm), SDSS-V production
#: planner (kaiju 1.4.1 ``RobotGrid._load_from_tables``), both sites; buffer 3 mm.
GFA_SEGMENTS_WOK = np.array([
    [[-267.49, 89.15], [-210.95, 187.08]],
    [[-56.54, 276.23], [56.54, 276.23]],
    [[210.95, 187.07], [267.49, 89.15]],
    [[267.49, -89.15], [210.95, -187.08]],
    [[56.54, -276.23], [-56.54, -276.23]],
    [[-210.95, -187.07], [-267.49, -89.15]],
])

WOK_COLUMNS = ("holeID", "holeType", "xWok", "yWok", "zWok",
               *(f"{a}{c}" for a in "ijk" for c in "xyz"))
POSITIONER_COLUMNS = ("holeID", "positionerID", "alphaArmLen", "metX", "metY", "apX", "apY",
                      "bossX", "bossY", "alphaOffset", "betaOffset", "dx", "dy")

#: Physical range of each robot's geometry in ``positionerTable.csv``, mm: column ->
#: (low, high, what it rests on). Design values (coordio defaults): alpha arm 7.4,
#: metrology fiber (14.314, 0), APOGEE (14.965, 0.376), BOSS (14.965, -0.376), alpha axis on
#: the hole centre (dx = dy = 0). The SDSS-V calibrations (fps_calibrations 2025.12.04, APO
#: and LCO flat woks, 500 robots each) spread: alphaArmLen 7.287..7.501 (sd 0.03); metX
#: 14.240..15.069, apX / bossX 14.814..15.717 (one LCO robot's head measured 0.75 mm out);
#: apY 0.090..0.430, bossY -0.593..-0.310, metY 0; dx -0.134..0.367, dy -0.509..0.254.
#: The ranges hold every measured robot with room to spare, and refuse what no
#: SDSS-V robot can be (an alpha arm of 70 mm, a fiber off its 3 mm-wide beta arm).
PHYSICAL_RANGES_MM = {
    "alphaArmLen": (6.9, 7.9, "design 7.4 mm +- 0.5 mm"),
    "metX": (13.3, 15.8, "design 14.314 mm, about +- 1 mm"),
    "apX": (13.9, 16.0, "design 14.965 mm, about +- 1 mm, short of the 16.2 mm tip"),
    "bossX": (13.9, 16.0, "design 14.965 mm, about +- 1 mm, short of the 16.2 mm tip"),
    "metY": (-1.0, 1.0, "design 0 mm, on the 3 mm-wide beta arm"),
    "apY": (-1.0, 1.0, "design 0.376 mm, on the 3 mm-wide beta arm"),
    "bossY": (-1.0, 1.0, "design -0.376 mm, on the 3 mm-wide beta arm"),
    "dx": (-1.0, 1.0, "alpha axis within 1 mm of its hole centre (measured <= 0.51 mm)"),
    "dy": (-1.0, 1.0, "alpha axis within 1 mm of its hole centre (measured <= 0.51 mm)"),
}
FIDUCIAL_COLUMNS = ("holeID", "id", "xWok", "yWok", "zWok")


@dataclass(frozen=True)
class Calibration:
    """One instrument's calibration, wok frame (mm, deg), robots in positioner-table order.

    Attributes
    ----------
    folder : Path
    robot_ids : (n,) int64 positioner ids
    robot_holes : (n,) object hole ids (``R-13C1``)
    robot_hole_types : (n,) object ``ApogeeBoss`` or ``Boss``
    hole_xyz : (n, 3) float64 hole centres of the robots
    frames : (n, 3, 3) float64 unit vectors i, j, k (rows) of each robot's hole
    base_offset : (n, 2) float64 ``dx, dy`` in the hole's i, j
    alpha_len : (n,) float64 alpha arm lengths
    fibers : (n, 3, 2) float64 metrology, BOSS, APOGEE in the beta-arm frame (NaN: not carried)
    angle_offset : (n, 2) float64 ``alphaOffset, betaOffset`` (deg)
    fiducial_names : (m,) object ids as written (``F201752``)
    fiducial_holes : (m,) object
    fiducial_xyz : (m, 3) float64
    gfa_segments : (6, 2, 2) float64 guide-camera collision segments, wok x, y
    """

    folder: Path
    robot_ids: np.ndarray
    robot_holes: np.ndarray
    robot_hole_types: np.ndarray
    hole_xyz: np.ndarray
    frames: np.ndarray
    base_offset: np.ndarray
    alpha_len: np.ndarray
    fibers: np.ndarray
    angle_offset: np.ndarray
    fiducial_names: np.ndarray
    fiducial_holes: np.ndarray
    fiducial_xyz: np.ndarray
    gfa_segments: np.ndarray

    @property
    def n_robots(self) -> int:
        return int(self.robot_ids.size)

    @property
    def base_xyz(self) -> np.ndarray:
        """(n, 3) float64 alpha axes on the wok: hole + dx i + dy j, mm."""
        return (self.hole_xyz + self.base_offset[:, :1] * self.frames[:, 0]
                + self.base_offset[:, 1:] * self.frames[:, 1])

    @property
    def curved(self) -> bool:
        """True when some hole is off the z = 0 plane or tilted."""
        return bool(np.any(self.hole_xyz[:, 2] != 0.0) or np.any(self.frames[:, 2, 2] != 1.0))


def read_calibration(folder: str | Path) -> Calibration:
    """Read and check a calibration folder (see the module docstring for the files).

    Raises
    ------
    CalibrationError
        A missing file or column; NaN or text in a number; a robot's alpha arm, fiber
        position or base offset outside its physical range (:data:`PHYSICAL_RANGES_MM`);
        a repeated hole or robot id; a
        robot hole or fiducial hole not in the wok table, or of the wrong type; i, j, k not
        unit or not orthogonal; a positioner of the fiber assignments missing from the
        positioner table. One line naming the file, row and field with the allowed values.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise CalibrationError(f"{folder}: not a folder; allowed: a calibration folder with "
                               "wokCoords.csv, positionerTable.csv, fiducialCoords.csv")
    wok = Table(folder / "wokCoords.csv", WOK_COLUMNS)
    pos = Table(folder / "positionerTable.csv", POSITIONER_COLUMNS)
    fid = Table(folder / "fiducialCoords.csv", FIDUCIAL_COLUMNS)

    holes = wok.text("holeID")
    wok.unique("holeID", holes)
    types = wok.text("holeType")
    for r, t in enumerate(types):
        if t not in HOLE_TYPES:
            raise CalibrationError(f"{wok.where(r)}: field 'holeType' = {t!r}; allowed: "
                                   f"{', '.join(HOLE_TYPES)}")
    xyz = np.column_stack([wok.numbers(c, -1e4, 1e4) for c in ("xWok", "yWok", "zWok")])
    frames = wok.frames()
    row_of = {h: r for r, h in enumerate(holes)}

    robot_holes = pos.text("holeID")
    pos.unique("holeID", robot_holes)
    robot_ids = pos.integers("positionerID")
    pos.unique("positionerID", robot_ids)
    rows = np.empty(pos.n_rows, dtype=np.int64)
    for r, h in enumerate(robot_holes):
        if h not in row_of:
            raise CalibrationError(f"{pos.where(r)}: field 'holeID' = {h!r} is not in "
                                   f"{wok.path.name}; allowed: a hole id of the wok table")
        if types[row_of[h]] not in ROBOT_HOLE_TYPES:
            raise CalibrationError(f"{pos.where(r)}: field 'holeID' = {h!r} is a "
                                   f"{types[row_of[h]]} hole; allowed: a hole of type "
                                   f"{' or '.join(ROBOT_HOLE_TYPES)}")
        rows[r] = row_of[h]
    hole_types = np.array([types[k] for k in rows], dtype=object)

    geom = {name: _physical(pos, name, robot_ids) for name in PHYSICAL_RANGES_MM}
    fibers = np.full((pos.n_rows, 3, 2), np.nan)
    fibers[:, 0] = np.column_stack([geom["metX"], geom["metY"]])
    boss = np.column_stack([geom["bossX"], geom["bossY"]])
    apogee = np.column_stack([geom["apX"], geom["apY"]])
    for r, t in enumerate(hole_types):
        fibers[r, 1] = boss[r]
        if "apogee" in ROBOT_HOLE_TYPES[t]:
            fibers[r, 2] = apogee[r]

    fid_holes = fid.text("holeID")
    fid.unique("holeID", fid_holes)
    fid_names = fid.text("id")
    fid.unique("id", fid_names)
    for r, (h, name) in enumerate(zip(fid_holes, fid_names)):
        if h not in row_of:
            raise CalibrationError(f"{fid.where(r)}: field 'holeID' = {h!r} is not in "
                                   f"{wok.path.name}; allowed: a hole id of the wok table")
        if not re.fullmatch(r"[A-Za-z]*\d+", name):
            raise CalibrationError(f"{fid.where(r)}: field 'id' = {name!r}; allowed: letters "
                                   "then digits (F201752)")
    fid_xyz = np.column_stack([fid.numbers(c, -1e4, 1e4) for c in ("xWok", "yWok", "zWok")])

    _check_assignments(folder / "fiberAssignments.csv", set(robot_ids.tolist()))
    return Calibration(
        folder=folder, robot_ids=robot_ids, robot_holes=np.array(robot_holes, dtype=object),
        robot_hole_types=hole_types, hole_xyz=xyz[rows], frames=frames[rows],
        base_offset=np.column_stack([geom["dx"], geom["dy"]]),
        alpha_len=geom["alphaArmLen"], fibers=fibers,
        angle_offset=np.column_stack([pos.numbers("alphaOffset", -180, 180),
                                      pos.numbers("betaOffset", -180, 180)]),
        fiducial_names=np.array(fid_names, dtype=object),
        fiducial_holes=np.array(fid_holes, dtype=object), fiducial_xyz=fid_xyz,
        gfa_segments=GFA_SEGMENTS_WOK.copy())


def _physical(table: Table, name: str, robot_ids: np.ndarray) -> np.ndarray:
    """Column ``name`` of the positioner table, (r,) float64 mm, each value within its
    :data:`PHYSICAL_RANGES_MM`; the error names file, line, robot, field and range."""
    values = table.numbers(name)
    lo, hi, why = PHYSICAL_RANGES_MM[name]
    bad = np.flatnonzero((values < lo) | (values > hi))
    if bad.size:
        r = int(bad[0])
        raise CalibrationError(f"{table.where(r)}: robot {int(robot_ids[r])}: field {name!r} = "
                               f"{values[r]:g} mm; allowed: [{lo:g}, {hi:g}] mm ({why})")
    return values


def _check_assignments(path: Path, robot_ids: set[int]) -> None:
    """Every positioner of the fiber assignments (optional file) must be a known robot."""
    if not path.is_file():
        return
    table = Table(path, ("Device", "positionerID"))
    for r, (device, pid) in enumerate(zip(table.columns["Device"], table.columns["positionerID"])):
        if device != "Positioner":
            continue
        try:
            known = int(float(pid)) in robot_ids
        except ValueError:
            known = False
        if not known:
            raise CalibrationError(f"{table.where(r)}: field 'positionerID' = {pid!r} is not in "
                                   "positionerTable.csv; allowed: a positioner of the table")
