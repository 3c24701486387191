"""Optional per-position columns of a layout: each robot's own geometry, each obstacle's shape.

A layout (:class:`rfp_twin.models.layout.Layout`) keeps any extra CSV column in ``extra``.
The columns named here have a meaning: when present they override the robot spec for
that robot (or obstacle), so a calibrated instrument is a layout with these columns
(:mod:`rfp_twin.models.instrument`) and a user's CSV can carry them too. A blank cell
means "the spec's value" (or "not carried" for a fiber).

Robot columns (mm and deg; plane frame, see :mod:`rfp_twin.models.instrument.frames`):

========================  ===============================================================
``alpha_len_mm``          alpha axis to beta axis (spec ``alpha_length_mm``)
``met_x_mm, met_y_mm``    metrology fiber in the beta-arm frame (spec fiber ``metrology``)
``boss_x_mm, boss_y_mm``  BOSS fiber (blank: not carried)
``apogee_x_mm, ...y_mm``  APOGEE fiber (blank: not carried)
``alpha_offset_deg``      model angle of the alpha encoder's zero (model = encoder + offset)
``beta_offset_deg``       same for beta
``buffer_add_mm``         added to the run's collision buffer for this robot (worn robots)
``z_mm``                  height of the robot's focal-surface point (x_mm, y_mm) relative to
                          a flat focal surface (blank: 0)
``kx, ky, kz``            the robot's axis (unit), plane frame; blank: (0, 0, 1). A tilted
                          robot's arms move in the plane normal to k through (x, y, z); the
                          2D model uses their projection, which is never closer than the 3D
                          bodies, and adds the projection's shortening to its buffer
========================  ===============================================================

Obstacle columns (rows of kind ``fiducial`` or ``gfa``):

========================  ===============================================================
``x2_mm, y2_mm``          other end of a segment obstacle (a GFA chip edge); blank: a point
``obstacle_buffer_mm``    keep-out radius around it (blank: spec ``fiducial_buffer_mm``)
========================  ===============================================================

Every reader returns a float64 array in layout order of robots (or obstacles) and raises
:class:`rfp_twin.models.errors.LayoutError` naming the layout, the id and the column for a
cell that is not a number or out of its range.
"""
from __future__ import annotations

import math

import numpy as np

from rfp_twin.models.errors import LayoutError

#: Fibers a robot may carry, in the order of :func:`robot_fibers` (axis 1).
FIBERS = ("metrology", "boss", "apogee")
FIBER_COLUMNS = {"metrology": ("met_x_mm", "met_y_mm"), "boss": ("boss_x_mm", "boss_y_mm"),
                 "apogee": ("apogee_x_mm", "apogee_y_mm")}

#: Nominal metrology fiber x of the SDSS-V beta arm, mm (coordio defaults). A robot whose
#: ``met_x_mm`` differs has its beta collision segment extended along its arm by the
#: difference (:func:`robot_collision_arrays`): the head that carries the fibers may sit
#: where its fibers were measured, and the segment still covers the spec's.
NOMINAL_MET_X_MM = 14.314

#: Column -> allowed closed range of its values.
ROBOT_COLUMNS = {
    "alpha_len_mm": (0.1, 1000.0),
    "met_x_mm": (0.1, 1000.0), "met_y_mm": (-100.0, 100.0),
    "boss_x_mm": (0.1, 1000.0), "boss_y_mm": (-100.0, 100.0),
    "apogee_x_mm": (0.1, 1000.0), "apogee_y_mm": (-100.0, 100.0),
    "alpha_offset_deg": (-180.0, 180.0), "beta_offset_deg": (-180.0, 180.0),
    "buffer_add_mm": (-100.0, 100.0),
    "z_mm": (-1000.0, 1000.0),
    "kx": (-1.0, 1.0), "ky": (-1.0, 1.0), "kz": (0.0, 1.0),
}
OBSTACLE_COLUMNS = {
    "x2_mm": (-1e5, 1e5), "y2_mm": (-1e5, 1e5), "obstacle_buffer_mm": (0.0, 100.0),
}


