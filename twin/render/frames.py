"""Drawing frames: pose and colour the robots of a render model, update the MuJoCo scene,
draw it offscreen and read the pixels back into (height, width, 3) uint8 arrays.

Robot colours
-------------
Each robot's alpha and beta links are coloured by its state
(:mod:`rfp_twin.twin.render.timeline`): waiting (the links' own colours), moving (blue), arrived
(green) and in contact (red), the alpha arm in a darker shade (:data:`ALPHA_SHADE`).

Lean rendering (default)
------------------------
The lean settings turn off multisampling, shadows, reflections, skybox, haze, fog and
post processing, hide the fiber sites on the wide cameras (a fiber is 0.12 mm: below one
pixel there), and draw the re-meshed render model (:func:`rfp_twin.twin.render.camera.render_model`).
``lean=False`` renders the twin's model as it is, with MuJoCo's default quality.

Shapes: n robots (layout order); angles (n, 2) deg (alpha, beta); states (n,) state
codes; world points mm; pixel coordinates (column, row) from the top-left corner.
"""
from __future__ import annotations

import mujoco
import numpy as np

from rfp_twin.models.mjcf import TwinModel
from rfp_twin.models.mjcf.options import RGBA
from rfp_twin.twin.render.backend import GL_BACKENDS, RenderError, gl_context_class, require_backend
from rfp_twin.twin.render.camera import focal_px, render_model
from rfp_twin.twin.render.settings import RenderSettings
from rfp_twin.twin.render.timeline import ARRIVED, CONTACT, MOVING, STATE_NAMES, WAITING

#: Beta-arm colour of each state (None: the link's own material colour).
STATE_RGBA = {WAITING: None, MOVING: (0.15, 0.5, 1.0, 1.0), ARRIVED: (0.2, 0.8, 0.3, 1.0),
              CONTACT: (1.0, 0.08, 0.05, 1.0)}
#: The alpha arm takes the state colour times this (a darker shade of it).
ALPHA_SHADE = 0.6
#: Scene flags turned off by the lean settings.
LEAN_OFF_FLAGS = ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX", "mjRND_HAZE", "mjRND_FOG",
                  "mjRND_POST_PROCESSING")


def state_palette(model: mujoco.MjModel, index) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The geoms coloured by state and their colours.

    Returns
    -------
    geoms (g,) : the visual geoms of every alpha and beta body (beta first);
    geom_robot (g,) : the robot (layout index) of each;
    palette (g, 4 states, 4) float32 RGBA : each geom's colour in each state (its own
    material or geom colour when WAITING).
    """
    n = index.n_robots
    visual = ~index.geom_collision
    gbody = np.asarray(model.geom_bodyid)
    link_geoms = []
    for bodies, shade in ((index.beta_body, 1.0), (index.alpha_body, ALPHA_SHADE)):
        robot_of = np.full(model.nbody, -1, dtype=np.int64)
        robot_of[bodies] = np.arange(n)
        g = np.flatnonzero(visual & (robot_of[gbody] >= 0))
        link_geoms.append((g, robot_of[gbody[g]], shade))
    geoms = np.concatenate([g for g, _, _ in link_geoms])
    geom_robot = np.concatenate([r for _, r, _ in link_geoms])
    default = np.asarray(model.geom_rgba, dtype=np.float32)[geoms].copy()
    matid = np.asarray(model.geom_matid)[geoms]
    has_mat = matid >= 0
    default[has_mat] = np.asarray(model.mat_rgba)[matid[has_mat]]
    pal = np.empty((geoms.size, len(STATE_NAMES), 4), dtype=np.float32)
    shades = np.concatenate([np.full(g.size, s) for g, _, s in link_geoms])
    for state, rgba in STATE_RGBA.items():
        if rgba is None:
            pal[:, state] = default
        else:
            c = np.asarray(rgba, dtype=np.float32)
            pal[:, state, :3] = c[:3] * shades[:, None]
            pal[:, state, 3] = c[3]
    return geoms, geom_robot, pal


def state_colours(link: str) -> np.ndarray:
    """(4 states, 4) float32 RGBA of a moving link (``alpha`` or ``beta``) in each state:
    :data:`STATE_RGBA` (alpha in :data:`ALPHA_SHADE`), waiting the link's own colour."""
    shade = ALPHA_SHADE if link == "alpha" else 1.0
    out = np.empty((len(STATE_NAMES), 4), dtype=np.float32)
    for state, rgba in STATE_RGBA.items():
        if rgba is None:
            out[state] = RGBA[link]
        else:
            out[state, :3] = np.asarray(rgba[:3]) * shade
            out[state, 3] = rgba[3]
    return out


