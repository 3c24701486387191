"""The grid model for MuJoCo, built with ``mujoco.MjSpec`` (no XML templating).

Units inside the model: millimetres, kilograms, seconds (so torques are kg mm^2 / s^2 =
1e-6 N m, i.e. uN m), angles in radians; the public API here takes mm and degrees.

One body tree per robot::

    r<id>            static, at the robot base, z so that the fiber tips lie on the focal
                     surface (``focal_z_mm`` of the [geometry] table); fixed-body mesh
      r<id>_alpha    hinge ``r<id>_alpha`` about z on the alpha axis
        r<id>_beta   hinge ``r<id>_beta`` about z at ``l_alpha`` along the alpha arm;
                     sites ``r<id>_<fiber>`` at the fiber tips

plus ``fid<id>`` static bodies for fiducials, the focal plate, two lights and three
cameras (``top``, ``oblique``, ``closeup``; :meth:`TwinModel.aim_closeup` points the
close-up at any robot). Each hinge has a position actuator (``r<id>_alpha`` /
``r<id>_beta``) with gains from :class:`ServoParams` and a torque limit; joint ranges
are the spec's travel limits.

Visual and collision geometry use separate default classes, as mujoco_menagerie does:
``visual`` (the link's watertight trimesh, contype/conaffinity 0, group 2) and
``collision`` (the link's convex pieces, group 3). MuJoCo collides meshes as convex
hulls, so collision geoms are the convex pieces from :mod:`models.geometry`.

Contact filtering (contype / conaffinity bits): beta pieces collide with beta pieces;
alpha pieces with alpha and beta pieces; fiducials with alpha and beta pieces; fixed
bodies and the plate with nothing. Same-robot pairs are parent/child or same-body and
MuJoCo filters them. The broadphase only pairs geoms whose boxes overlap, so only robots
whose parts can reach each other (neighbours, Sayres 2021 Eq. 4) ever reach the
narrowphase: :meth:`TwinModel.neighbour_pairs` lists them and tests check that no other
pair makes a contact.
"""
from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import trimesh

from models.errors import SpecError
from models.geometry import RobotGeometry, geometry_for_spec
from models.files import atomic_write_bytes
from models.layout import Layout
from models.robot import RobotSpec, load_tables

# -- constants: every magic string in one place ------------------------------------
VISUAL_CLASS = "visual"
COLLISION_CLASS = "collision"
VISUAL_GROUP = 2
COLLISION_GROUP = 3
#: contype/conaffinity bits.
BIT_BETA = 1
BIT_ALPHA = 2
CAMERAS = ("top", "oblique", "closeup")
MESH_DIR = "meshes"
MODEL_FILE = "rfp-twin.xml"
#: Link colours (rgba).
RGBA = {"body": (0.45, 0.45, 0.48, 1.0), "alpha": (0.25, 0.32, 0.45, 1.0),
        "beta": (0.88, 0.88, 0.84, 1.0), "fiducial": (0.95, 0.65, 0.1, 1.0),
        "plate": (0.12, 0.12, 0.13, 1.0), "collision": (0.8, 0.2, 0.2, 0.4)}
FIBER_RGBA = {"metrology": (0.1, 0.9, 0.2, 1.0), "boss": (0.2, 0.4, 1.0, 1.0),
              "apogee": (1.0, 0.2, 0.2, 1.0)}
DEFAULT_FIBER_RGBA = (0.9, 0.9, 0.2, 1.0)
#: mN m -> model torque units (kg mm^2 / s^2).
MNM = 1e3


@contextlib.contextmanager
def collect_mujoco_warnings():
    """Context manager: MuJoCo warning messages raised inside go to the yielded list
    (instead of stdout / MUJOCO_LOG.TXT); the previous handler is restored after."""
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


def _name(rid: int, part: str = "") -> str:
    return f"r{rid}_{part}" if part else f"r{rid}"


def fiducial_name(fid: int) -> str:
    return f"fid{fid}"


