"""The robot and fiducial bodies of the MuJoCo grid model, with their meshes and servos.

Units inside the model: mm, kg, s, radians. One body tree per robot::

    r<id>            static, at the robot base, z so that the fiber tips lie on the focal
                     surface; fixed-body mesh
      r<id>_alpha    hinge ``r<id>_alpha`` about z on the alpha axis
        r<id>_beta   hinge ``r<id>_beta`` about z at ``l_alpha`` along the alpha arm;
                     sites ``r<id>_<fiber>`` at the fiber tips

plus ``fid<id>`` static bodies for the obstacles (fiducials and guide-camera edges). Each
hinge has a position actuator (``r<id>_alpha`` / ``r<id>_beta``) with gains from
:class:`ServoParams` for the joint's inertia (armature + link) and a torque limit; joint
ranges are each robot's travel limits (the spec's, shifted by its encoder offsets:
:func:`rfp_twin.models.layout.columns.robot_joint_limits`). Visual geoms use the ``visual`` default class (the
link's watertight trimesh), collision geoms the ``collision`` class (its convex pieces), as
mujoco_menagerie does.

Each robot's own geometry (layout columns, :mod:`rfp_twin.models.layout.columns`;
:func:`robot_frames`): its alpha arm ``alpha_len_mm`` puts its beta body (the beta hinge)
at that distance along the alpha arm; the alpha link's *mesh* stays the nominal one (it
differs by at most 0.1 mm on the calibrated instruments; only the joint axis moves). Its
fibers get sites where it carries them (``robot_fibers``: none where a fiber is not
carried). The whole robot is tilted so that its alpha axis is along ``(kx, ky, kz)`` (the
smallest rotation taking z to that axis: the arm's alpha = 0 direction stays as close to +x
as the tilt allows) and stands on that axis so that its axis meets the focal surface at the
layout's ``(x_mm, y_mm)``, ``z_mm`` above the flat focal plane: its base is ``fiber_z_mm``
back along the axis from there (:func:`rfp_twin.models.layout.columns.robot_frame_origins`).
Blank columns give the nominal robot, bit for bit.

Obstacles (:func:`obstacle_shapes`): a point obstacle (a fiducial) is the fiducial post at
its xy; a segment obstacle (a ``gfa`` row with ``x2_mm, y2_mm``: a guide-camera chip edge)
is a thin wall along the segment, a box ``2 * fiducial_radius_mm`` thick (the same estimate
as the posts, inside the keep-out), reaching ``fiducial_radius_mm`` past both ends, over the
height of the beta arms (the beta link's z range, :data:`SLAB_Z_MARGIN_MM` more each way):
only beta arms collide with it, as only beta arms are checked against obstacles in 2D.
The layout gives no obstacle heights: each obstacle stands at the ``z_mm`` of the robot
nearest to it (its midpoint for a segment; 0 on flat layouts).

Robots and obstacles are added into small specs that are then merged into the grid's
(:func:`rfp_twin.models.mjcf.blocks.add_in_blocks`): MuJoCo re-lists a spec's whole tree on
every add, so adding 12,852 robots into one spec would take O(n^2).

Contact filtering (contype / conaffinity bits): beta pieces collide with beta pieces;
alpha pieces with beta pieces, and with alpha pieces only where two alpha arms of the
layout can touch (:func:`rfp_twin.models.mjcf.tiles.alpha_arms_meet`; never on SDSS-V's or
the raft's pitch, and testing them cost a third of a step's collision time); fiducials with
alpha and beta pieces, guide-camera walls with beta pieces; fixed bodies and the plate with
nothing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh

from rfp_twin.models.geometry import RobotGeometry
from rfp_twin.models.layout import Layout
from rfp_twin.models.layout.columns import (FIBERS, obstacle_arrays, robot_axes, robot_column,
                                            robot_fibers, robot_frame_origins,
                                            robot_joint_limits)
from rfp_twin.models.mjcf.blocks import add_in_blocks
from rfp_twin.models.mjcf.tiles import alpha_arms_meet
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


_Z_AXIS = [0.0, 0.0, 1.0]

#: Height added below and above the beta link's z range for a guide-camera wall, mm
#: (estimate: covers a robot tilted by 2 deg, whose arm tip then rises or sinks by 0.8 mm,
#: and the height change of a curved wok along a chip edge).
SLAB_Z_MARGIN_MM = 2.0


@dataclass(frozen=True)
class RobotFrames:
    """Each robot's own placement and fibers, layout robot order (mm).

    alpha_len : (n,) float64, alpha axis to beta hinge
    z : (n,) float64, height of the robot's focal-surface point above a flat wok's
    origin : (n, 3) float64, robot frame origin relative to the nominal robot frames'
        height (:func:`rfp_twin.models.layout.columns.robot_frame_origins`)
    quat : (n, 4) float64, (w, x, y, z) rotation taking +z to the robot's axis
    tilted : (n,) bool, rows whose axis is not +z (their ``quat`` is applied)
    fibers : (n, k, 2) float64, fiber (x, y) in the beta frame per name of the geometry's
        fibers (same order); NaN where the robot does not carry it
    """

    alpha_len: np.ndarray
    z: np.ndarray
    origin: np.ndarray
    quat: np.ndarray
    tilted: np.ndarray
    fibers: np.ndarray


def robot_frames(layout: Layout, geometry: RobotGeometry) -> RobotFrames:
    """:class:`RobotFrames` from the layout's columns (blank: the geometry's values).

    Raises
    ------
    LayoutError
        An axis ``(kx, ky, kz)`` that is not a unit vector (within
        :data:`rfp_twin.models.layout.columns.AXIS_TOL`).
    """
    n = layout.n_robots
    p = geometry.params
    la = robot_column(layout, "alpha_len_mm", float(geometry.link_offset("beta")[0]))
    z = robot_column(layout, "z_mm", 0.0)
    k = robot_axes(layout)
    tilted = (k[:, 0] != 0.0) | (k[:, 1] != 0.0)
    quat = np.zeros((n, 4))
    quat[:, 0] = 1.0
    u = k[tilted]
    # half-way quaternion of z -> u: (1 + z.u, z x u), normalised
    q = np.column_stack([1.0 + u[:, 2], -u[:, 1], u[:, 0], np.zeros(len(u))])
    quat[tilted] = q / np.sqrt((q * q).sum(axis=1))[:, None]
    own = robot_fibers(layout, {f: (x, y) for f, x, y in p.fibers if f in FIBERS})
    fibers = np.empty((n, len(p.fibers), 2))
    for c, (f, x, y) in enumerate(p.fibers):
        fibers[:, c] = own[:, FIBERS.index(f)] if f in FIBERS else (x, y)
    origin = robot_frame_origins(layout, p.fiber_z_mm, k)
    return RobotFrames(la, z, origin, quat, tilted, fibers)


@dataclass(frozen=True)
class ObstacleShapes:
    """The obstacles of a layout (non-robot rows, layout order) as the model draws them, mm.

    a, b : (m, 2) float64, ends (``a == b``: a point, drawn as a fiducial post at ``a``)
    z : (m,) float64, height of the obstacle's frame above the nominal robot frames
    slab_z : (2,) float64, z range of a wall (robot frame, before ``z``)
    half_width : float, half thickness of a wall
    """

    a: np.ndarray
    b: np.ndarray
    z: np.ndarray
    slab_z: np.ndarray
    half_width: float

    @property
    def segment(self) -> np.ndarray:
        """(m,) bool, True for the walls (segment obstacles)."""
        return np.any(self.a != self.b, axis=1)

    def slab_box(self, f: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Wall ``f`` as a box in its body frame (origin at ``a[f]``, height ``z[f]``):
        (centre (3,), half sizes (3,), quaternion (w, x, y, z) about z), mm."""
        d = self.b[f] - self.a[f]
        length = float(np.hypot(d[0], d[1]))
        yaw = math.atan2(d[1], d[0])
        z0, z1 = float(self.slab_z[0]), float(self.slab_z[1])
        centre = np.array([d[0] / 2.0, d[1] / 2.0, (z0 + z1) / 2.0])
        half = np.array([length / 2.0 + self.half_width, self.half_width, (z1 - z0) / 2.0])
        return centre, half, np.array([math.cos(yaw / 2.0), 0.0, 0.0, math.sin(yaw / 2.0)])


