"""Offscreen video of a run: MuJoCo frames on the CPU (Mesa), encoded to MP4.

OpenGL backend
--------------
MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported. Importing this module
therefore picks a backend *before* it imports mujoco: if ``MUJOCO_GL`` is unset,
:func:`select_gl_backend` probes ``egl`` then ``osmesa``, each in a throw-away subprocess
(a backend whose libraries are missing or broken can fail on import and must not poison
this process), and sets ``MUJOCO_GL`` to the first that creates a context. A value the
user set is kept as it is. Import this module before anything imports mujoco (the CLI's
``render`` command imports it first).

If mujoco was imported earlier anyway, rendering still works: :class:`FrameRenderer`
creates its GL context from the chosen backend's own module (``mujoco.egl`` /
``mujoco.osmesa``), not from whatever ``mujoco.GLContext`` was bound at import.
When no backend works, importing still succeeds (other commands need no GL); the first
renderer raises :class:`RenderError` naming each backend and why it failed.

Lean rendering (default)
------------------------
On a CPU rasteriser (llvmpipe) the cost of a frame is mostly vertices, then pixels. The
lean settings turn off multisampling, shadows, reflections, skybox, haze, fog and post
processing, hide the fiber sites on the wide cameras (a fiber is 0.12 mm: below one pixel
there), and, on the wide cameras, draw the procedural links re-meshed with as few facets
per circle as look round at the frame's scale (:func:`lean_circle_sections`: outlines
within :data:`LEAN_SAGITTA_PX` pixel of a circle; at 1280x720, 8 instead of the model's
32 for the 547-robot grid, 16 for a 7-robot grid). That is a render-only copy of the
model; the twin's own model is never changed. ``lean=False`` renders the twin's model as
it is, with MuJoCo's default quality.

Robot colours
-------------
Each robot's alpha and beta links are coloured by its state at the frame time:
waiting (the links' own colours: not moving, not at its end), moving (blue), arrived
(green: within :data:`ARRIVED_TOL_DEG` of where the run ends it) and in contact (red:
a contact of the simulation's :class:`twin.sim.ContactLog` since the previous frame;
this wins over the others).

Frames and time
---------------
A video of ``fps`` frames per second at ``speedup`` shows the simulation at sim times
``k * speedup / fps`` for ``k = 0 .. floor(sim_s * fps / speedup)``: that many frames + 1.
Joint angles come from the simulation record (20 ms samples, linearly interpolated).
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from models.errors import RfpError

#: Offscreen backends, in the order they are tried.
GL_BACKENDS = ("egl", "osmesa")
#: Seconds one backend probe may take.
PROBE_TIMEOUT_S = 60.0

_PROBE = r"""
import mujoco
ctx = mujoco.GLContext(16, 16)
ctx.make_current()
con = mujoco.MjrContext(mujoco.MjModel.from_xml_string("<mujoco/>"),
                        mujoco.mjtFontScale.mjFONTSCALE_100)
