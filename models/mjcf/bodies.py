"""The robot and fiducial bodies of the MuJoCo grid model, with their meshes and servos.

Units inside the model: mm, kg, s, radians. One body tree per robot::

    r<id>            static, at the robot base, z so that the fiber tips lie on the focal
                     surface; fixed-body mesh
      r<id>_alpha    hinge ``r<id>_alpha`` about z on the alpha axis
        r<id>_beta   hinge ``r<id>_beta`` about z at ``l_alpha`` along the alpha arm;
                     sites ``r<id>_<fiber>`` at the fiber tips

plus ``fid<id>`` static bodies for fiducials. Each hinge has a position actuator
(``r<id>_alpha`` / ``r<id>_beta``) with gains from :class:`ServoParams` for the joint's
inertia (armature + link) and a torque limit; joint ranges are the spec's travel limits.
Visual geoms use the ``visual`` default class (the link's watertight trimesh), collision
geoms the ``collision`` class (its convex pieces), as mujoco_menagerie does.

Contact filtering (contype / conaffinity bits): beta pieces collide with beta pieces;
alpha pieces with alpha and beta pieces; fiducials with alpha and beta pieces; fixed
bodies and the plate with nothing.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh

from rfp_twin.models.geometry import RobotGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf.options import (BIT_ALPHA, BIT_BETA, COLLISION_CLASS, COLLISION_GROUP,
                                 DEFAULT_FIBER_RGBA, FIBER_RGBA, MNM, RGBA, VISUAL_CLASS,
                                 VISUAL_GROUP, ServoParams, fiducial_name, robot_name)
from rfp_twin.models.robot import RobotSpec


def add_default_classes(s: mujoco.MjSpec):
    """The ``visual`` and ``collision`` default classes (mujoco_menagerie style)."""
    vis = s.add_default(VISUAL_CLASS, s.default)
    vis.geom.type = mujoco.mjtGeom.mjGEOM_MESH
    vis.geom.contype = 0
    vis.geom.conaffinity = 0
    vis.geom.group = VISUAL_GROUP
    vis.geom.density = 0.0
    col = s.add_default(COLLISION_CLASS, s.default)
    col.geom.type = mujoco.mjtGeom.mjGEOM_MESH
    col.geom.group = COLLISION_GROUP
    col.geom.density = 0.0
    col.geom.rgba = list(RGBA["collision"])
    col.geom.condim = 3
    return vis, col


@dataclass(frozen=True)
class _MovingLink:
    """What every robot's alpha or beta body gets: offset from its parent (mm), inertial
    (mass kg, com (3,) mm, full inertia), joint range (rad), meshes and contact bits."""

    name: str
    pos: list
    inertial: tuple
    range_rad: list
    visual_mesh: str
    collision_meshes: list
    contype: int
    conaffinity: int


def add_grid(s: mujoco.MjSpec, spec: RobotSpec, layout: Layout, geometry: RobotGeometry,
             servo: ServoParams, collide_alpha: bool, base_z: float, vis, col,
             mesh_files: dict | None) -> None:
    """Add materials, mesh assets, one body tree + two actuators per robot and one body
    per fiducial; robot frames at height ``base_z`` mm."""
    p = geometry.params
    # materials and meshes (one asset per link piece, shared by every robot)
    for key, rgba in RGBA.items():
        s.add_material(name=key, rgba=list(rgba))
    used = ["body", "alpha", "beta"] + (["fiducial"] if layout.n_fiducials else [])
    colliding = ["beta"] + (["alpha"] if collide_alpha else []) \
        + (["fiducial"] if layout.n_fiducials else [])
    vis_mesh = {n: _add_mesh(s, f"{n}_visual", geometry.links[n].visual, mesh_files) for n in used}
    col_mesh = {n: [_add_mesh(s, f"{n}_collision_{k}", piece, mesh_files)
                    for k, piece in enumerate(geometry.links[n].collision)]
                for n in colliding}

    # joint inertia for the servo gains (armature dominates)
    a_mass, a_com, a_full = _inertial(geometry.links["alpha"].visual, p.density_kg_mm3)
    b_mass, b_com, b_full = _inertial(geometry.links["beta"].visual, p.density_kg_mm3)
    j_beta = servo.armature_kg_mm2 + _axis_inertia(b_mass, b_com, b_full)
    j_alpha = servo.armature_kg_mm2 + _axis_inertia(a_mass, a_com, a_full) \
        + _axis_inertia(b_mass, b_com, b_full, (-spec.alpha_length_mm, 0.0))
    gains = {"alpha": servo.gains(j_alpha), "beta": servo.gains(j_beta)}
    torque = servo.torque_limit_mNm * MNM
    alpha = _MovingLink("alpha", list(geometry.link_offset("alpha")), (a_mass, a_com, a_full),
                        list(np.radians(spec.alpha_limits_deg)), vis_mesh["alpha"],
                        col_mesh["alpha"] if collide_alpha else [],
                        BIT_ALPHA if collide_alpha else 0, BIT_ALPHA | BIT_BETA)
    beta = _MovingLink("beta", list(geometry.link_offset("beta")), (b_mass, b_com, b_full),
                       list(np.radians(spec.beta_limits_deg)), vis_mesh["beta"],
                       col_mesh["beta"], BIT_BETA, BIT_BETA)
    world = s.worldbody

    for rid, (x, y) in zip(layout.robot_ids, layout.robot_xy):
        rid = int(rid)
        base = world.add_body(name=robot_name(rid), pos=[float(x), float(y), base_z])
        base.add_geom(default=vis, name=robot_name(rid, "body"), meshname=vis_mesh["body"],
                      material="body")
        alpha_body = _add_moving_link(base, rid, alpha, servo.armature_kg_mm2, vis, col)
        beta_body = _add_moving_link(alpha_body, rid, beta, servo.armature_kg_mm2, vis, col)
        for fname, fx, fy in p.fibers:
            beta_body.add_site(name=robot_name(rid, fname), pos=[fx, fy, p.beta_height_mm],
                               type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                               size=[p.fiber_radius_mm, 0.02, 0.0],
                               rgba=list(FIBER_RGBA.get(fname, DEFAULT_FIBER_RGBA)))
        for axis in ("alpha", "beta"):
            kp, kv = gains[axis]
            act = s.add_actuator(name=robot_name(rid, axis), target=robot_name(rid, axis),
                                 trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.set_to_position(kp=kp, kv=kv)
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-torque, torque]

    for fid, (x, y) in zip(layout.fiducial_ids, layout.fiducial_xy):
        fb = world.add_body(name=fiducial_name(int(fid)), pos=[float(x), float(y), base_z])
        fb.add_geom(default=vis, name=f"{fiducial_name(int(fid))}_visual",
                    meshname=vis_mesh["fiducial"], material="fiducial")
        for k, mname in enumerate(col_mesh["fiducial"]):
            fb.add_geom(default=col, name=f"{fiducial_name(int(fid))}_c{k}", meshname=mname,
                        contype=0, conaffinity=BIT_ALPHA | BIT_BETA)


def _add_moving_link(parent, rid: int, link: _MovingLink, armature: float, vis, col):
    """Robot ``rid``'s alpha or beta body under ``parent``: inertial, hinge about z, visual
    geom and collision geoms. Returns the body."""
    body = parent.add_body(name=robot_name(rid, link.name), pos=link.pos)
    mass, com, full = link.inertial
    body.explicitinertial = True
    body.mass = mass
    body.ipos = list(com)
    body.fullinertia = list(full)
    body.add_joint(name=robot_name(rid, link.name), type=mujoco.mjtJoint.mjJNT_HINGE,
                   axis=[0.0, 0.0, 1.0], range=link.range_rad,
                   limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=armature)
    body.add_geom(default=vis, name=robot_name(rid, f"{link.name}_visual"),
                  meshname=link.visual_mesh, material=link.name)
    for k, mname in enumerate(link.collision_meshes):
        body.add_geom(default=col, name=robot_name(rid, f"{link.name}_c{k}"), meshname=mname,
                      contype=link.contype, conaffinity=link.conaffinity)
    return body


def _inertial(mesh: trimesh.Trimesh, density: float):
    """(mass, com (3,), fullinertia [xx, yy, zz, xy, xz, yz]) of a mesh, link frame."""
    m = mesh.copy()
    m.density = density
    mp = m.mass_properties
    inertia = np.asarray(mp["inertia"])  # about the centre of mass
    full = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    return float(mp["mass"]), np.asarray(mp["center_mass"]), full


def _axis_inertia(mass: float, com: np.ndarray, full, offset_xy=(0.0, 0.0)) -> float:
    """Inertia about a z axis through ``offset_xy`` (link frame), kg mm^2."""
    dx, dy = com[0] - offset_xy[0], com[1] - offset_xy[1]
    return float(full[2] + mass * (dx * dx + dy * dy))


def _add_mesh(s: mujoco.MjSpec, name: str, mesh: trimesh.Trimesh, files: dict | None) -> str:
    """A mesh asset, inline or (``files`` given) as ``<name>.stl`` recorded in ``files``."""
    if files is None:
        s.add_mesh(name=name, uservert=np.asarray(mesh.vertices, float).ravel().tolist(),
                   userface=np.asarray(mesh.faces, np.int64).ravel().tolist())
    else:
        fname = f"{name}.stl"
        files[fname] = mesh
        s.add_mesh(name=name, file=fname)
    return name