# -- parameters ----------------------------------------------------------------------
@dataclass(frozen=True)
class ServoParams:
    """The position servo of each axis (all estimates: no published SDSS-V figures).

    bandwidth_hz : closed-loop bandwidth; kp = J (2 pi f)^2, kv = 2 zeta sqrt(kp J).
    damping_ratio : zeta.
    armature_kg_mm2 : reflected motor inertia on the joint (rotor ~3e-4 kg mm^2 times a
        ~1000:1 gearbox squared: ~300 kg mm^2); it dominates the tiny link inertia and
        keeps the servo stable at millisecond timesteps.
    torque_limit_mNm : largest actuator torque (a 6 mm motor, ~0.1 mN m, through the
        gearbox at ~50 % efficiency: ~50 mN m).
    Overridable in a preset's ``[actuators]`` table with keys ``servo_bandwidth_hz``,
    ``servo_damping_ratio``, ``armature_kg_mm2``, ``torque_limit_mNm``.
    """

    bandwidth_hz: float = 10.0
    damping_ratio: float = 1.0
    armature_kg_mm2: float = 300.0
    torque_limit_mNm: float = 50.0

    def __post_init__(self) -> None:
        for name in ("bandwidth_hz", "damping_ratio", "armature_kg_mm2", "torque_limit_mNm"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise SpecError(f"field '{name}' = {v!r}; allowed: a finite number > 0")

    def gains(self, inertia_kg_mm2: float) -> tuple[float, float]:
        """(kp, kv) for a joint of total inertia J (armature included), model units."""
        w = 2.0 * math.pi * self.bandwidth_hz
        kp = inertia_kg_mm2 * w * w
        return kp, 2.0 * self.damping_ratio * math.sqrt(kp * inertia_kg_mm2)

    @classmethod
    def from_tables(cls, tables: dict, source: str = "<memory>") -> ServoParams:
        """From the ``[actuators]`` table (only the keys above are read)."""
        table = tables.get("actuators", {})
        keys = {"servo_bandwidth_hz": "bandwidth_hz", "servo_damping_ratio": "damping_ratio",
                "armature_kg_mm2": "armature_kg_mm2", "torque_limit_mNm": "torque_limit_mNm"}
        kwargs = {attr: table[k] for k, attr in keys.items() if isinstance(table, dict) and k in table}
        try:
            return cls(**kwargs)
        except SpecError as exc:
            raise SpecError(f"{source}: [actuators] {exc}") from None


@dataclass(frozen=True)
class ModelOptions:
    """How the MuJoCo model is built.

    timestep_s : physics step (default 4 ms: the servo at 10 Hz has w dt = 0.25; arms move
        < 0.2 mm per step at 30 deg/s, far below the 3 mm arm width).
    integrator : "implicitfast" (handles the servo damping implicitly) or "euler" / "rk4"
        / "implicit".
    servo : ServoParams or None (from the preset's ``[actuators]`` table, else defaults).
    closeup_robot : robot id the ``closeup`` camera looks at (default: nearest the centre).
    collide_alpha : give alpha arms collision geoms (default True; they never touch when
        :meth:`RobotGeometry.alpha_arms_can_touch` is False, and cost little).
    """

    timestep_s: float = 0.004
    integrator: str = "implicitfast"
    servo: ServoParams | None = None
    closeup_robot: int | None = None
    collide_alpha: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.timestep_s, (int, float)) and 1e-5 <= self.timestep_s <= 0.05):
            raise SpecError(f"field 'timestep_s' = {self.timestep_s!r}; allowed: [1e-5, 0.05] s")
        if self.integrator not in _INTEGRATORS:
            raise SpecError(f"field 'integrator' = {self.integrator!r}; allowed: "
                            f"{', '.join(_INTEGRATORS)}")


_INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4,
                "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
                "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}


# -- index of the compiled model ---------------------------------------------------------
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
    fiber_site : (n, k) site ids of the fibers, columns in ``fiber_names`` order
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

        body = lambda n: ident(obj.mjOBJ_BODY, n)  # noqa: E731
        joint = lambda n: ident(obj.mjOBJ_JOINT, n)  # noqa: E731
        aj = np.array([joint(_name(r, "alpha")) for r in ids], dtype=np.int64)
        bj = np.array([joint(_name(r, "beta")) for r in ids], dtype=np.int64)
        base = np.array([body(_name(r)) for r in ids], dtype=np.int64)
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
            alpha_body=np.array([body(_name(r, "alpha")) for r in ids], dtype=np.int64),
            beta_body=np.array([body(_name(r, "beta")) for r in ids], dtype=np.int64),
            alpha_joint=aj, beta_joint=bj,
            qpos_adr=np.column_stack([m.jnt_qposadr[aj], m.jnt_qposadr[bj]]).astype(np.int64),
            dof_adr=np.column_stack([m.jnt_dofadr[aj], m.jnt_dofadr[bj]]).astype(np.int64),
            actuator=np.array([[ident(obj.mjOBJ_ACTUATOR, _name(r, "alpha")),
                                ident(obj.mjOBJ_ACTUATOR, _name(r, "beta"))] for r in ids],
                              dtype=np.int64).reshape(-1, 2),
            fiber_site=np.array([[ident(obj.mjOBJ_SITE, _name(r, f)) for f in fiber_names]
                                 for r in ids], dtype=np.int64).reshape(ids.size, len(fiber_names)),
            fiber_names=tuple(fiber_names),
            geom_robot=robot_of_body[geom_body],
            geom_fiducial=fid_of_body[geom_body],
            geom_collision=np.asarray(m.geom_group) == COLLISION_GROUP,
            fiducial_ids=fids, fiducial_body=fbody,
            camera={c: ident(obj.mjOBJ_CAMERA, c) for c in CAMERAS},
        )


