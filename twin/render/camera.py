"""The model frames are drawn from: a render-only copy of the twin with its camera placed
and, for lean renders, its round parts re-meshed. The twin's own model is never changed.

Cameras
-------
The ``top`` and ``oblique`` cameras are moved (orientation and field of view kept) so that
the whole grid fills the frame at its aspect ratio (:func:`fitted_camera`); the
``closeup`` camera can be aimed at one robot.

Lean re-meshing
---------------
On a CPU rasteriser (llvmpipe) the cost of a frame is mostly vertices, then pixels. On the
wide cameras a lean render draws the procedural links with as few facets per circle as
look round at the frame's scale (:func:`lean_circle_sections`: outlines within
:data:`LEAN_SAGITTA_PX` pixel of a circle; at 1280x720, 8 instead of the model's 32 for
the 547-robot grid, 16 for a 7-robot grid).

Units: world positions and distances in mm, frame sizes in pixels, angles in degrees.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from rfp_twin.models.mjcf import TwinModel, build_model
from rfp_twin.models.mjcf.bodies import add_default_classes
from rfp_twin.models.mjcf.cameras import add_scene
from rfp_twin.twin.render.settings import RenderSettings

#: Lean wide-camera renders re-mesh round parts so that their outline departs from a
#: circle by at most this, pixels ...
LEAN_SAGITTA_PX = 1.0
#: ... with at least this many facets per circle.
LEAN_MIN_SECTIONS = 8
#: Margin left around the grid by a fitted camera, fraction of the half-frame.
FIT_MARGIN = 0.04


def fitted_camera(twin: TwinModel, camera: str, aspect: float,
                  margin: float = FIT_MARGIN) -> tuple[np.ndarray, float]:
    """Where a world camera of ``twin.model`` must stand so that the grid fits a frame of
    ``aspect`` = width / height: same orientation and field of view, moved along its view
    axis and sideways so that every base plus the arm reach in 16 directions, at the plate
    and at the focal surface, lands inside the frame less ``margin``, centred
    (:func:`fit_camera_pose` with the twin's spec, layout, geometry and base height).

    Returns
    -------
    (pos (3,), distance): the camera position (world, mm) and its distance from the aim
    point (the grid's centre), mm.
    """
    c = twin.index.camera[camera]
    m = twin.model
    return fit_camera_pose(np.asarray(m.cam_quat[c], float), float(m.cam_fovy[c]), twin.spec,
                           twin.layout, twin.geometry.params, twin.base_z_mm, aspect, margin)


def fit_camera_pose(cam_quat: np.ndarray, fovy_deg: float, spec, layout, params,
                    base_z_mm: float, aspect: float,
                    margin: float = FIT_MARGIN) -> tuple[np.ndarray, float]:
    """:func:`fitted_camera` without a compiled model: a camera of orientation ``cam_quat``
    (4,) (w, x, y, z) and vertical field of view ``fovy_deg`` deg, framing the robots of
    ``layout`` (RobotSpec ``spec``, GeometryParams ``params``, nominal robot frames at
    world height ``base_z_mm`` mm) in a frame of ``aspect`` = width / height.

    Returns (pos (3,) world mm, distance from the aim point mm).
    """
    p = params
    reach = spec.alpha_length_mm + spec.beta_length_mm + p.beta_half_width_mm
    ang = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    ring = reach * np.column_stack([np.cos(ang), np.sin(ang)])
    xy = (np.asarray(layout.xy, float)[:, None, :] + ring[None]).reshape(-1, 2)
    z_lo, z_hi = base_z_mm - p.body_length_mm, p.focal_z_mm
    pts = np.vstack([np.column_stack([xy, np.full(len(xy), z)]) for z in (z_lo, z_hi)])
    target = (pts.min(axis=0) + pts.max(axis=0)) / 2.0
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(cam_quat, float))
    axes = mat.reshape(3, 3)  # columns: camera x (right), y (up), z (backwards)
    ty = math.tan(math.radians(float(fovy_deg)) / 2.0) * (1.0 - margin)
    tx = ty * aspect

    def distance(aim):
        # nearest distance along the view axis at which every point is inside the frame
        rel = (pts - aim) @ axes
        return rel, float(np.max(np.maximum(np.abs(rel[:, 0]) / tx, np.abs(rel[:, 1]) / ty)
                                 + rel[:, 2]))

    for _ in range(4):
        # re-centre: shift the aim so that the projected extent is symmetric
        rel, dist = distance(target)
        depth = dist - rel[:, 2]
        u, v = rel[:, 0] / depth, rel[:, 1] / depth
        target = target + dist * ((u.max() + u.min()) / 2.0 * axes[:, 0]
                                  + (v.max() + v.min()) / 2.0 * axes[:, 1])
    _, dist = distance(target)
    return target + dist * axes[:, 2], dist


def wide_camera_setup(spec, layout, params,
                      settings: RenderSettings) -> tuple[np.ndarray, float, float, float]:
    """The ``settings.camera`` of a render without a compiled grid model (RobotSpec
    ``spec``, Layout ``layout``, GeometryParams ``params``): (position (3,) world mm,
    distance to the grid mm, vertical field of view deg, robot pitch in the frame px), the
    camera as the grid model has it (:func:`rfp_twin.models.mjcf.cameras.add_scene`), moved
    by :func:`fit_camera_pose` when ``settings.fit``."""
    base_z = params.focal_z_mm - params.fiber_z_mm
    probe = mujoco.MjSpec()
    vis, _ = add_default_classes(probe)
    add_scene(probe, spec, layout, params, base_z, None, vis)
    cam = next(c for c in probe.cameras if c.name == settings.camera)
    fovy = float(cam.fovy)
    if settings.fit:
        pos, distance = fit_camera_pose(np.asarray(cam.quat, float), fovy, spec, layout, params,
                                        base_z, settings.width / settings.height)
    else:
        pos = np.asarray(cam.pos, float)
        centre = np.append(np.asarray(layout.xy, float).mean(axis=0), base_z)
        distance = float(np.linalg.norm(pos - centre))
    f = 0.5 * settings.height / math.tan(math.radians(fovy) / 2.0)
    return pos, distance, fovy, f * spec.pitch_mm / max(distance, 1e-9)


def focal_px(model: mujoco.MjModel, camera_id: int, height_px: int) -> float:
    """Focal length in pixels of a camera with the model's vertical field of view, for a
    frame ``height_px`` pixels high."""
    return 0.5 * height_px / math.tan(math.radians(float(model.cam_fovy[camera_id])) / 2.0)


def lean_circle_sections(twin: TwinModel, settings: RenderSettings, distance_mm: float) -> int:
    """Facets per circle for a lean render: the fewest (a multiple of 4, at least
    :data:`LEAN_MIN_SECTIONS`, at most the model's) for which the outline of the widest
    round part (fixed body or alpha hub) seen from ``distance_mm`` departs from a circle
    by at most :data:`LEAN_SAGITTA_PX` pixels (shading stays smooth: MuJoCo smooths the
    normals). :func:`lean_sections_for` without a compiled model."""
    c = twin.index.camera[settings.camera]
    return lean_sections_for(twin.geometry.params, float(twin.model.cam_fovy[c]),
                             settings.height, distance_mm)


def lean_sections_for(params, fovy_deg: float, height_px: int, distance_mm: float) -> int:
    """:func:`lean_circle_sections` of GeometryParams ``params`` seen by a camera of
    vertical field of view ``fovy_deg`` deg in a frame ``height_px`` high from
    ``distance_mm`` mm."""
    p = params
    f = 0.5 * height_px / math.tan(math.radians(float(fovy_deg)) / 2.0)
    radius_px = max(p.body_radius_mm, p.alpha_hub_radius_mm) * f / max(distance_mm, 1e-9)
    if radius_px <= LEAN_SAGITTA_PX:
        n = LEAN_MIN_SECTIONS
    else:
        n = 4 * math.ceil(math.pi / math.acos(1.0 - LEAN_SAGITTA_PX / radius_px) / 4.0 - 1e-9)
    return int(min(p.circle_sections, max(LEAN_MIN_SECTIONS, n)))


def fit_offscreen(m: mujoco.MjModel, settings: RenderSettings) -> None:
    """Size ``m``'s offscreen buffer for the frame and, for lean renders, turn off
    multisampling and use few slices for MuJoCo's own round shapes."""
    m.vis.global_.offwidth = max(int(m.vis.global_.offwidth), settings.width)
    m.vis.global_.offheight = max(int(m.vis.global_.offheight), settings.height)
    if settings.lean:
        m.vis.quality.offsamples = 0
        m.vis.quality.numslices = 12
        m.vis.quality.numstacks = 6
        m.vis.quality.numquads = 1


def render_model(twin: TwinModel, settings: RenderSettings) -> TwinModel:
    """The model frames are drawn from: a copy of the twin's own or, for lean renders with
    the ``top`` / ``oblique`` camera where the robots are small in the frame, the same
    grid with its procedural links re-meshed at fewer facets per circle
    (:func:`lean_circle_sections`; CAD links are kept). Camera poses are copied from the
    twin's model (so an ``aim_closeup`` there carries over), then fitted
    (:func:`fitted_camera`) or aimed (``robot_id``); the offscreen buffer fits the frame.
    """
    geometry = twin.geometry
    wide = settings.wide
    c = twin.index.camera[settings.camera]
    cam_pos = np.array(twin.model.cam_pos[c])
    if wide and settings.fit:
        cam_pos, distance = fitted_camera(twin, settings.camera, settings.width / settings.height)
    else:
        centre = np.append(np.asarray(twin.layout.xy, float).mean(axis=0), twin.base_z_mm)
        distance = float(np.linalg.norm(cam_pos - centre))
    sections = lean_circle_sections(twin, settings, distance) if settings.lean and wide \
        else geometry.params.circle_sections
    if sections < geometry.params.circle_sections:
        rt = build_model(twin.spec, twin.layout, geometry.with_params(circle_sections=sections),
                         twin.options)
    else:
        m = twin.model.__copy__()
        rt = TwinModel(m, twin.mjspec, twin.index, spec=twin.spec, layout=twin.layout,
                       geometry=geometry, options=twin.options, base_z_mm=twin.base_z_mm)
    m = rt.model
    for name in ("cam_pos", "cam_quat", "cam_pos0", "cam_mat0", "cam_fovy"):
        getattr(m, name)[:] = getattr(twin.model, name)
    if wide:
        m.cam_pos[c] = cam_pos
        m.cam_pos0[c] = cam_pos
    elif settings.robot_id is not None:
        rt.aim_closeup(int(settings.robot_id))
    fit_offscreen(m, settings)
    return rt
