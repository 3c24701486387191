"""A calibrated instrument as a planning layout, and the built-in instruments by name.

The planning frame of an instrument is its wok frame turned by +90 degrees about z: a
flat-wok hole's local axes (i = (0, -1, 0), j = (1, 0, 0) in the wok frame) become the
plane's x and y, so every robot's alpha = 0 points along +x as in every other layout
(:func:`wok_to_plane`, :func:`plane_to_wok`). A robot's position in the layout is where its
alpha axis (through its hole + dx i + dy j, along the hole's k) meets the focal surface,
:data:`FOCAL_HEIGHT_MM` above the hole: there its arms move. On a flat wok that is the
hole + offset itself; on the curved wok the tilted axes move the heads by up to 5 mm from
their holes' x, y, as in SDSS-V's 3D robot positions. ``z_mm`` is that point's height
relative to a flat wok's focal surface (0 on a flat wok). Each robot carries its own
calibration as layout columns
(:mod:`rfp_twin.models.layout.columns`): ``alpha_len_mm``, its three fibers (the APOGEE
one only on ``ApogeeBoss`` holes), ``alpha_offset_deg, beta_offset_deg``, ``z_mm`` and its
axis ``kx, ky, kz`` (plane frame), plus ``hole_id``, ``hole_type``. Obstacles follow
SDSS-V's production rules (data folder README): the fiducials as points with a 3 mm
keep-out, the six guide cameras as segments with a 3 mm keep-out. Robots next to a
fiducial that SDSS-V watches (``fiducialWatch``: the hole one row above, one column left
when the robot's row is positive) get ``fiducial_watch = 1``; their motion near the fiducial is limited by
the fiducial's keep-out itself, which every planner and checker applies.
"""
from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

import numpy as np

from rfp_twin.models.instrument.calibration import Calibration, read_calibration
from rfp_twin.models.layout.core import Layout

#: Built-in instruments: layout name -> (package data folder, description).
INSTRUMENTS = {
    "sdss-v-apo": ("apo-sloanFlatCMM", "SDSS-V at APO (Sloan 2.5 m), flat wok, calibrated"),
    "sdss-v-lco": ("lco-duPontFlatCMM", "SDSS-V at LCO (du Pont), flat wok, calibrated"),
    "sdss-v-curved": ("apo-sloanCurveCMM", "SDSS-V curved wok measured by CMM, nominal robots"),
}
#: Keep-out radius of a fiducial and of a guide camera in SDSS-V production, mm.
PRODUCTION_FIDUCIAL_BUFFER_MM = 3.0
PRODUCTION_GFA_BUFFER_MM = 3.0
#: Fibers above the wok surface along the robot's axis, mm (coordio defaults).
FOCAL_HEIGHT_MM = 143.1
#: Layout ids of obstacles: fiducial ``F<k>`` -> FIDUCIAL_ID_BASE + k; guide camera g -> GFA_ID_BASE + g.
FIDUCIAL_ID_BASE = 1_000_000
GFA_ID_BASE = 2_000_000

_QUARTER = np.array([[0.0, -1.0], [1.0, 0.0]])   # +90 deg about z


def wok_to_plane(xy: np.ndarray) -> np.ndarray:
    """(..., 2) wok x, y -> planning-frame x, y, mm (turned +90 deg)."""
    return np.asarray(xy, dtype=np.float64) @ _QUARTER.T


def plane_to_wok(xy: np.ndarray) -> np.ndarray:
    """(..., 2) planning-frame x, y -> wok x, y, mm."""
    return np.asarray(xy, dtype=np.float64) @ _QUARTER


def calibration_folder(name: str) -> Path:
    """The packaged calibration folder of a built-in instrument name."""
    ref = resources.files("rfp_twin.models.data").joinpath("calibrations", INSTRUMENTS[name][0])
    return Path(str(ref))


