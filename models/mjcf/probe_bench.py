"""The MIRADAS bench in MuJoCo: closed-loop probe arms built with ``mujoco.MjSpec``.

Each arm (Sabater et al. 2018 Fig. 5) is a planar chain closed by an equality
constraint: base (J1 at the bench, x axis towards the field centre) -> crank (hinge J1,
motor theta1) -> long tube (hinge J3) -> sleeve (slide J4 along the tube); and base ->
rocker (hinge J2 at ``(d12, 0)``, motor theta2); a ``connect`` equality holds the
rocker's end on the sleeve (J4 turns freely on the tube). The bodies are placed at the
park pose with each joint's ``ref`` set to its park value, so joint positions are
absolute: crank = theta1, rocker = -theta2 (theta2 turns clockwise, Fig. 3b), tube = its
angle to the crank, sleeve = d34, all in radians / mm. Collision capsules are those of
:meth:`rfp_twin.models.kinds.ProbeArmKind.bodies`; the parts of one arm do not collide
with each other. Position servos on J1 and J2 (estimated gains). Units: mm, kg, s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from rfp_twin.models.kinds.probe_kind import ProbeArmKind

#: Estimated masses (kg) of crank, rocker, tube (with cabinet and head) and sleeve.
MASS_KG = {"crank": 0.3, "rocker": 0.2, "tube": 0.8, "sleeve": 0.1}
#: Servo natural frequency (rad/s) and damping ratio of the J1 / J2 position servos
#: (estimates: the steppers hold their commanded angle).
SERVO_OMEGA = 40.0
SERVO_ZETA = 1.0
#: Simulation time step, s.
TIMESTEP_S = 0.002
#: Height of the arms' plane above the bench, mm (visual).
PLANE_Z_MM = 20.0
#: Colours (rgba) of the parts.
RGBA = {"link": [0.3, 0.4, 0.6, 1.0], "cabinet": [0.55, 0.55, 0.6, 1.0],
        "tube": [0.85, 0.85, 0.8, 1.0], "head": [0.9, 0.6, 0.15, 1.0]}
#: Largest offscreen frame (pixels a side) the model allows a renderer.
OFFSCREEN_PX = 1920
#: Joint names of arm k: f"a{k}_{part}".
PARTS = ("crank", "rocker", "tube", "sleeve")


def arm_name(k: int, part: str = "") -> str:
    return f"a{k}_{part}" if part else f"a{k}"


def _quat_z(angle: float) -> list[float]:
    return [math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2)]


def joint_positions(kind: ProbeArmKind, q_deg: np.ndarray) -> np.ndarray:
    """(n, 4) crank, rocker, tube, sleeve joint positions (rad, rad, rad, mm) of the
    arms at motor angles ``q_deg`` (n, 2) deg: the closed loop's consistent state."""
    q = np.atleast_2d(np.asarray(q_deg, dtype=np.float64))
    s = kind.spec
    t1, t2 = np.radians(q[:, 0]), np.radians(q[:, 1])
    j3 = np.column_stack([s.d13_mm * np.cos(t1), s.d13_mm * np.sin(t1)])
    j4 = np.column_stack([s.d12_mm - s.d24_mm * np.cos(t2), s.d24_mm * np.sin(t2)])
    v = j4 - j3
    phi = np.arctan2(v[:, 1], v[:, 0])
    rel = (phi - t1 + np.pi) % (2 * np.pi) - np.pi
    return np.column_stack([t1, -t2, rel, np.hypot(v[:, 0], v[:, 1])])


@dataclass
class ProbeBench:
    """A compiled bench: the model and the address of each arm's joints and actuators."""

    model: mujoco.MjModel
    spec: mujoco.MjSpec
    kind: ProbeArmKind
    qpos_adr: np.ndarray      # (n, 4) crank, rocker, tube, sleeve
    dof_adr: np.ndarray       # (n, 4)
    act: np.ndarray           # (n, 2) theta1, theta2 actuators

    def set_pose(self, data: mujoco.MjData, q_deg: np.ndarray) -> None:
        """Put every arm at ``q_deg`` (n, 2) deg, at rest, servos commanding it."""
        jp = joint_positions(self.kind, q_deg)
        for k in range(self.kind.n_arms):
            data.qpos[self.qpos_adr[k]] = jp[k]
            data.qvel[self.dof_adr[k]] = 0.0
        self.command(data, q_deg)
        mujoco.mj_forward(self.model, data)

    def command(self, data: mujoco.MjData, q_deg: np.ndarray) -> None:
        """Servo targets for motor angles ``q_deg`` (n, 2) deg."""
        q = np.radians(np.atleast_2d(q_deg))
        data.ctrl[self.act[:, 0]] = q[:, 0]
        data.ctrl[self.act[:, 1]] = -q[:, 1]

    def motor_angles(self, data: mujoco.MjData) -> np.ndarray:
        """(n, 2) theta1, theta2 deg read from the simulated joints."""
        return np.degrees(np.column_stack([data.qpos[self.qpos_adr[:, 0]],
                                           -data.qpos[self.qpos_adr[:, 1]]]))