def open_offscreen(backend: str, model: mujoco.MjModel, width: int, height: int):
    """(GL context, MjrContext) drawing ``model`` into a ``width`` x ``height`` offscreen
    buffer; RenderError (naming the backend) when that fails."""
    gl = None
    try:
        gl = gl_context_class(backend)(width, height)
        gl.make_current()
        con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, con)
    except Exception as exc:  # noqa: BLE001 - any GL failure is a render error
        if gl is not None:
            gl.free()
        raise RenderError(f"MUJOCO_GL={backend!r}: cannot create a {width}x{height} offscreen "
                          f"context ({type(exc).__name__}: {exc}); allowed: "
                          f"{', '.join(GL_BACKENDS)} with Mesa installed") from None
    return gl, con


def project_points(model: mujoco.MjModel, data: mujoco.MjData, camera_id: int, width: int,
                   height: int, xyz: np.ndarray) -> np.ndarray:
    """Pixel coordinates (k, 2) as (column, row) of world points (k, 3) mm seen by camera
    ``camera_id`` (after ``mj_camlight``) in a ``width`` x ``height`` frame (rows from the
    top); points behind the camera give NaN."""
    rel = np.asarray(xyz, float).reshape(-1, 3) - data.cam_xpos[camera_id]
    cam = rel @ data.cam_xmat[camera_id].reshape(3, 3)  # camera axes: x right, y up, -z forward
    f = focal_px(model, camera_id, height)
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = -cam[:, 2]
        col = width / 2.0 + f * cam[:, 0] / depth
        row = height / 2.0 - f * cam[:, 1] / depth
    out = np.column_stack([col, row])
    out[depth <= 0] = np.nan
    return out


#: Scene slots beyond the model's geoms and sites (lights' and cameras' decor, labels).
SCENE_SPARE = 64


def scene_capacity(model: mujoco.MjModel) -> int:
    """``maxgeom`` of a scene that holds every geom and site of ``model``, plus
    :data:`SCENE_SPARE`."""
    return int(model.ngeom + model.nsite + SCENE_SPARE)


def visible_geoms(model: mujoco.MjModel, option: mujoco.MjvOption) -> int:
    """Number of the model's geoms a scene with ``option`` draws: those of a shown group
    that are not fully transparent (MuJoCo skips ``rgba`` alpha 0)."""
    group = np.clip(np.asarray(model.geom_group), 0, len(option.geomgroup) - 1)
    shown = np.asarray(option.geomgroup, dtype=bool)[group]
    return int(np.count_nonzero(shown & (np.asarray(model.geom_rgba)[:, 3] > 0)))


def lean_scene(model: mujoco.MjModel, maxgeom: int, lean: bool) -> mujoco.MjvScene:
    """A scene of room ``maxgeom`` for ``model``; with ``lean``, the costly effects off
    (:data:`LEAN_OFF_FLAGS`)."""
    scene = mujoco.MjvScene(model, maxgeom=int(maxgeom))
    if lean:
        for flag in LEAN_OFF_FLAGS:
            if hasattr(mujoco.mjtRndFlag, flag):
                scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
    return scene


class OffscreenOwner:
    """Base of the renderers: owns a GL context ``_gl`` and an MjrContext ``_con`` (None
    when not open); :meth:`close` frees them; a context manager."""

    _gl = None
    _con = None

    def close(self) -> None:
        """Free the GL resources (idempotent)."""
        if self._con is not None:
            try:
                if self._gl is not None:
                    self._gl.make_current()
                self._con.free()
            finally:
                self._con = None
        if self._gl is not None:
            try:
                self._gl.free()
            finally:
                self._gl = None

    def _begin_frame(self, angles_deg, states) -> None:
        """Before drawing a frame: check the renderer is open, pose / colour the robots
        when ``angles_deg`` (n, 2) / ``states`` (n,) are given, make its GL context current."""
        if self._con is None:
            raise RenderError("render() after close(); allowed: a renderer that is open")
        if angles_deg is not None:
            self.set_angles(angles_deg)
        if states is not None:
            self.set_states(states)
        self._gl.make_current()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