def _cell(cell) -> float | None:
    """A cell as a float; None when blank (empty text or NaN); NaN when not a number."""
    if isinstance(cell, (int, float, np.integer, np.floating)):
        value = float(cell)
    else:
        text = str(cell).strip()
        if text == "":
            return None
        try:
            value = float(text)
        except ValueError:
            return math.nan
    return None if math.isnan(value) else value


def _column(layout, name: str, rows: np.ndarray, default: float, bounds) -> np.ndarray:
    """Column ``name`` of the positions ``rows`` (k,) as float64; blank -> ``default``."""
    out = np.full(rows.size, float(default))
    raw = layout.extra.get(name)
    if raw is None:
        return out
    lo, hi = bounds
    for k, r in enumerate(rows):
        value = _cell(raw[r])
        if value is None:
            continue
        if not (math.isfinite(value) and lo <= value <= hi):
            raise LayoutError(f"{layout.name}: id {int(layout.ids[r])} field {name!r} = "
                              f"{str(raw[r])!r}; allowed: a number in [{lo:g}, {hi:g}] or blank")
        out[k] = value
    return out


def robot_column(layout, name: str, default: float) -> np.ndarray:
    """(n_robots,) float64 values of robot column ``name``; ``default`` where blank/absent."""
    return _column(layout, name, np.flatnonzero(layout.robot_mask), default, ROBOT_COLUMNS[name])


def obstacle_column(layout, name: str, default: float) -> np.ndarray:
    """(n_obstacles,) float64 values of obstacle column ``name`` (non-robot rows)."""
    return _column(layout, name, np.flatnonzero(~layout.robot_mask), default,
                   OBSTACLE_COLUMNS[name])


def robot_fibers(layout, nominal: dict[str, tuple[float, float]]) -> np.ndarray:
    """(n_robots, 3, 2) float64 fiber positions in the beta-arm frame, mm, axis 1 in
    :data:`FIBERS` order; NaN where a robot does not carry that fiber.

    ``nominal`` maps a fiber name to the spec's (x, y); a layout without any fiber column
    gives every robot the spec's fibers; with fiber columns, a blank cell means "not
    carried" (except the metrology fiber, which every robot has).
    """
    n = layout.n_robots
    out = np.full((n, len(FIBERS), 2), np.nan)
    has_columns = any(c in layout.extra for cols in FIBER_COLUMNS.values() for c in cols)
    for f, fiber in enumerate(FIBERS):
        nom = nominal.get(fiber, (math.nan, math.nan))
        default = nom if (not has_columns or fiber == "metrology") else (math.nan, math.nan)
        for ax, col in enumerate(FIBER_COLUMNS[fiber]):
            out[:, f, ax] = robot_column(layout, col, default[ax])
    bad = np.flatnonzero(np.isnan(out[:, :, 0]) != np.isnan(out[:, :, 1]))
    if bad.size:
        r = bad[0] // len(FIBERS)
        raise LayoutError(f"{layout.name}: id {int(layout.robot_ids[r])} has one of "
                          f"{FIBER_COLUMNS[FIBERS[bad[0] % len(FIBERS)]]} blank; allowed: "
                          "both or neither")
    return out


def segment_shift(layout) -> np.ndarray:
    """(n_robots,) float64 offset of each robot's fiber head along its beta arm, mm:
    ``met_x_mm - NOMINAL_MET_X_MM`` where the layout has a metrology column, else 0."""
    if "met_x_mm" not in layout.extra:
        return np.zeros(layout.n_robots)
    return robot_column(layout, "met_x_mm", NOMINAL_MET_X_MM) - NOMINAL_MET_X_MM