# -- the compiled twin -------------------------------------------------------------
@dataclass
class TwinModel:
    """A compiled grid model and everything needed to drive, render or record it.

    Attributes
    ----------
    model : mujoco.MjModel
    mjspec : mujoco.MjSpec (the spec it was compiled from)
    index : ModelIndex
    spec : RobotSpec; layout : Layout; geometry : RobotGeometry; options : ModelOptions
    base_z_mm : float, world z of every robot frame (top face of the fixed bodies)
    """

    model: mujoco.MjModel
    mjspec: mujoco.MjSpec
    index: ModelIndex
    spec: RobotSpec
    layout: Layout
    geometry: RobotGeometry
    options: ModelOptions
    base_z_mm: float

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
        """(n, k, 3) world positions of the fiber tips, mm (after mj_forward/mj_step)."""
        return d.site_xpos[self.index.fiber_site]

    def neighbour_pairs(self) -> np.ndarray:
        """(p, 2) robot index pairs whose parts can touch (bases within twice the reach
        of the largest moving piece)."""
        reach = max(self.geometry.beta_reach_mm(), self.geometry.alpha_reach_mm())
        return self.layout.neighbour_pairs(2.0 * reach)

    def aim_closeup(self, robot_id: int, distance_mm: float | None = None) -> None:
        """Point the ``closeup`` camera at one robot (oblique view from the south-west)."""
        k = self.layout.robot_index(robot_id)
        x, y = self.layout.robot_xy[k]
        pos, quat = closeup_pose(np.array([x, y, self.base_z_mm]), self.spec, distance_mm)
        c = self.index.camera["closeup"]
        self.model.cam_pos[c] = pos
        self.model.cam_quat[c] = quat
        self.model.cam_pos0[c] = pos
        self.model.cam_mat0[c] = _quat_to_mat(quat).ravel()


# -- camera helpers -----------------------------------------------------------------
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


def _quat_to_mat(quat: np.ndarray) -> np.ndarray:
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


# -- building ------------------------------------------------------------------------
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
    if files is None:
        s.add_mesh(name=name, uservert=np.asarray(mesh.vertices, float).ravel().tolist(),
                   userface=np.asarray(mesh.faces, np.int64).ravel().tolist())
    else:
        fname = f"{name}.stl"
        files[fname] = mesh
        s.add_mesh(name=name, file=fname)
    return name