class FrameRenderer(OffscreenOwner):
    """Draws frames of one grid with one camera into numpy arrays.

    Parameters
    ----------
    twin : TwinModel (not modified; frames come from a render copy,
        :func:`rfp_twin.twin.render.camera.render_model`)
    settings : RenderSettings

    Use as a context manager (or call :meth:`close`): it owns a GL context.
    """

    def __init__(self, twin: TwinModel, settings: RenderSettings | None = None) -> None:
        self._gl = None
        self._con = None
        self.settings = settings = settings or RenderSettings()
        self.backend = require_backend()
        self.twin = render_model(twin, settings)
        m = self.model = self.twin.model
        self.data = mujoco.MjData(m)
        idx = self.twin.index
        self.n_robots = idx.n_robots
        self._qpos = idx.qpos_adr.ravel()
        self._geoms, self._geom_robot, self._palette = state_palette(m, idx)
        self._rows = np.arange(self._geoms.size)
        self.states = np.zeros(self.n_robots, dtype=np.int8)
        self.set_states(self.states)
        # scene
        self.option = mujoco.MjvOption()
        if settings.lean and settings.wide:
            self.option.sitegroup[:] = 0
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.camera.fixedcamid = int(idx.camera[settings.camera])
        # room for every geom and site the options show: a full scene drops geoms silently
        # (MuJoCo only counts mjWARN_VGEOMFULL); 12,852 robots draw 38,557 geoms
        self.scene = lean_scene(m, scene_capacity(m), settings.lean)
        # GL
        w, h = settings.width, settings.height
        self._gl, self._con = open_offscreen(self.backend, m, w, h)
        self._rect = mujoco.MjrRect(0, 0, w, h)
        self._buf = np.empty((h, w, 3), dtype=np.uint8)
        self.set_angles(np.tile(np.asarray(twin.spec.fold_deg, float), (self.n_robots, 1)))

    # -- state ---------------------------------------------------------------------
    def set_angles(self, angles_deg: np.ndarray) -> None:
        """Pose every robot at (n, 2) deg (layout robot order); kinematics only."""
        a = np.asarray(angles_deg, dtype=np.float64).reshape(self.n_robots, 2)
        self.data.qpos[self._qpos] = np.radians(a).ravel()
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def set_states(self, states: np.ndarray) -> None:
        """Colour the robots by (n,) state codes (WAITING, MOVING, ARRIVED, CONTACT)."""
        s = np.asarray(states, dtype=np.int64).reshape(self.n_robots)
        self.states = s.astype(np.int8)
        self.model.geom_rgba[self._geoms] = self._palette[self._rows, s[self._geom_robot]]

    # -- drawing -------------------------------------------------------------------
    def render(self, angles_deg: np.ndarray | None = None, states: np.ndarray | None = None,
               out: np.ndarray | None = None) -> np.ndarray:
        """One frame, (height, width, 3) uint8, top row first. Poses / colours the robots
        first when ``angles_deg`` (n, 2) / ``states`` (n,) are given."""
        self._begin_frame(angles_deg, states)
        mujoco.mjv_updateScene(self.model, self.data, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        if self.scene.ngeom >= self.scene.maxgeom:      # pragma: no cover - capacity above
            raise RenderError(f"the scene is full ({self.scene.maxgeom} geoms): geoms would be "
                              "dropped; allowed: a scene sized by scene_capacity()")
        mujoco.mjr_render(self._rect, self.scene, self._con)
        mujoco.mjr_readPixels(self._buf, None, self._rect, self._con)
        if out is None:
            out = np.empty_like(self._buf)
        np.copyto(out, self._buf[::-1])
        return out

    def project(self, xyz: np.ndarray) -> np.ndarray:
        """Pixel coordinates (k, 2) as (column, row) of world points (k, 3) mm in the
        current camera (rows from the top); points behind the camera give NaN."""
        return project_points(self.model, self.data, self.camera.fixedcamid,
                              self.settings.width, self.settings.height, xyz)


def render_frame(twin: TwinModel, angles_deg: np.ndarray | None = None,
                 settings: RenderSettings | None = None,
                 states: np.ndarray | None = None) -> np.ndarray:
    """One frame (height, width, 3) uint8 of the grid at ``angles_deg`` (n, 2) deg
    (default: the spec's fold), robots coloured by ``states`` (n,) (default: waiting)."""
    with FrameRenderer(twin, settings) as fr:
        return fr.render(angles_deg, states)