def obstacle_shapes(spec: RobotSpec, layout: Layout, geometry: RobotGeometry,
                    robot_z: np.ndarray) -> ObstacleShapes:
    """:class:`ObstacleShapes` of the layout (:func:`obstacle_arrays`); ``robot_z`` (n,) mm
    the robots' base heights (an obstacle stands at its nearest robot's)."""
    a, b, _ = obstacle_arrays(spec, layout)
    z = np.zeros(len(a))
    if len(a) and layout.n_robots and np.any(robot_z != 0.0):
        ref = (a + b) / 2.0
        d2 = ((ref[:, None, :] - layout.robot_xy[None, :, :]) ** 2).sum(axis=2)
        z = np.asarray(robot_z, dtype=np.float64)[np.argmin(d2, axis=1)]
    oz = float(geometry.link_offset("alpha")[2] + geometry.link_offset("beta")[2])
    vz = np.concatenate([np.asarray(m.vertices)[:, 2] for m in geometry.links["beta"].collision])
    slab_z = np.array([vz.min() + oz - SLAB_Z_MARGIN_MM, vz.max() + oz + SLAB_Z_MARGIN_MM])
    return ObstacleShapes(a, b, z, slab_z, float(geometry.params.fiducial_radius_mm))


def add_grid(s: mujoco.MjSpec, spec: RobotSpec, layout: Layout, geometry: RobotGeometry,
             servo: ServoParams, collide_alpha: bool, base_z: float, vis, col,
             mesh_files: dict | None, progress=None, robot_visuals: bool = True) -> None:
    """Add materials, mesh assets, one body tree + two actuators per robot and one body
    per obstacle; robot frames at height ``base_z`` mm (plus each robot's ``z_mm``).
    ``progress(robots_added)`` is called as the robots are added (in blocks);
    ``robot_visuals`` False leaves the robots' visual meshes out (simulation only)."""
    p = geometry.params
    frames = robot_frames(layout, geometry)
    obstacles = obstacle_shapes(spec, layout, geometry, frames.z)
    posts = bool(layout.n_fiducials) and not obstacles.segment.all()
    # materials and meshes (one asset per link piece, shared by every robot)
    for key, rgba in RGBA.items():
        s.add_material(name=key, rgba=list(rgba))
    used = ["body", "alpha", "beta"] + (["fiducial"] if posts else [])
    colliding = ["beta"] + (["alpha"] if collide_alpha else []) \
        + (["fiducial"] if posts else [])
    vis_mesh = {n: _add_mesh(s, f"{n}_visual", geometry.links[n].visual, mesh_files) for n in used}
    col_mesh = {n: [_add_mesh(s, f"{n}_collision_{k}", piece, mesh_files)
                    for k, piece in enumerate(geometry.links[n].collision)]
                for n in colliding}

    # joint inertia for the servo gains (armature dominates)
    a_mass, a_com, a_full = _inertial(geometry.links["alpha"].visual, p.density_kg_mm3)
    b_mass, b_com, b_full = _inertial(geometry.links["beta"].visual, p.density_kg_mm3)
    j_beta = servo.armature_kg_mm2 + _axis_inertia(b_mass, b_com, b_full)

    def alpha_gains(l_alpha: float) -> tuple[float, float]:
        return servo.gains(servo.armature_kg_mm2 + _axis_inertia(a_mass, a_com, a_full)
                           + _axis_inertia(b_mass, b_com, b_full, (-l_alpha, 0.0)))

    nominal_la = float(geometry.link_offset("beta")[0])
    gains = {"alpha": {nominal_la: alpha_gains(spec.alpha_length_mm)},
             "beta": servo.gains(j_beta)}
    torque = servo.torque_limit_mNm * MNM
    alpha = _MovingLink("alpha", list(geometry.link_offset("alpha")), (a_mass, a_com, a_full),
                        list(np.radians(spec.alpha_limits_deg)), vis_mesh["alpha"],
                        col_mesh["alpha"] if collide_alpha else [],
                        BIT_ALPHA if collide_alpha else 0,
                        (BIT_ALPHA | BIT_BETA) if alpha_arms_meet(layout, geometry) else BIT_BETA)
    beta = _MovingLink("beta", list(geometry.link_offset("beta")), (b_mass, b_com, b_full),
                       list(np.radians(spec.beta_limits_deg)), vis_mesh["beta"],
                       col_mesh["beta"], BIT_BETA, BIT_BETA)
    limits = robot_joint_limits(spec, layout)     # (n, 4) each robot's range, model deg
    fiber_rgba = [list(FIBER_RGBA.get(f, DEFAULT_FIBER_RGBA)) for f, _, _ in p.fibers]

    def add_robot(blk: mujoco.MjSpec, k: int) -> None:
        rid = int(layout.robot_ids[k])
        la = float(frames.alpha_len[k])
        x, y, z = (float(v) for v in frames.origin[k])
        base = blk.worldbody.add_body()
        base.name = robot_name(rid)
        base.pos = [x, y, base_z + z]
        if frames.tilted[k]:
            base.quat = list(frames.quat[k])
        if robot_visuals:
            geom = base.add_geom(vis)
            geom.name = robot_name(rid, "body")
            geom.meshname = vis_mesh["body"]
            geom.material = "body"
        link_vis = vis if robot_visuals else None
        alpha_body = _add_moving_link(base, rid, alpha, servo.armature_kg_mm2, link_vis, col,
                                      range_rad=list(np.radians(limits[k, 0:2])))
        beta_body = _add_moving_link(alpha_body, rid, beta, servo.armature_kg_mm2, link_vis, col,
                                     pos=[la, *beta.pos[1:]],
                                     range_rad=list(np.radians(limits[k, 2:4])))
        for c, (fname, _, _) in enumerate(p.fibers):
            fx, fy = (float(v) for v in frames.fibers[k, c])
            if math.isnan(fx):
                continue                        # this robot does not carry that fiber
            site = beta_body.add_site()
            site.name = robot_name(rid, fname)
            site.pos = [fx, fy, p.fiber_height_mm]
            site.type = mujoco.mjtGeom.mjGEOM_CYLINDER
            site.size = [p.fiber_radius_mm, 0.02, 0.0]
            site.rgba = fiber_rgba[c]
        if la not in gains["alpha"]:
            gains["alpha"][la] = alpha_gains(la)
        for axis in ("alpha", "beta"):
            kp, kv = gains["alpha"][la] if axis == "alpha" else gains["beta"]
            act = blk.add_actuator()
            act.name = act.target = robot_name(rid, axis)
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.set_to_position(kp=kp, kv=kv)
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.forcerange = [-torque, torque]

    def add_obstacle(blk: mujoco.MjSpec, f: int) -> None:
        name = fiducial_name(int(layout.fiducial_ids[f]))
        x, y = (float(v) for v in obstacles.a[f])
        fb = blk.worldbody.add_body(name=name, pos=[x, y, base_z + float(obstacles.z[f])])
        if obstacles.segment[f]:
            _add_wall(fb, name, *obstacles.slab_box(f), vis, col)
            return
        fb.add_geom(default=vis, name=f"{name}_visual", meshname=vis_mesh["fiducial"],
                    material="fiducial")
        for c, mname in enumerate(col_mesh["fiducial"]):
            fb.add_geom(default=col, name=f"{name}_c{c}", meshname=mname,
                        contype=0, conaffinity=BIT_ALPHA | BIT_BETA)

    # in blocks: an add costs O(size of its spec) (models/mjcf/blocks.py)
    add_in_blocks(s, layout.n_robots, add_robot, progress)
    add_in_blocks(s, layout.n_fiducials, add_obstacle, grid_first=False)