def robot_buffers(spec, layout, buffer_mm: float) -> np.ndarray:
    """(n_robots,) float64 collision buffer of each robot: ``buffer_mm`` plus its
    ``buffer_add_mm``, mm; LayoutError naming the robot when one leaves (0, pitch / 2)."""
    add = robot_column(layout, "buffer_add_mm", 0.0)
    out = float(buffer_mm) + add
    bad = np.flatnonzero((out <= 0.0) | (out >= spec.pitch_mm / 2))
    if bad.size:
        k = int(bad[0])
        raise LayoutError(f"{layout.name}: robot {int(layout.robot_ids[k])} field "
                          f"'buffer_add_mm' = {add[k]!r} gives a buffer of {out[k]:.3f} mm; "
                          f"allowed: buffer_mm + buffer_add_mm in (0, {spec.pitch_mm / 2}) mm")
    return out


def robot_collision_arrays(spec, layout, buffer_mm: float):
    """Each robot's own 2D collision body (Sayres 2021 Eq. 3 with per-robot values).

    Returns ``(alpha_len, seg_start, seg_end, buffer)``, four (n_robots,) float64 arrays
    in mm: alpha axis to beta axis, the beta collision segment's start and end along the
    beta arm, and the buffer (:func:`robot_buffers`).

    The segment is the union of the spec's segment ``[segment_start_mm,
    segment_end(buffer)]`` and that segment moved along the arm by the robot's
    :func:`segment_shift` (its fibers measured farther out or in than nominal). It thus
    always contains the spec's segment, the body SDSS-V's production planner gives every
    robot whatever its fibers (``sdss-v-production``: from the beta axis to
    ``16.2 - (sqrt(cb^2 + 0.3^2) - 0.55)`` mm), and is longer than it by ``|shift|``
    (by ``max(shift, 0)`` when the spec's segment starts at the beta axis, as
    production's does): stricter than production, never looser.
    """
    buffer = robot_buffers(spec, layout, buffer_mm)
    alpha_len = robot_column(layout, "alpha_len_mm", spec.alpha_length_mm)
    shift = segment_shift(layout)
    start = float(spec.segment_start_mm)
    seg_start = np.maximum(np.minimum(start, start + shift), 0.0)
    ends = np.array([spec.segment_end(b) for b in buffer], dtype=np.float64).reshape(-1)
    seg_end = np.maximum(np.maximum(ends, ends + shift), seg_start)
    if "kz" in layout.extra:
        # a tilted robot's arm, projected on the plane, is shorter by up to L (1 - kz): the
        # planar model is then off by at most that much; the buffer covers it
        kz = robot_column(layout, "kz", 1.0)
        buffer = buffer + (alpha_len + seg_end) * (1.0 - kz)
    return alpha_len, seg_start, seg_end, buffer


def production_body_layout(layout):
    """``layout`` without its fiber columns (a new Layout named ``<name>-production``):
    every robot's beta collision segment is then the spec's, the body SDSS-V's production
    planner gives every robot, while its base, alpha arm, buffer, offsets and the
    obstacles stay. Checking a trajectory on it measures clearance under production's
    rule (:func:`robot_collision_arrays` explains why ours contains it)."""
    import dataclasses

    fibers = {c for cols in FIBER_COLUMNS.values() for c in cols}
    extra = {k: v for k, v in layout.extra.items() if k not in fibers}
    return dataclasses.replace(layout, extra=extra, name=f"{layout.name}-production")


def obstacle_arrays(spec, layout):
    """The obstacles (non-robot rows, layout order) as buffered segments.

    Returns ``(a, b, buffer)``: (m, 2) first ends, (m, 2) second ends (== ``a`` for a
    point obstacle such as a fiducial), mm, and (m,) keep-out radii, mm.
    """
    a = np.ascontiguousarray(layout.fiducial_xy, dtype=np.float64).reshape(-1, 2)
    b = a.copy()
    b[:, 0] = obstacle_column(layout, "x2_mm", math.nan)
    b[:, 1] = obstacle_column(layout, "y2_mm", math.nan)
    point = np.isnan(b).any(axis=1)
    b[point] = a[point]
    return a, b, obstacle_column(layout, "obstacle_buffer_mm", spec.fiducial_buffer_mm)


#: Largest departure of a layout axis ``(kx, ky, kz)`` from unit length (it is normalised).
AXIS_TOL = 1e-3