def build_probe_bench(kind: ProbeArmKind) -> ProbeBench:
    """Build and compile the bench of ``kind`` (every arm at park)."""
    s = kind.spec
    ms = mujoco.MjSpec()
    ms.compiler.degree = False
    ms.option.timestep = TIMESTEP_S
    ms.option.gravity = [0.0, 0.0, -9810.0]
    ms.visual.global_.offwidth, ms.visual.global_.offheight = OFFSCREEN_PX, OFFSCREEN_PX
    ms.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[s.bench_radius_mm + 150, 2, 0],
                          pos=[0, 0, -2], rgba=[0.15, 0.15, 0.17, 1], contype=0, conaffinity=0)
    park = joint_positions(kind, np.array(s.park_deg))[0]
    hinge, slide = mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE
    cap = mujoco.mjtGeom.mjGEOM_CAPSULE
    bases, heads = kind.bases(), kind.headings_rad()
    for k in range(s.n_arms):
        base = ms.worldbody.add_body(name=arm_name(k), pos=[*bases[k], PLANE_Z_MM],
                                     quat=_quat_z(float(heads[k])))
        crank = base.add_body(name=arm_name(k, "crank"), quat=_quat_z(float(park[0])))
        crank.add_joint(name=arm_name(k, "crank"), type=hinge, axis=[0, 0, 1], ref=float(park[0]),
                        damping=0.0, armature=1e3)
        crank.add_geom(name=arm_name(k, "crank_c"), type=cap, fromto=[0, 0, 0, s.d13_mm, 0, 0],
                       size=[s.link_radius_mm, 0, 0], mass=MASS_KG["crank"], rgba=RGBA["link"])
        tube = crank.add_body(name=arm_name(k, "tube"), pos=[s.d13_mm, 0, 0],
                              quat=_quat_z(float(park[2])))
        tube.add_joint(name=arm_name(k, "tube"), type=hinge, axis=[0, 0, 1], ref=float(park[2]))
        head0 = s.d3tip_mm - s.head_length_mm
        for part, a, b, r, m in (("cabinet", -s.tube_rear_mm, s.ds1_mm, s.cabinet_radius_mm, 0.3),
                                 ("tube", 0.0, head0, s.tube_radius_mm, 0.4),
                                 ("head", head0, s.d3tip_mm, s.head_radius_mm, 0.1)):
            tube.add_geom(name=arm_name(k, part), type=cap, fromto=[a, 0, 0, b, 0, 0],
                          size=[r, 0, 0], mass=m, rgba=RGBA[part])
        tube.add_site(name=arm_name(k, "tip"), pos=[s.d3tip_mm, 0, 0], size=[2, 0, 0])
        sleeve = tube.add_body(name=arm_name(k, "sleeve"), pos=[float(park[3]), 0, 0])
        sleeve.add_joint(name=arm_name(k, "sleeve"), type=slide, axis=[1, 0, 0],
                         ref=float(park[3]), range=[s.ds1_mm, s.ds2_mm], limited=1)
        sleeve.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[s.tube_radius_mm + 2, 0, 0],
                        mass=MASS_KG["sleeve"], contype=0, conaffinity=0)
        rocker = base.add_body(name=arm_name(k, "rocker"), pos=[s.d12_mm, 0, 0],
                               quat=_quat_z(math.pi + float(park[1])))
        rocker.add_joint(name=arm_name(k, "rocker"), type=hinge, axis=[0, 0, 1], ref=float(park[1]),
                         armature=1e3)
        rocker.add_geom(name=arm_name(k, "rocker_c"), type=cap, fromto=[0, 0, 0, s.d24_mm, 0, 0],
                        size=[s.link_radius_mm, 0, 0], mass=MASS_KG["rocker"], rgba=RGBA["link"])
        eq = ms.add_equality(name=arm_name(k, "loop"), type=mujoco.mjtEq.mjEQ_CONNECT,
                             objtype=mujoco.mjtObj.mjOBJ_BODY, name1=arm_name(k, "rocker"),
                             name2=arm_name(k, "sleeve"))
        eq.data[0:3] = [s.d24_mm, 0.0, 0.0]
        names = [arm_name(k, p) for p in PARTS] + [arm_name(k)]
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                ms.add_exclude(bodyname1=a, bodyname2=b)
        for j, joint in ((0, "crank"), (1, "rocker")):
            inertia = 2e4 if j == 0 else 5e3           # estimate, kg mm^2 about the joint
            kp = inertia * SERVO_OMEGA ** 2
            act = ms.add_actuator(name=arm_name(k, f"theta{j + 1}"), target=arm_name(k, joint),
                                  trntype=mujoco.mjtTrn.mjTRN_JOINT)
            act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
            act.gainprm[0] = kp
            act.biasprm[0:3] = [0.0, -kp, -2 * SERVO_ZETA * SERVO_OMEGA * inertia]
    model = ms.compile()
    n = s.n_arms
    qadr = np.array([[model.jnt_qposadr[model.joint(arm_name(k, p)).id] for p in PARTS]
                     for k in range(n)])
    dadr = np.array([[model.jnt_dofadr[model.joint(arm_name(k, p)).id] for p in PARTS]
                     for k in range(n)])
    act = np.array([[model.actuator(arm_name(k, f"theta{j}")).id for j in (1, 2)]
                    for k in range(n)])
    return ProbeBench(model, ms, kind, qadr, dadr, act)


def export_probe_bench(kind: ProbeArmKind, out_dir) -> "Path":
    """Write the bench as ``out_dir/rfp-twin.xml`` (atomically); MuJoCo's viewer opens it.
    Returns the path."""
    from pathlib import Path

    from rfp_twin.models.errors import SpecError
    from rfp_twin.models.files import atomic_write_text
    from rfp_twin.models.mjcf.options import MODEL_FILE

    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError(f"{out}: cannot create the output folder ({exc.strerror}); allowed: a "
                        "writable path") from None
    path = out / MODEL_FILE
    atomic_write_text(path, build_probe_bench(kind).spec.to_xml())
    return path