def _add_wall(body, name: str, centre, half, quat, vis, col) -> None:
    """A guide-camera wall: one box, visual and collision (beta arms only)."""
    box = mujoco.mjtGeom.mjGEOM_BOX
    for cls, suffix, extra in ((vis, "visual", {"material": "fiducial"}),
                               (col, "c0", {"contype": 0, "conaffinity": BIT_BETA})):
        body.add_geom(default=cls, name=f"{name}_{suffix}", type=box, size=list(half),
                      pos=list(centre), quat=list(quat), **extra)


def _add_moving_link(parent, rid: int, link: _MovingLink, armature: float, vis, col,
                     pos: list | None = None, range_rad: list | None = None):
    """Robot ``rid``'s alpha or beta body under ``parent`` (at ``pos`` mm, default
    ``link.pos``): inertial, hinge about z with range ``range_rad`` (default
    ``link.range_rad``), visual geom and collision geoms. Returns the body."""
    # attribute assignment: a third faster than keyword arguments of add_* (12,852 robots)
    body = parent.add_body()
    body.name = robot_name(rid, link.name)
    body.pos = link.pos if pos is None else pos
    mass, com, full = link.inertial
    body.explicitinertial = True
    body.mass = mass
    body.ipos = com
    body.fullinertia = full
    joint = body.add_joint()
    joint.name = body.name
    joint.type = mujoco.mjtJoint.mjJNT_HINGE
    joint.axis = _Z_AXIS
    joint.range = link.range_rad if range_rad is None else range_rad
    joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    joint.armature = armature
    if vis is not None:                       # None: no visual mesh (simulation only)
        geom = body.add_geom(vis)
        geom.name = robot_name(rid, f"{link.name}_visual")
        geom.meshname = link.visual_mesh
        geom.material = link.name
    for k, mname in enumerate(link.collision_meshes):
        geom = body.add_geom(col)
        geom.name = robot_name(rid, f"{link.name}_c{k}")
        geom.meshname = mname
        geom.contype = link.contype
        geom.conaffinity = link.conaffinity
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