from OpenGL import GL
print("RENDERER=" + GL.glGetString(GL.GL_RENDERER).decode(errors="replace"))
con.free()
ctx.free()
"""


class RenderError(RfpError):
    """Rendering cannot run: no working OpenGL backend, bad render settings, a report
    without the sampled record, an unwritable output."""


def probe_gl_backend(backend: str, timeout_s: float = PROBE_TIMEOUT_S) -> tuple[bool, str]:
    """Try one backend in a subprocess: ``(True, GL renderer string)`` when mujoco can
    create a context with ``MUJOCO_GL=backend``, else ``(False, why)``."""
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        r = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True,
                           text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        return False, f"no answer within {timeout_s:g} s"
    except OSError as exc:
        return False, f"cannot start {sys.executable}: {exc.strerror}"
    for line in r.stdout.splitlines():
        if r.returncode == 0 and line.startswith("RENDERER="):
            return True, line[len("RENDERER="):].strip()
    lines = [ln.strip() for ln in (r.stderr or r.stdout).splitlines() if ln.strip()]
    return False, (lines[-1] if lines else f"exit code {r.returncode}")[:300]


_selected: dict[str, object] = {}


def select_gl_backend(candidates: tuple[str, ...] = GL_BACKENDS) -> str:
    """The offscreen backend to use, and ``MUJOCO_GL`` set to it.

    A ``MUJOCO_GL`` already set (by the user or an earlier call) is kept. Otherwise each
    candidate is probed in a subprocess (:func:`probe_gl_backend`) and the first that
    works is exported as ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM`` when unset), so child
    processes inherit it without probing again. Call it before ``import mujoco``.

    Raises
    ------
    RenderError
        No candidate works; the message lists each backend's failure.
    """
    current = os.environ.get("MUJOCO_GL", "").strip().lower()
    if current:
        return current
    failures = []
    for backend in candidates:
        ok, info = probe_gl_backend(backend)
        if ok:
            os.environ["MUJOCO_GL"] = backend
            os.environ.setdefault("PYOPENGL_PLATFORM", backend)
            _selected["renderer"] = info
            return backend
        failures.append(f"{backend}: {info}")
    raise RenderError("no offscreen OpenGL backend works (" + "; ".join(failures) + "); allowed: "
                      "install Mesa's EGL (Debian libegl1) or OSMesa (libosmesa6), or set "
                      "MUJOCO_GL to a working backend")


# Pick the backend before mujoco is imported (see the module docstring).
try:
    BACKEND: str | None = select_gl_backend()
    _BACKEND_ERROR: RenderError | None = None
except RenderError as _exc:  # pragma: no cover - depends on the machine
    BACKEND, _BACKEND_ERROR = None, _exc

import imageio_ffmpeg  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from models.mjcf import CAMERAS, TwinModel, build_model  # noqa: E402
from models.trajectory import Trajectory  # noqa: E402
from twin.sim import SimReport, SimSettings, simulate  # noqa: E402

# -- constants ---------------------------------------------------------------------
#: Robot states, as stored in a timeline's ``states`` array.
WAITING, MOVING, ARRIVED, CONTACT = 0, 1, 2, 3
STATE_NAMES = ("waiting", "moving", "arrived", "contact")
#: Beta-arm colour of each state (None: the link's own material colour).
STATE_RGBA = {WAITING: None, MOVING: (0.15, 0.5, 1.0, 1.0), ARRIVED: (0.2, 0.8, 0.3, 1.0),
              CONTACT: (1.0, 0.08, 0.05, 1.0)}
#: The alpha arm takes the state colour times this (a darker shade of it).
ALPHA_SHADE = 0.6
#: A robot turning faster than this on either axis is moving, deg/s.
MOVING_DEG_S = 0.5
#: A robot within this of its final angles on both axes has arrived, deg.
ARRIVED_TOL_DEG = 0.1
#: Lean wide-camera renders re-mesh round parts so that their outline departs from a
#: circle by at most this, pixels ...
LEAN_SAGITTA_PX = 1.0
#: ... with at least this many facets per circle.
LEAN_MIN_SECTIONS = 8
#: Scene flags turned off by the lean settings.
LEAN_OFF_FLAGS = ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX", "mjRND_HAZE", "mjRND_FOG",
                  "mjRND_POST_PROCESSING")
MAX_SIZE = 4096
#: libx264 speed presets.
X264_PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow",
                "slower", "veryslow")
#: Margin left around the grid by a fitted camera, fraction of the half-frame.
FIT_MARGIN = 0.04


# -- settings ------------------------------------------------------------------------
@dataclass(frozen=True)
class RenderSettings:
    """How to render.

    width, height : frame size, pixels (even, 16..4096; MP4 / yuv420p needs even sizes).
    fps : video frames per second.
    speedup : simulated seconds per video second (2 = twice real speed).
    camera : ``top``, ``oblique`` or ``closeup`` (the model's cameras).
    robot_id : with ``closeup``, the robot to look at (default: the model's close-up
        robot, nearest the centre).
    lean : cheap CPU render settings (see the module docstring); False = MuJoCo defaults.
    fit : move the ``top`` / ``oblique`` camera (orientation and field of view kept) so
        that the whole grid (bases plus arm reach, plate to focal surface) fills the frame,
        centred, with a small margin, for this frame's aspect ratio
        (:func:`fitted_camera`; the model's cameras are framed for a square).
        False: the model's camera poses as they are.
    crf, preset : libx264 quality (0-51, lower is better) and speed preset.
    """

    width: int = 1280
    height: int = 720
    fps: float = 30.0
    speedup: float = 1.0
    camera: str = "top"
    robot_id: int | None = None
    lean: bool = True
    fit: bool = True
    crf: int = 23
    preset: str = "veryfast"

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not 16 <= v <= MAX_SIZE or v % 2:
                raise RenderError(f"field '{name}' = {v!r}; allowed: an even integer in "
                                  f"[16, {MAX_SIZE}] pixels")
        for name in ("fps", "speedup"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise RenderError(f"field '{name}' = {v!r}; allowed: a finite number > 0")
        if self.camera not in CAMERAS:
            raise RenderError(f"field 'camera' = {self.camera!r}; allowed: {', '.join(CAMERAS)}")
        if self.robot_id is not None and self.camera != "closeup":
            raise RenderError(f"field 'robot_id' = {self.robot_id!r} with camera {self.camera!r}; "
                              "allowed: a robot id only with camera 'closeup'")
        if isinstance(self.crf, bool) or not isinstance(self.crf, int) or not 0 <= self.crf <= 51:
            raise RenderError(f"field 'crf' = {self.crf!r}; allowed: an integer in [0, 51]")
        if self.preset not in X264_PRESETS:
            raise RenderError(f"field 'preset' = {self.preset!r}; allowed: {', '.join(X264_PRESETS)}")

    @property
    def frame_dt_s(self) -> float:
        """Simulated seconds between two frames."""
        return self.speedup / self.fps


# -- GL context ------------------------------------------------------------------------
def require_backend() -> str:
    """The selected backend; raises :class:`RenderError` when none works."""
    if _BACKEND_ERROR is not None:
        raise _BACKEND_ERROR
    return os.environ.get("MUJOCO_GL", BACKEND or "").strip().lower()


def _gl_context_class(backend: str):
    """The GLContext class of a backend, imported from its own module so that it works
    even when mujoco was imported before ``MUJOCO_GL`` was set."""
    try:
        if backend == "egl":
            from mujoco.egl import GLContext
        elif backend == "osmesa":
            from mujoco.osmesa import GLContext
        else:
            GLContext = mujoco.GLContext
    except (ImportError, AttributeError, OSError) as exc:
        raise RenderError(f"MUJOCO_GL={backend!r}: cannot load the backend ({exc}); allowed: "
                          f"{', '.join(GL_BACKENDS)} with Mesa installed") from None
    return GLContext


def gl_renderer_info() -> str:
    """The backend and GL renderer string (e.g. ``egl: llvmpipe (LLVM 15.0.6, 256 bits)``)."""
    backend = require_backend()
    info = _selected.get("renderer")
    if info is None:
        ok, info = probe_gl_backend(backend)
        _selected["renderer"] = info if ok else f"unknown ({info})"
    return f"{backend}: {_selected['renderer']}"


# -- the render model ----------------------------------------------------------------
def fitted_camera(twin: TwinModel, camera: str, aspect: float,
                  margin: float = FIT_MARGIN) -> tuple[np.ndarray, float]:
    """Where a world camera of ``twin.model`` must stand so that the grid fits a frame of
    ``aspect`` = width / height: same orientation and field of view, moved along its view
    axis and sideways so that every base plus the arm reach in 16 directions, at the plate
    and at the focal surface, lands inside the frame less ``margin``, centred.

    Returns
    -------
    (pos (3,), distance): the camera position (world, mm) and its distance from the aim
    point (the grid's centre), mm.
    """
    m = twin.model
    c = twin.index.camera[camera]
    spec, p = twin.spec, twin.geometry.params
    reach = spec.alpha_length_mm + spec.beta_length_mm + p.beta_half_width_mm
    ang = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
    ring = reach * np.column_stack([np.cos(ang), np.sin(ang)])
    xy = (np.asarray(twin.layout.xy, float)[:, None, :] + ring[None]).reshape(-1, 2)
    z_lo, z_hi = twin.base_z_mm - p.body_length_mm, p.focal_z_mm
    pts = np.vstack([np.column_stack([xy, np.full(len(xy), z)]) for z in (z_lo, z_hi)])
    target = (pts.min(axis=0) + pts.max(axis=0)) / 2.0
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(m.cam_quat[c], float))
    axes = mat.reshape(3, 3)  # columns: camera x (right), y (up), z (backwards)
    ty = math.tan(math.radians(float(m.cam_fovy[c])) / 2.0) * (1.0 - margin)
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


def lean_circle_sections(twin: TwinModel, settings: RenderSettings, distance_mm: float) -> int:
    """Facets per circle for a lean render: the fewest (a multiple of 4, at least
    :data:`LEAN_MIN_SECTIONS`, at most the model's) for which the outline of the widest
    round part (fixed body or alpha hub) seen from ``distance_mm`` departs from a circle
    by at most :data:`LEAN_SAGITTA_PX` pixels (shading stays smooth: MuJoCo smooths the
    normals)."""
    p = twin.geometry.params
    c = twin.index.camera[settings.camera]
    f = 0.5 * settings.height / math.tan(math.radians(float(twin.model.cam_fovy[c])) / 2.0)
    radius_px = max(p.body_radius_mm, p.alpha_hub_radius_mm) * f / max(distance_mm, 1e-9)
    if radius_px <= LEAN_SAGITTA_PX:
        n = LEAN_MIN_SECTIONS
    else:
        n = 4 * math.ceil(math.pi / math.acos(1.0 - LEAN_SAGITTA_PX / radius_px) / 4.0 - 1e-9)
    return int(min(p.circle_sections, max(LEAN_MIN_SECTIONS, n)))


def render_model(twin: TwinModel, settings: RenderSettings) -> TwinModel:
    """The model frames are drawn from: a copy of the twin's own or, for lean renders with
    the ``top`` / ``oblique`` camera where the robots are small in the frame, the same
    grid with its procedural links re-meshed at fewer facets per circle
    (:func:`lean_circle_sections`; CAD links are kept). Camera poses are copied from the
    twin's model (so an ``aim_closeup`` there carries over), then fitted
    (:func:`fitted_camera`) or aimed (``robot_id``); the offscreen buffer fits the frame.
    """
    geometry = twin.geometry
    wide = settings.camera in ("top", "oblique")
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
        rt = TwinModel(m, twin.mjspec, twin.index, twin.spec, twin.layout, geometry, twin.options,
                       twin.base_z_mm)
    m = rt.model
    for name in ("cam_pos", "cam_quat", "cam_pos0", "cam_mat0", "cam_fovy"):
        getattr(m, name)[:] = getattr(twin.model, name)
    if wide:
        m.cam_pos[c] = cam_pos
        m.cam_pos0[c] = cam_pos
    elif settings.robot_id is not None:
        rt.aim_closeup(int(settings.robot_id))
    m.vis.global_.offwidth = max(int(m.vis.global_.offwidth), settings.width)
    m.vis.global_.offheight = max(int(m.vis.global_.offheight), settings.height)
    if settings.lean:
        m.vis.quality.offsamples = 0
        m.vis.quality.numslices = 12
        m.vis.quality.numstacks = 6
        m.vis.quality.numquads = 1
    return rt


class FrameRenderer:
    """Draws frames of one grid with one camera into numpy arrays.

    Parameters
    ----------
    twin : TwinModel (not modified; frames come from a render copy, :func:`render_model`)
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
        # geoms coloured by state: visual geoms of alpha and beta bodies
        visual = ~idx.geom_collision
        gbody = np.asarray(m.geom_bodyid)
        link_geoms = []
        for bodies, shade in ((idx.beta_body, 1.0), (idx.alpha_body, ALPHA_SHADE)):
            robot_of = np.full(m.nbody, -1, dtype=np.int64)
            robot_of[bodies] = np.arange(self.n_robots)
            g = np.flatnonzero(visual & (robot_of[gbody] >= 0))
            link_geoms.append((g, robot_of[gbody[g]], shade))
        self._geoms = np.concatenate([g for g, _, _ in link_geoms])
        self._geom_robot = np.concatenate([r for _, r, _ in link_geoms])
        default = np.asarray(m.geom_rgba, dtype=np.float32)[self._geoms].copy()
        matid = np.asarray(m.geom_matid)[self._geoms]
        has_mat = matid >= 0
        default[has_mat] = np.asarray(m.mat_rgba)[matid[has_mat]]
        # palette (n_geoms, 4 states, 4): default colour for WAITING
        pal = np.empty((self._geoms.size, len(STATE_NAMES), 4), dtype=np.float32)
        shades = np.concatenate([np.full(g.size, s) for g, _, s in link_geoms])
        for state, rgba in STATE_RGBA.items():
            if rgba is None:
                pal[:, state] = default
            else:
                c = np.asarray(rgba, dtype=np.float32)
                pal[:, state, :3] = c[:3] * shades[:, None]
                pal[:, state, 3] = c[3]
        self._palette = pal
        self._rows = np.arange(self._geoms.size)
        self.states = np.zeros(self.n_robots, dtype=np.int8)
        self.set_states(self.states)
        # scene
        self.option = mujoco.MjvOption()
        if settings.lean and settings.camera != "closeup":
            self.option.sitegroup[:] = 0
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.camera.fixedcamid = int(self.twin.index.camera[settings.camera])
        self.scene = mujoco.MjvScene(m, maxgeom=int(m.ngeom + m.nsite + 64))
        if settings.lean:
            for flag in LEAN_OFF_FLAGS:
                if hasattr(mujoco.mjtRndFlag, flag):
                    self.scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        # GL
        gl_cls = _gl_context_class(self.backend)
        w, h = settings.width, settings.height
        try:
            self._gl = gl_cls(w, h)
            self._gl.make_current()
            self._con = mujoco.MjrContext(m, mujoco.mjtFontScale.mjFONTSCALE_100)
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._con)
        except Exception as exc:  # noqa: BLE001 - any GL failure is a render error
            self.close()
            raise RenderError(f"MUJOCO_GL={self.backend!r}: cannot create a {w}x{h} offscreen "
                              f"context ({type(exc).__name__}: {exc}); allowed: "
                              f"{', '.join(GL_BACKENDS)} with Mesa installed") from None
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
        if self._con is None:
            raise RenderError("render() after close(); allowed: a renderer that is open")
        if angles_deg is not None:
            self.set_angles(angles_deg)
        if states is not None:
            self.set_states(states)
        self._gl.make_current()
        mujoco.mjv_updateScene(self.model, self.data, self.option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        mujoco.mjr_render(self._rect, self.scene, self._con)
        mujoco.mjr_readPixels(self._buf, None, self._rect, self._con)
        if out is None:
            out = np.empty_like(self._buf)
        np.copyto(out, self._buf[::-1])
        return out

    def project(self, xyz: np.ndarray) -> np.ndarray:
        """Pixel coordinates (k, 2) as (column, row) of world points (k, 3) mm in the
        current camera (rows from the top); points behind the camera give NaN."""
        m, d = self.model, self.data
        c = self.camera.fixedcamid
        rel = np.asarray(xyz, float).reshape(-1, 3) - d.cam_xpos[c]
        cam = rel @ d.cam_xmat[c].reshape(3, 3)  # camera axes: x right, y up, -z forward
        w, h = self.settings.width, self.settings.height
        f = 0.5 * h / math.tan(math.radians(float(m.cam_fovy[c])) / 2.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = -cam[:, 2]
            col = w / 2.0 + f * cam[:, 0] / depth
            row = h / 2.0 - f * cam[:, 1] / depth
        out = np.column_stack([col, row])
        out[depth <= 0] = np.nan
        return out

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

    def __enter__(self) -> FrameRenderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


def render_frame(twin: TwinModel, angles_deg: np.ndarray | None = None,
                 settings: RenderSettings | None = None,
                 states: np.ndarray | None = None) -> np.ndarray:
    """One frame (height, width, 3) uint8 of the grid at ``angles_deg`` (n, 2) deg
    (default: the spec's fold), robots coloured by ``states`` (n,) (default: waiting)."""
    with FrameRenderer(twin, settings) as fr:
        return fr.render(angles_deg, states)


# -- the timeline of a video ------------------------------------------------------------
@dataclass
class FrameTimeline:
    """What each frame shows: times (F,) sim s; angles (F, n, 2) true joint angles, deg;
    states (F, n) int8 state codes (see :data:`STATE_NAMES`)."""

    times: np.ndarray
    angles: np.ndarray
    states: np.ndarray

    @property
    def n_frames(self) -> int:
        return int(self.times.size)

    def state_counts(self) -> dict[str, int]:
        """Robot-frames in each state."""
        return {name: int(np.count_nonzero(self.states == k)) for k, name in enumerate(STATE_NAMES)}


def frame_times(sim_s: float, settings: RenderSettings) -> np.ndarray:
    """Sim times of the frames: ``k * speedup / fps``, k = 0 .. floor(sim_s * fps / speedup)."""
    dt = settings.frame_dt_s
    n = int(math.floor(max(0.0, sim_s) / dt + 1e-9)) + 1
    return np.arange(n) * dt


def frame_timeline(twin: TwinModel, report: SimReport, settings: RenderSettings) -> FrameTimeline:
    """Angles and robot states at each frame time of a simulation with a record."""
    rec = report.record
    if rec is None or rec.times.size == 0:
        raise RenderError("the simulation report has no sampled record; allowed: a report "
                          "from simulate(..., record=True)")
    times = frame_times(report.sim_s, settings)
    t, a = np.asarray(rec.times, float), np.asarray(rec.angles, float)
    if t.size == 1:
        angles = np.repeat(a[:1], times.size, axis=0)
        speed = np.zeros(angles.shape[:2])
    else:
        i0 = np.clip(np.searchsorted(t, times, side="right") - 1, 0, t.size - 2)
        span = t[i0 + 1] - t[i0]
        w = np.clip((times - t[i0]) / np.where(span > 0, span, 1.0), 0.0, 1.0)[:, None, None]
        angles = a[i0] * (1.0 - w) + a[i0 + 1] * w
        rate = np.abs(a[i0 + 1] - a[i0]) / np.where(span > 0, span, np.inf)[:, None, None]
        speed = rate.max(axis=2)
    final = np.asarray(rec.reference, float)[-1]
    states = np.full(angles.shape[:2], WAITING, dtype=np.int8)
    states[np.abs(angles - final[None]).max(axis=2) <= ARRIVED_TOL_DEG] = ARRIVED
    states[speed > MOVING_DEG_S] = MOVING
    c = report.contacts
    if len(c):
        # a contact at time tc shows on the first frame at or after it
        dt = settings.frame_dt_s
        frame = np.clip(np.ceil(np.asarray(c.time_s) / dt - 1e-9).astype(np.int64), 0, times.size - 1)
        lay = twin.layout
        for ids in (np.asarray(c.robot_a), np.asarray(c.robot_b)):
            keep = ids >= 0
            if keep.any():
                states[frame[keep], lay.robot_indices(ids[keep])] = CONTACT
    return FrameTimeline(times, angles, states)


# -- MP4 -----------------------------------------------------------------------------
class Mp4Writer:
    """Frames (height, width, 3) uint8 into an H.264 MP4 (imageio-ffmpeg), written to a
    temp file beside ``path`` and renamed onto it by :meth:`close` (removed on error)."""

    def __init__(self, path: str | Path, width: int, height: int, fps: float,
                 crf: int = 23, preset: str = "veryfast") -> None:
        self.path = Path(path)
        self.size = (int(width), int(height))
        self.frames = 0
        parent = self.path.parent
        try:
            parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=parent, prefix=f".{self.path.stem}.", suffix=".tmp.mp4")
            os.close(fd)
        except OSError as exc:
            raise RenderError(f"{self.path}: cannot write here ({exc.strerror}); allowed: a path "
                              "in a writable folder") from None
        self._tmp = Path(tmp)
        self._gen = imageio_ffmpeg.write_frames(
            str(self._tmp), self.size, fps=float(fps), codec="libx264", quality=None,
            pix_fmt_out="yuv420p", macro_block_size=2, ffmpeg_log_level="error",
            output_params=["-preset", preset, "-crf", str(int(crf)), "-movflags", "+faststart"])
        self._gen.send(None)

    def write(self, frame: np.ndarray) -> None:
        if frame.shape != (self.size[1], self.size[0], 3) or frame.dtype != np.uint8:
            raise RenderError(f"frame of shape {frame.shape} {frame.dtype}; allowed: "
                              f"({self.size[1]}, {self.size[0]}, 3) uint8")
        self._gen.send(np.ascontiguousarray(frame))
        self.frames += 1

    def close(self) -> Path:
        """Finish the file and move it into place; returns the path."""
        if self._gen is None:
            return self.path
        try:
            self._gen.close()
            self._gen = None
            os.chmod(self._tmp, 0o644)
            os.replace(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Drop the partial file."""
        gen, self._gen = self._gen, None
        if gen is not None:
            try:
                gen.close()
            except Exception:  # noqa: BLE001 - already failing
                pass
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> Mp4Writer:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


# -- a whole run -------------------------------------------------------------------------
@dataclass
class RenderReport:
    """What :func:`render_run` wrote.

    path : the MP4; frames : frames written; video_s : frames / fps; sim_s : simulated
    time shown; width, height, fps, speedup, camera : as rendered; backend : MUJOCO_GL;
    render_s : wall time of drawing (scene + GL + read-back); total_s : wall time of the
    whole video (drawing + encoding, not the simulation); sim_wall_s : wall time of the
    simulation (0 when a report was given); state_counts : robot-frames per state.
    """

    path: Path
    frames: int
    video_s: float
    sim_s: float
    width: int
    height: int
    fps: float
    speedup: float
    camera: str
    backend: str
    render_s: float
    total_s: float
    sim_wall_s: float = 0.0
    state_counts: dict[str, int] = field(default_factory=dict)
    sim_report: SimReport | None = field(default=None, repr=False)

    @property
    def fps_rendered(self) -> float:
        """Frames drawn per wall second (drawing only)."""
        return self.frames / self.render_s if self.render_s > 0 else math.inf

    @property
    def fps_achieved(self) -> float:
        """Frames per wall second, drawing and encoding."""
        return self.frames / self.total_s if self.total_s > 0 else math.inf

    def to_dict(self) -> dict:
        return {"path": str(self.path), "frames": self.frames, "video_s": self.video_s,
                "sim_s": self.sim_s, "width": self.width, "height": self.height, "fps": self.fps,
                "speedup": self.speedup, "camera": self.camera, "backend": self.backend,
                "render_s": self.render_s, "total_s": self.total_s, "sim_wall_s": self.sim_wall_s,
                "fps_rendered": self.fps_rendered, "fps_achieved": self.fps_achieved,
                "state_counts": dict(self.state_counts)}


Progress = Callable[[int, int], None]


def render_run(twin: TwinModel, trajectory: Trajectory | None, out_mp4: str | Path,
               settings: RenderSettings | None = None, sim_report: SimReport | None = None,
               faults=(), sim_settings: SimSettings | None = None,
               progress: Progress | None = None) -> RenderReport:
    """Render a run to an MP4.

    Parameters
    ----------
    twin : TwinModel
    trajectory : what to simulate (ignored when ``sim_report`` is given).
    out_mp4 : path of the video (written atomically).
    settings : RenderSettings
    sim_report : a finished simulation with its record; default: simulate ``trajectory``
        with ``faults`` and ``sim_settings`` (:func:`twin.sim.simulate`).
    progress : called as ``progress(frames_done, frames_total)`` after each frame.

    Returns
    -------
    RenderReport
    """
    settings = settings or RenderSettings()
    backend = require_backend()
    sim_wall = 0.0
    if sim_report is None:
        if trajectory is None:
            raise RenderError("render_run needs a trajectory or a simulation report")
        t0 = time.perf_counter()
        sim_report = simulate(twin, trajectory, faults, sim_settings, record=True)
        sim_wall = time.perf_counter() - t0
    timeline = frame_timeline(twin, sim_report, settings)
    t_total = time.perf_counter()
    t_render = 0.0
    with FrameRenderer(twin, settings) as fr, \
            Mp4Writer(out_mp4, settings.width, settings.height, settings.fps, settings.crf,
                      settings.preset) as writer:
        frame = np.empty((settings.height, settings.width, 3), dtype=np.uint8)
        for j in range(timeline.n_frames):
            t0 = time.perf_counter()
            fr.render(timeline.angles[j], timeline.states[j], out=frame)
            t_render += time.perf_counter() - t0
            writer.write(frame)
            if progress is not None:
                progress(j + 1, timeline.n_frames)
        frames = writer.frames
    total = time.perf_counter() - t_total
    return RenderReport(Path(out_mp4), frames, frames / settings.fps, float(sim_report.sim_s),
                        settings.width, settings.height, float(settings.fps),
                        float(settings.speedup), settings.camera, backend, t_render, total,
                        sim_wall, timeline.state_counts(), sim_report)


def save_png(image: np.ndarray, path: str | Path) -> Path:
    """Write an (h, w, 3) uint8 image as PNG, atomically."""
    import imageio.v3 as iio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".tmp.png")
    os.close(fd)
    try:
        iio.imwrite(tmp, np.asarray(image, dtype=np.uint8))
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


__all__ = ["ARRIVED", "BACKEND", "CONTACT", "FrameRenderer", "FrameTimeline", "GL_BACKENDS",
           "MOVING", "Mp4Writer", "RenderError", "RenderReport", "RenderSettings", "STATE_NAMES",
           "WAITING", "fitted_camera", "frame_timeline", "frame_times", "gl_renderer_info",
           "lean_circle_sections", "probe_gl_backend", "render_frame", "render_model",
           "render_run", "require_backend", "save_png", "select_gl_backend"]