def build_spec(spec: RobotSpec, layout: Layout, geometry: RobotGeometry | None = None,
               options: ModelOptions | None = None, mesh_files: dict | None = None,
               model_name: str | None = None) -> mujoco.MjSpec:
    """The uncompiled MjSpec of a grid.

    Parameters
    ----------
    spec, layout : the robots and where they stand.
    geometry : RobotGeometry, default :func:`models.geometry.geometry_for_spec`.
    options : ModelOptions.
    mesh_files : dict, optional
        If given, meshes refer to files ``<name>.stl`` (in ``meshdir`` "meshes") and this
        dict is filled with file name -> trimesh for the caller to write; otherwise the
        vertices are inline.

    Raises
    ------
    SpecError
        Geometry that does not fit the layout (alpha arms overlapping at rest).
    """
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    options = options if options is not None else ModelOptions()
    servo = options.servo if options.servo is not None else _servo_for(spec)
    p = geometry.params
    if layout.n_robots == 0:
        raise SpecError(f"layout {layout.name!r}: no robots; allowed: at least one robot")
    s = mujoco.MjSpec()
    s.modelname = model_name or f"rfp-twin-{spec.name}-{layout.name}"
    s.compiler.degree = False
    s.option.timestep = float(options.timestep_s)
    s.option.integrator = _INTEGRATORS[options.integrator]
    s.option.gravity = [0.0, 0.0, -9810.0]  # mm/s^2 (no effect on z hinges)
    if mesh_files is not None:
        s.meshdir = MESH_DIR

    # default classes (mujoco_menagerie style)
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

    # materials and meshes (one asset per link piece, shared by every robot)
    for key, rgba in RGBA.items():
        s.add_material(name=key, rgba=list(rgba))
    used = ["body", "alpha", "beta"] + (["fiducial"] if layout.n_fiducials else [])
    colliding = ["beta"] + (["alpha"] if options.collide_alpha else []) \
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
    limits = {"alpha": spec.alpha_limits_deg, "beta": spec.beta_limits_deg}

    base_z = p.focal_z_mm - p.fiber_z_mm
    beta_bits = BIT_BETA
    alpha_bits = BIT_ALPHA if options.collide_alpha else 0
    world = s.worldbody

    for rid, (x, y) in zip(layout.robot_ids, layout.robot_xy):
        rid = int(rid)
        base = world.add_body(name=_name(rid), pos=[float(x), float(y), base_z])
        base.add_geom(default=vis, name=_name(rid, "body"), meshname=vis_mesh["body"],
                      material="body")
        alpha = base.add_body(name=_name(rid, "alpha"), pos=list(geometry.link_offset("alpha")))
        _set_inertial(alpha, a_mass, a_com, a_full)
        alpha.add_joint(name=_name(rid, "alpha"), type=mujoco.mjtJoint.mjJNT_HINGE,
                        axis=[0.0, 0.0, 1.0], range=list(np.radians(limits["alpha"])),
                        limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                        armature=servo.armature_kg_mm2)
        alpha.add_geom(default=vis, name=_name(rid, "alpha_visual"), meshname=vis_mesh["alpha"],
                       material="alpha")
        if alpha_bits:
            for k, mname in enumerate(col_mesh["alpha"]):
                alpha.add_geom(default=col, name=_name(rid, f"alpha_c{k}"), meshname=mname,
                               contype=alpha_bits, conaffinity=BIT_ALPHA | BIT_BETA)
        beta = alpha.add_body(name=_name(rid, "beta"), pos=list(geometry.link_offset("beta")))
        _set_inertial(beta, b_mass, b_com, b_full)
        beta.add_joint(name=_name(rid, "beta"), type=mujoco.mjtJoint.mjJNT_HINGE,
                       axis=[0.0, 0.0, 1.0], range=list(np.radians(limits["beta"])),
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                       armature=servo.armature_kg_mm2)
        beta.add_geom(default=vis, name=_name(rid, "beta_visual"), meshname=vis_mesh["beta"],
                      material="beta")
        for k, mname in enumerate(col_mesh["beta"]):
            beta.add_geom(default=col, name=_name(rid, f"beta_c{k}"), meshname=mname,
                          contype=beta_bits, conaffinity=BIT_BETA)
        for fname, fx, fy in p.fibers:
            beta.add_site(name=_name(rid, fname), pos=[fx, fy, p.beta_height_mm],
                          type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                          size=[p.fiber_radius_mm, 0.02, 0.0],
                          rgba=list(FIBER_RGBA.get(fname, DEFAULT_FIBER_RGBA)))
        for axis in ("alpha", "beta"):
            kp, kv = gains[axis]
            act = s.add_actuator(name=_name(rid, axis), target=_name(rid, axis),
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

    # focal plate, lights, cameras
    xy = np.asarray(layout.xy, float)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    centre = (lo + hi) / 2.0
    margin = spec.pitch_mm
    half = (hi - lo) / 2.0 + margin
    plate_top = base_z - p.body_length_mm
    world.add_geom(default=vis, name="focal_plate", type=mujoco.mjtGeom.mjGEOM_BOX,
                   size=[float(half[0]), float(half[1]), p.plate_thickness_mm / 2.0],
                   pos=[float(centre[0]), float(centre[1]), plate_top - p.plate_thickness_mm / 2.0],
                   material="plate")
    extent = float(max(half.max(), spec.pitch_mm))
    top = np.array([centre[0], centre[1], p.focal_z_mm])
    world.add_light(name="sun", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                    pos=[float(centre[0]), float(centre[1]), p.focal_z_mm + 4 * extent],
                    dir=[0.3, 0.2, -1.0], diffuse=[0.7, 0.7, 0.7], specular=[0.2, 0.2, 0.2],
                    castshadow=False)
    world.add_light(name="fill", type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
                    pos=[float(centre[0]), float(centre[1]), p.focal_z_mm + 4 * extent],
                    dir=[-0.4, -0.3, -0.6], diffuse=[0.3, 0.3, 0.35], specular=[0.0, 0.0, 0.0],
                    castshadow=False)
    fovy = 45.0
    top_pos = top + np.array([0.0, 0.0, 1.15 * extent / math.tan(math.radians(fovy / 2))])
    world.add_camera(name="top", pos=list(top_pos), quat=list(look_at_quat(top_pos, top, (0, 1, 0))),
                     fovy=fovy)
    obl_pos = top + extent * np.array([0.0, -1.6, 1.3])
    world.add_camera(name="oblique", pos=list(obl_pos), quat=list(look_at_quat(obl_pos, top)),
                     fovy=fovy)
    k_close = _closeup_index(layout, options.closeup_robot, centre)
    cx, cy = layout.robot_xy[k_close]
    c_pos, c_quat = closeup_pose(np.array([cx, cy, base_z]), spec)
    world.add_camera(name="closeup", pos=list(c_pos), quat=list(c_quat), fovy=fovy)
    s.visual.global_.offwidth = 1280
    s.visual.global_.offheight = 720
    s.visual.headlight.ambient = [0.25, 0.25, 0.25]
    s.stat.center = [float(centre[0]), float(centre[1]), float(p.focal_z_mm)]
    s.stat.extent = extent
    return s


def _set_inertial(body, mass, com, full) -> None:
    body.explicitinertial = True
    body.mass = mass
    body.ipos = list(com)
    body.fullinertia = list(full)


def _closeup_index(layout: Layout, robot_id, centre) -> int:
    if robot_id is not None:
        return layout.robot_index(robot_id)
    return int(np.argmin(np.hypot(*(layout.robot_xy - centre).T)))


def _servo_for(spec: RobotSpec) -> ServoParams:
    src = spec.source
    name = src[len("preset "):] if src.startswith("preset ") else (
        src if src.endswith(".toml") and Path(src).is_file() else None)
    if name is None:
        return ServoParams()
    return ServoParams.from_tables(load_tables(name), src)


def build_model(spec: RobotSpec, layout: Layout, geometry: RobotGeometry | None = None,
                options: ModelOptions | None = None) -> TwinModel:
    """Build and compile the grid model.

    Returns
    -------
    TwinModel
        The MjModel, the MjSpec, the id index and the inputs.
    """
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    options = options if options is not None else ModelOptions()
    s = build_spec(spec, layout, geometry, options)
    try:
        m = s.compile()
    except ValueError as exc:
        raise SpecError(f"MuJoCo could not compile the {spec.name} model: {exc}") from None
    index = ModelIndex.from_model(m, layout, tuple(n for n, _, _ in geometry.params.fibers))
    base_z = geometry.params.focal_z_mm - geometry.params.fiber_z_mm
    return TwinModel(m, s, index, spec, layout, geometry, options, base_z)


def export_model(spec: RobotSpec, layout: Layout, out_dir: str | Path,
                 geometry: RobotGeometry | None = None,
                 options: ModelOptions | None = None) -> Path:
    """Write the MJCF model and its meshes: ``out_dir/rfp-twin.xml`` and
    ``out_dir/meshes/*.stl`` (binary STL, mm). Each file is written to a temp file and
    renamed. Returns the XML path; ``mujoco.MjModel.from_xml_path`` loads it.
    """
    out = Path(out_dir)
    mesh_dir = out / MESH_DIR
    try:
        mesh_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError(f"{out}: cannot create the output folder ({exc.strerror}); allowed: a "
                        "writable path") from None
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    files: dict[str, trimesh.Trimesh] = {}
    s = build_spec(spec, layout, geometry, options, mesh_files=files)
    for fname, mesh in files.items():
        atomic_write_bytes(mesh_dir / fname, mesh.export(file_type="stl"))
    s.modelfiledir = str(out)
    try:
        s.compile()
    except ValueError as exc:
        raise SpecError(f"MuJoCo could not compile the exported model: {exc}") from None
    xml_path = out / MODEL_FILE
    atomic_write_bytes(xml_path, s.to_xml().encode("utf-8"))
    return xml_path


__all__ = ["BIT_ALPHA", "BIT_BETA", "CAMERAS", "COLLISION_CLASS", "VISUAL_CLASS", "ModelIndex",
           "collect_mujoco_warnings",
           "ModelOptions", "ServoParams", "TwinModel", "build_model", "build_spec",
           "closeup_pose", "export_model", "look_at_quat"]