def robot_axes(layout) -> np.ndarray:
    """(n_robots, 3) float64 unit axis of each robot (columns ``kx, ky, kz``, blank +z),
    normalised; LayoutError naming the robot for one that is not unit within AXIS_TOL."""
    k = np.column_stack([robot_column(layout, c, d) for c, d in (("kx", 0.0), ("ky", 0.0),
                                                                 ("kz", 1.0))])
    norm = np.sqrt((k * k).sum(axis=1))
    bad = np.flatnonzero(np.abs(norm - 1.0) > AXIS_TOL)
    if bad.size:
        r = int(bad[0])
        raise LayoutError(f"{layout.name}: robot {int(layout.robot_ids[r])} fields 'kx, ky, kz' "
                          f"= {k[r].tolist()} (length {norm[r]:.6f}); allowed: a unit vector "
                          f"(within {AXIS_TOL}) or blank")
    return k / norm[:, None]


def robot_joint_limits(spec, layout) -> np.ndarray:
    """(n_robots, 4) float64 travel range of each robot in model angles, deg:
    ``(alpha_lo, alpha_hi, beta_lo, beta_hi)``. The spec's ranges are the firmware's, in
    encoder angles; a robot whose encoder zero sits at ``alpha_offset_deg`` /
    ``beta_offset_deg`` (model = encoder + offset) has them shifted by its offsets.
    Blank offsets: the spec's ranges, bit for bit."""
    lim = np.array([*spec.alpha_limits_deg, *spec.beta_limits_deg], dtype=np.float64)
    out = np.tile(lim, (layout.n_robots, 1))
    for name, cols in (("alpha_offset_deg", (0, 1)), ("beta_offset_deg", (2, 3))):
        if name in layout.extra:
            off = robot_column(layout, name, 0.0)
            out[:, cols[0]] += off
            out[:, cols[1]] += off
    return out


def fit_to_limits(angles: np.ndarray, limits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Configurations moved into each robot's travel range where a turn of alpha allows.

    angles : (n, 2) float64 (alpha, beta) deg; limits : (n, 4) float64 from
    :func:`robot_joint_limits`. Returns ``(fitted, inside)``: alpha shifted by a whole
    number of turns to the lowest value >= ``alpha_lo`` (the same arm pose), beta
    unchanged; ``inside`` (n,) bool where the fitted row is within both ranges (a beta
    outside its range cannot be fixed: that pose is out of the robot's reach).
    More dimensions broadcast: angles (..., 2) with limits (..., 4), e.g. (r, k, 2) draws
    of r robots with their limits as (r, 1, 4); ``inside`` is then (..., )."""
    a = np.array(angles, dtype=np.float64, copy=True)
    if a.ndim < 2:
        a = a.reshape(-1, 2)
    lo = limits[..., 0]
    a[..., 0] = lo + np.mod(a[..., 0] - lo, 360.0)
    inside = ((a[..., 0] <= limits[..., 1]) & (a[..., 1] >= limits[..., 2])
              & (a[..., 1] <= limits[..., 3]))
    return a, inside


def robot_frame_origins(layout, fiber_z_mm: float, axes: np.ndarray | None = None) -> np.ndarray:
    """(n_robots, 3) float64 origin of each robot's frame, mm: the point of its alpha axis
    ``fiber_z_mm`` below its focal-surface point ``(x, y, z_mm)`` (the robot stands on its
    axis ``k``, its fibers at the surface): ``(x, y, z_mm) - fiber_z_mm (k - e_z)``, height
    relative to the flat wok's robot frames. Exactly ``(x, y, z_mm)`` for an upright robot.
    ``axes``: :func:`robot_axes` of the layout when the caller already has it."""
    k = robot_axes(layout) if axes is None else axes
    out = np.column_stack([layout.robot_xy, robot_column(layout, "z_mm", 0.0)]).reshape(-1, 3)
    tilted = (k[:, 0] != 0.0) | (k[:, 1] != 0.0)
    k_minus_z = k[tilted] - np.array([0.0, 0.0, 1.0])
    out[tilted] -= float(fiber_z_mm) * k_minus_z
    return out
