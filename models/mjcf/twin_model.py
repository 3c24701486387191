"""The compiled twin: a MuJoCo grid model and what is needed to drive, render or record it.

Angles in degrees at this API (radians inside MuJoCo), positions in mm. Joint angles are
``(n, 2)`` per robot index (alpha, beta); fiber tips ``(n, k, 3)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from rfp_twin.models.geometry import RobotGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf.cameras import closeup_pose, quat_to_mat
from rfp_twin.models.mjcf.index import ModelIndex
from rfp_twin.models.mjcf.options import ModelOptions
from rfp_twin.models.mjcf.tiles import contact_reach_mm
from rfp_twin.models.robot import RobotSpec


@dataclass(kw_only=True)
class ModelInputs:
    """What a twin (:class:`TwinModel`, or a tiled one) was built from, to rebuild or redraw it.

    spec : RobotSpec; layout : Layout; geometry : RobotGeometry; options : ModelOptions
    base_z_mm : float, world z of the nominal robot frame (top face of the fixed bodies); a
        robot with a ``z_mm`` layout column stands that much higher
    """

    spec: RobotSpec
    layout: Layout
    geometry: RobotGeometry
    options: ModelOptions
    base_z_mm: float


@dataclass
class TwinModel(ModelInputs):
    """A compiled grid model and everything needed to drive, render or record it.

    Attributes
    ----------
    model : mujoco.MjModel
    mjspec : mujoco.MjSpec (the spec it was compiled from; None for the tiles of a tiled
        twin, which do not keep it)
    index : ModelIndex
    spec, layout, geometry, options, base_z_mm : what it was built from (:class:`ModelInputs`)
    """

    model: mujoco.MjModel
    mjspec: mujoco.MjSpec | None
    index: ModelIndex

    @property
    def n_robots(self) -> int:
        return self.index.n_robots

    def make_data(self, angles_deg: np.ndarray | None = None) -> mujoco.MjData:
        """New MjData with every robot at ``angles_deg`` (n, 2) (default: the spec's
        fold), actuators holding that position, kinematics computed."""
        d = mujoco.MjData(self.model)
        if angles_deg is None:
            angles_deg = np.tile(np.asarray(self.spec.fold_deg, float), (self.n_robots, 1))
        self.set_angles(d, angles_deg)
        return d

    def set_angles(self, d: mujoco.MjData, angles_deg: np.ndarray, hold: bool = True) -> None:
        """Put every robot at (n, 2) deg, zero velocity; ``hold`` sets the actuator
        targets there too. Runs ``mj_forward``."""
        a = np.radians(np.asarray(angles_deg, dtype=np.float64).reshape(self.n_robots, 2))
        d.qpos[self.index.qpos_adr.ravel()] = a.ravel()
        d.qvel[:] = 0.0
        if hold:
            d.ctrl[self.index.actuator.ravel()] = a.ravel()
        mujoco.mj_forward(self.model, d)

    def angles(self, d: mujoco.MjData) -> np.ndarray:
        """(n, 2) joint angles, deg."""
        return np.degrees(d.qpos[self.index.qpos_adr])

    def fiber_xyz(self, d: mujoco.MjData) -> np.ndarray:
        """(n, k, 3) world positions of the fiber tips, mm (after mj_forward/mj_step); NaN
        where a robot does not carry that fiber."""
        sites = self.index.fiber_site
        xyz = d.site_xpos[sites]
        if (sites < 0).any():
            xyz[sites < 0] = np.nan
        return xyz

    def neighbour_pairs(self) -> np.ndarray:
        """(p, 2) robot index pairs whose parts can touch: bases within twice
        :func:`rfp_twin.models.mjcf.tiles.contact_reach_mm` (the longest alpha arm of the
        layout and, for tilted robots, the sideways shift of their highest point)."""
        return self.layout.neighbour_pairs(2.0 * contact_reach_mm(self.layout, self.geometry))

    def aim_closeup(self, robot_id: int, distance_mm: float | None = None) -> None:
        """Point the ``closeup`` camera at one robot (oblique view from the south-west)."""
        k = self.layout.robot_index(robot_id)
        x, y = self.layout.robot_xy[k]
        z = float(self.model.body_pos[self.index.base_body[k], 2])   # base_z + its z_mm
        pos, quat = closeup_pose(np.array([x, y, z]), self.spec, distance_mm)
        c = self.index.camera["closeup"]
        self.model.cam_pos[c] = pos
        self.model.cam_quat[c] = quat
        self.model.cam_pos0[c] = pos
        self.model.cam_mat0[c] = quat_to_mat(quat).ravel()
