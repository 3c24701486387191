"""Cameras, lights and the focal plate of the MuJoCo grid model.

Positions in mm (world frame, z up), quaternions ``(w, x, y, z)``. Three cameras:
``top`` (looking down on the whole grid), ``oblique`` (from the south) and ``closeup``
(one robot, from the south-west; :func:`closeup_pose`).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from rfp_twin.models.geometry import GeometryParams
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import robot_column
from rfp_twin.models.robot import RobotSpec


def look_at_quat(pos: np.ndarray, target: np.ndarray, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Quaternion (w, x, y, z) of a MuJoCo camera at ``pos`` looking at ``target``
    (cameras look along their -z axis, y up)."""
    z = np.asarray(pos, float) - np.asarray(target, float)
    z /= np.linalg.norm(z)
    up = np.asarray(up, float)
    if abs(np.dot(up, z)) > 0.999:
        up = np.array([0.0, 1.0, 0.0])
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    mat = np.column_stack([x, y, z])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, mat.ravel())
    return quat


def quat_to_mat(quat: np.ndarray) -> np.ndarray:
    """3x3 rotation matrix of a quaternion (w, x, y, z)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(quat, float))
    return mat.reshape(3, 3)


def closeup_pose(base_world: np.ndarray, spec: RobotSpec, distance_mm: float | None = None):
    """(pos, quat) of a camera looking at a robot whose frame origin is ``base_world``."""
    reach = spec.alpha_length_mm + spec.beta_length_mm
    dist = distance_mm if distance_mm is not None else 3.0 * reach
    target = base_world + np.array([0.0, 0.0, 3.0])
    pos = target + dist * np.array([-0.5, -0.6, 0.62])
    return pos, look_at_quat(pos, target)


def add_scene(s: mujoco.MjSpec, spec: RobotSpec, layout: Layout, p: GeometryParams,
              base_z: float, closeup_robot: int | None, visual_class) -> None:
    """Add the focal plate (a box below the fixed bodies), two directional lights, the
    three cameras and the visual / statistic settings that frame the grid."""
    world = s.worldbody
    xy = np.asarray(layout.xy, float)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    centre = (lo + hi) / 2.0
    margin = spec.pitch_mm
    half = (hi - lo) / 2.0 + margin
    plate_top = base_z - p.body_length_mm
    world.add_geom(default=visual_class, name="focal_plate", type=mujoco.mjtGeom.mjGEOM_BOX,
                   size=[float(half[0]), float(half[1]), p.plate_thickness_mm / 2.0],
                   pos=[float(centre[0]), float(centre[1]), plate_top - p.plate_thickness_mm / 2.0],
                   material="plate")
    extent = float(max(half.max(), spec.pitch_mm))
    top = np.array([centre[0], centre[1], p.focal_z_mm])
    for name, direction, diffuse, specular in (
            ("sun", [0.3, 0.2, -1.0], [0.7, 0.7, 0.7], [0.2, 0.2, 0.2]),
            ("fill", [-0.4, -0.3, -0.6], [0.3, 0.3, 0.35], [0.0, 0.0, 0.0])):
        world.add_light(name=name, type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                        pos=[float(centre[0]), float(centre[1]), p.focal_z_mm + 4 * extent],
                        dir=direction, diffuse=diffuse, specular=specular, castshadow=False)
    fovy = 45.0
    top_pos = top + np.array([0.0, 0.0, 1.15 * extent / math.tan(math.radians(fovy / 2))])
    world.add_camera(name="top", pos=list(top_pos), quat=list(look_at_quat(top_pos, top, (0, 1, 0))),
                     fovy=fovy)
    obl_pos = top + extent * np.array([0.0, -1.6, 1.3])
    world.add_camera(name="oblique", pos=list(obl_pos), quat=list(look_at_quat(obl_pos, top)),
                     fovy=fovy)
    k_close = _closeup_index(layout, closeup_robot, centre)
    cx, cy = layout.robot_xy[k_close]
    cz = base_z + float(robot_column(layout, "z_mm", 0.0)[k_close])    # its own base height
    c_pos, c_quat = closeup_pose(np.array([cx, cy, cz]), spec)
    world.add_camera(name="closeup", pos=list(c_pos), quat=list(c_quat), fovy=fovy)
    s.visual.global_.offwidth = 1280
    s.visual.global_.offheight = 720
    s.visual.headlight.ambient = [0.25, 0.25, 0.25]
    s.stat.center = [float(centre[0]), float(centre[1]), float(p.focal_z_mm)]
    s.stat.extent = extent


def _closeup_index(layout: Layout, robot_id, centre) -> int:
    """Robot index the close-up camera looks at: ``robot_id``, else nearest ``centre``."""
    if robot_id is not None:
        return layout.robot_index(robot_id)
    return int(np.argmin(np.hypot(*(layout.robot_xy - centre).T)))
