"""Names, colours and build options of the MuJoCo grid model.

Units inside the model: millimetres, kilograms, seconds (torques in kg mm^2 / s^2 =
1e-6 N m, i.e. uN m), angles in radians; the options here take mm, s and mN m.
Every magic string of the model is defined here: default classes, geom groups,
contact bits, camera names, body names (``r<id>``, ``r<id>_alpha``, ``fid<id>``).
:class:`ServoParams` are the position servos, :class:`ModelOptions` how the model is
built; bad values raise :class:`rfp_twin.models.errors.SpecError`.
"""
from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import mujoco

from rfp_twin.models.errors import SpecError
from rfp_twin.models.robot import RobotSpec, load_tables, spec_origin

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
#: Integrator names of :class:`ModelOptions`.
INTEGRATORS = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4,
               "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
               "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}


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


def robot_name(rid: int, part: str = "") -> str:
    """Name of robot ``rid``'s base body (``r<id>``) or of one of its parts (``r<id>_<part>``)."""
    return f"r{rid}_{part}" if part else f"r{rid}"


def fiducial_name(fid: int) -> str:
    """Name of fiducial ``fid``'s body."""
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
    robot_visuals : give the robots their visual meshes (default True). The tiles of a
        tiled twin, which only simulate, are built without them (each robot then has its
        collision pieces and its fiber sites: ~7 % less per step; renderers draw tiled
        twins from their own models).
    contacts_per_robot : room in MuJoCo's arena for this many contacts per robot at once
        (default 4; every arm through its neighbours at random angles makes < 1). More in
        one step are dropped with a ``mjWARN_CONTACTFULL`` warning
        (:mod:`rfp_twin.models.mjcf.memory`).
    """

    timestep_s: float = 0.004
    integrator: str = "implicitfast"
    servo: ServoParams | None = None
    closeup_robot: int | None = None
    collide_alpha: bool = True
    contacts_per_robot: float = 4.0
    robot_visuals: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.timestep_s, (int, float)) and 1e-5 <= self.timestep_s <= 0.05):
            raise SpecError(f"field 'timestep_s' = {self.timestep_s!r}; allowed: [1e-5, 0.05] s")
        if self.integrator not in INTEGRATORS:
            raise SpecError(f"field 'integrator' = {self.integrator!r}; allowed: "
                            f"{', '.join(INTEGRATORS)}")
        c = self.contacts_per_robot
        if isinstance(c, bool) or not isinstance(c, (int, float)) or not 0 <= c <= 1000:
            raise SpecError(f"field 'contacts_per_robot' = {c!r}; allowed: [0, 1000]")


def servo_for(spec: RobotSpec) -> ServoParams:
    """The servo of a spec: the ``[actuators]`` table of its preset or file, else defaults."""
    origin = spec_origin(spec)
    if origin is None:
        return ServoParams()
    return ServoParams.from_tables(load_tables(origin), spec.source)