def instrument_layout(source: str | Path | Calibration, name: str | None = None) -> Layout:
    """The planning layout of a calibrated instrument.

    Parameters
    ----------
    source : a built-in name (:data:`INSTRUMENTS`), a calibration folder, or a Calibration
    name : label of the layout (default: the instrument name or the folder's name)
    """
    if isinstance(source, Calibration):
        cal = source
    elif str(source) in INSTRUMENTS:
        name = name or str(source)
        cal = read_calibration(calibration_folder(str(source)))
    else:
        cal = read_calibration(source)
    name = name or cal.folder.name
    n, m, g = cal.n_robots, cal.fiducial_xyz.shape[0], cal.gfa_segments.shape[0]
    head = cal.base_xyz + FOCAL_HEIGHT_MM * cal.frames[:, 2]
    axis = cal.frames[:, 2]
    fid_num = np.array([int(re.sub(r"\D", "", s)) for s in cal.fiducial_names], dtype=np.int64)
    ids = np.concatenate([cal.robot_ids, FIDUCIAL_ID_BASE + fid_num, GFA_ID_BASE + 1 + np.arange(g)])
    xy = np.concatenate([wok_to_plane(head[:, :2]), wok_to_plane(cal.fiducial_xyz[:, :2]),
                         wok_to_plane(cal.gfa_segments[:, 0])])
    kinds = ["robot"] * n + ["fiducial"] * m + ["gfa"] * g
    blank_obs = [""] * (m + g)
    blank_rob = [""] * n

    def robot(values, fmt=repr) -> list[str]:
        return [("" if isinstance(v, float) and np.isnan(v) else fmt(v)) for v in values] + blank_obs

    k_plane = np.column_stack([wok_to_plane(axis[:, :2]), axis[:, 2]])
    gfa_end = wok_to_plane(cal.gfa_segments[:, 1])
    extra = {
        "hole_id": list(cal.robot_holes) + list(cal.fiducial_holes) + [f"GFA{k + 1}" for k in range(g)],
        "hole_type": list(cal.robot_hole_types) + ["Fiducial"] * m + ["GFA"] * g,
        "alpha_len_mm": robot(cal.alpha_len.tolist()),
        "met_x_mm": robot(cal.fibers[:, 0, 0].tolist()), "met_y_mm": robot(cal.fibers[:, 0, 1].tolist()),
        "boss_x_mm": robot(cal.fibers[:, 1, 0].tolist()), "boss_y_mm": robot(cal.fibers[:, 1, 1].tolist()),
        "apogee_x_mm": robot(cal.fibers[:, 2, 0].tolist()),
        "apogee_y_mm": robot(cal.fibers[:, 2, 1].tolist()),
        "alpha_offset_deg": robot(cal.angle_offset[:, 0].tolist()),
        "beta_offset_deg": robot(cal.angle_offset[:, 1].tolist()),
        "z_mm": robot((head[:, 2] - FOCAL_HEIGHT_MM).tolist()),
        "kx": robot(k_plane[:, 0].tolist()), "ky": robot(k_plane[:, 1].tolist()),
        "kz": robot(k_plane[:, 2].tolist()),
        "fiducial_watch": robot(_fiducial_watch(cal).tolist(), fmt=lambda v: str(int(v))),
        "fiducial_name": blank_rob + list(cal.fiducial_names) + [""] * g,
        "x2_mm": blank_rob + [""] * m + [repr(v) for v in gfa_end[:, 0].tolist()],
        "y2_mm": blank_rob + [""] * m + [repr(v) for v in gfa_end[:, 1].tolist()],
        "obstacle_buffer_mm": blank_rob + [repr(PRODUCTION_FIDUCIAL_BUFFER_MM)] * m
        + [repr(PRODUCTION_GFA_BUFFER_MM)] * g,
    }
    return Layout(ids, xy, np.array(kinds, dtype=object), name=name, extra=extra).validate(1.0)


def _fiducial_watch(cal: Calibration) -> np.ndarray:
    """(n,) 0/1: robots in the hole one row above each fiducial (one column left when that
    hole's row is positive), as SDSS-V's planner marks them (kaiju 1.4.1
    ``RobotGrid._load_from_tables``: fiducial R0C24 -> robot R+1C23)."""
    hole_rc = {}
    for k, h in enumerate(cal.robot_holes):
        rc = _row_col(h)
        if rc is not None:
            hole_rc[rc] = k
    out = np.zeros(cal.n_robots, dtype=np.int64)
    for h in cal.fiducial_holes:
        rc = _row_col(h)
        if rc is None:
            continue
        row, col = rc
        # the hole one row up; from row +1 on (the watched robot's row, as SDSS-V's
        # planner tests it) the columns are numbered one further left
        k = hole_rc.get((row + 1, col - 1 if row + 1 > 0 else col))
        if k is not None:
            out[k] = 1
    return out


def _row_col(hole: str) -> tuple[int, int] | None:
    """``R+12C8`` -> (12, 8); None for another name."""
    m = re.fullmatch(r"R([+-]?\d+)C(\d+)", hole)
    return (int(m.group(1)), int(m.group(2))) if m else None
