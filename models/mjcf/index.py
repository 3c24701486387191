"""Ids of the compiled MuJoCo grid model, per robot index (layout robot order).

:class:`ModelIndex` maps robots and fiducials to body, joint, actuator, site and geom
ids of an ``mujoco.MjModel``, as int64 arrays: ``(n,)`` per robot, ``(n, 2)`` per
(alpha, beta) axis, ``(n, k)`` per fiber, ``(ngeom,)`` per geom.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf.options import CAMERAS, COLLISION_GROUP, fiducial_name, robot_name


@dataclass(frozen=True)
class ModelIndex:
    """Ids in the compiled MjModel, per robot index (layout robot order).

    Attributes
    ----------
    robot_ids : (n,) int64
    base_body, alpha_body, beta_body : (n,) int body ids
    alpha_joint, beta_joint : (n,) joint ids
    qpos_adr : (n, 2) qpos addresses of (alpha, beta); dof_adr : (n, 2) dof addresses
    actuator : (n, 2) actuator ids of (alpha, beta)
    fiber_site : (n, k) site ids of the fibers, columns in ``fiber_names`` order; -1 where
        the robot does not carry that fiber (a calibrated instrument: no site)
    fiber_names : tuple of k str
    geom_robot : (ngeom,) robot index owning each geom, -1 for none
    geom_fiducial : (ngeom,) fiducial index owning each geom, -1 for none
    geom_collision : (ngeom,) bool, True for collision-class geoms
    fiducial_ids : (m,) int64; fiducial_body : (m,) body ids
    camera : dict name -> camera id
    """

    robot_ids: np.ndarray
    base_body: np.ndarray
    alpha_body: np.ndarray
    beta_body: np.ndarray
    alpha_joint: np.ndarray
    beta_joint: np.ndarray
    qpos_adr: np.ndarray
    dof_adr: np.ndarray
    actuator: np.ndarray
    fiber_site: np.ndarray
    fiber_names: tuple[str, ...]
    geom_robot: np.ndarray
    geom_fiducial: np.ndarray
    geom_collision: np.ndarray
    fiducial_ids: np.ndarray
    fiducial_body: np.ndarray
    camera: dict[str, int] = field(default_factory=dict)

    @property
    def n_robots(self) -> int:
        return int(self.robot_ids.size)

    def robot_geoms(self, robot_index: int, collision: bool | None = None) -> np.ndarray:
        """Geom ids of one robot (all, or only collision / only visual)."""
        mask = self.geom_robot == robot_index
        if collision is not None:
            mask &= self.geom_collision == collision
        return np.flatnonzero(mask)

    @classmethod
    def from_model(cls, m: mujoco.MjModel, layout: Layout, fiber_names: tuple[str, ...]) -> ModelIndex:
        ids = np.asarray(layout.robot_ids, dtype=np.int64)
        fids = np.asarray(layout.fiducial_ids, dtype=np.int64)
        obj = mujoco.mjtObj

        def ident(kind, name):
            i = mujoco.mj_name2id(m, kind, name)
            if i < 0:
                raise KeyError(name)
            return i

        def site(name):
            return mujoco.mj_name2id(m, obj.mjOBJ_SITE, name)   # -1: fiber not carried

        body = lambda n: ident(obj.mjOBJ_BODY, n)  # noqa: E731
        joint = lambda n: ident(obj.mjOBJ_JOINT, n)  # noqa: E731
        aj = np.array([joint(robot_name(r, "alpha")) for r in ids], dtype=np.int64)
        bj = np.array([joint(robot_name(r, "beta")) for r in ids], dtype=np.int64)
        base = np.array([body(robot_name(r)) for r in ids], dtype=np.int64)
        fbody = np.array([body(fiducial_name(f)) for f in fids], dtype=np.int64)
        robot_of_body = np.full(m.nbody, -1, dtype=np.int64)
        for k in range(ids.size):
            robot_of_body[base[k]] = k
        fid_of_body = np.full(m.nbody, -1, dtype=np.int64)
        fid_of_body[fbody] = np.arange(fids.size)
        # walk up the tree: every body below a robot base belongs to that robot
        for b in range(m.nbody):
            p = b
            while p > 0 and robot_of_body[p] < 0:
                p = m.body_parentid[p]
            robot_of_body[b] = robot_of_body[p] if p > 0 else -1
        geom_body = np.asarray(m.geom_bodyid)
        return cls(
            robot_ids=ids, base_body=base,
            alpha_body=np.array([body(robot_name(r, "alpha")) for r in ids], dtype=np.int64),
            beta_body=np.array([body(robot_name(r, "beta")) for r in ids], dtype=np.int64),
            alpha_joint=aj, beta_joint=bj,
            qpos_adr=np.column_stack([m.jnt_qposadr[aj], m.jnt_qposadr[bj]]).astype(np.int64),
            dof_adr=np.column_stack([m.jnt_dofadr[aj], m.jnt_dofadr[bj]]).astype(np.int64),
            actuator=np.array([[ident(obj.mjOBJ_ACTUATOR, robot_name(r, "alpha")),
                                ident(obj.mjOBJ_ACTUATOR, robot_name(r, "beta"))] for r in ids],
                              dtype=np.int64).reshape(-1, 2),
            fiber_site=np.array([[site(robot_name(r, f)) for f in fiber_names]
                                 for r in ids], dtype=np.int64).reshape(ids.size, len(fiber_names)),
            fiber_names=tuple(fiber_names),
            geom_robot=robot_of_body[geom_body],
            geom_fiducial=fid_of_body[geom_body],
            geom_collision=np.asarray(m.geom_group) == COLLISION_GROUP,
            fiducial_ids=fids, fiducial_body=fbody,
            camera={c: ident(obj.mjOBJ_CAMERA, c) for c in CAMERAS},
        )
