"""Large-array frames: the whole array in a handful of draw calls.

:class:`FrameRenderer` draws one MuJoCo geom per robot part (~8 us each on llvmpipe: 38,557
geoms at 12,852 robots). :class:`MergedFrameRenderer` builds its own small render-only
model instead (no physics grid model is compiled):

- the plate, lights and cameras of the grid model
  (:func:`rfp_twin.models.mjcf.cameras.add_scene`), the cameras fitted as FrameRenderer's;
- one static merged mesh of every robot's fixed body and one of every fiducial post
  (guide-camera walls stay boxes), in world coordinates;
- for each moving link (alpha, beta) and each robot state (:data:`STATE_RGBA`), one
  dynamic merged mesh with room for every robot. The robots in that state are packed into
  its first slots, their vertices and normals posed from the joint angles (numba,
  :func:`_pose_slots`), the mesh re-uploaded (``mujoco.mjr_uploadMesh``) with
  ``mesh_facenum`` cut to the used slots; only when its robots changed or moved.

Robot placement is the grid model's (:func:`rfp_twin.models.mjcf.bodies.robot_frames`: each
robot on its own axis on a curved wok, its own alpha arm length from the calibration
columns). Link shapes are the grid model's visual meshes at the lean facet count, with
MuJoCo's own normals; when the robot pitch is under :data:`CAP_PITCH_PX` pixels in the
frame, each moving link is only its top cap (:func:`cap_template`: its outline seen from
above, at most :data:`CAP_MAX_VERTS` corners, 4 under :data:`QUAD_PITCH_PX`): llvmpipe
takes ~0.35 us to upload and ~0.3 us to draw a triangle, and 12,852 robots have 1.8 M link
triangles at the lean facet count, 51 k as quads (pitch 5.3 px at 1280x720, top).

Lean renders (no multisampling) draw the static part once into a background (colour and
depth) and each frame only the moving links, composited over it by depth
(:func:`_composite`); ``lean=False`` draws everything every frame. Fibers are not drawn.
The ``closeup`` camera is not supported (FrameRenderer draws close-ups).

Shapes: n robots (layout order); angles (n, 2) deg (alpha, beta); states (n,) state
codes; world points mm; pixel coordinates (column, row) from the top-left corner.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh
from numba import njit
from scipy.spatial import ConvexHull

from rfp_twin.models.geometry import RobotGeometry, geometry_for_spec
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf.bodies import add_default_classes, obstacle_shapes, robot_frames
from rfp_twin.models.mjcf.blocks import quiet_attach
from rfp_twin.models.mjcf.cameras import add_scene, quat_to_mat
from rfp_twin.models.mjcf.options import RGBA, VISUAL_GROUP
from rfp_twin.models.robot import RobotSpec
from rfp_twin.twin.render.backend import RenderError, require_backend
from rfp_twin.twin.render.camera import fit_offscreen, lean_sections_for, wide_camera_setup
from rfp_twin.twin.render.frames import (SCENE_SPARE, OffscreenOwner, lean_scene,
                                         open_offscreen, project_points, state_colours)
from rfp_twin.twin.render.settings import RenderSettings
from rfp_twin.twin.render.timeline import STATE_NAMES

#: Automatic choice (``RenderSettings.merged = None``): merged above this many robots.
MERGED_MIN_ROBOTS = 1000
#: Moving links are drawn as top caps when the robot pitch is below this in the frame, px.
CAP_PITCH_PX = 10.0
#: Most corners of a top cap ...
CAP_MAX_VERTS = 6
#: ... and of a top cap when the robot pitch is below this in the frame, px: a quad.
QUAD_PITCH_PX = 9.0
#: Geom groups: the static part (plate, fixed bodies, fiducials) and the moving links.
STATIC_GROUP = VISUAL_GROUP
DYNAMIC_GROUP = 1
#: The moving links, in drawing order.
MOVING = ("alpha", "beta")


def use_merged(settings: RenderSettings, n_robots: int, pitch_px: float | None = None) -> bool:
    """Whether to draw with :class:`MergedFrameRenderer`: ``settings.merged`` if set, else
    for over :data:`MERGED_MIN_ROBOTS` robots under :data:`CAP_PITCH_PX` (``pitch_px``,
    from :func:`~rfp_twin.twin.render.camera.wide_camera_setup`; None: not checked): with
    lean meshes FrameRenderer is faster. Never for the ``closeup`` camera."""
    if not settings.wide:
        return False
    if settings.merged is not None:
        return settings.merged
    return n_robots > MERGED_MIN_ROBOTS and (pitch_px is None or pitch_px < CAP_PITCH_PX)


# -- link shapes -----------------------------------------------------------------------
@dataclass(frozen=True)
class LinkTemplate:
    """One link's triangles in its link frame, mm, as MuJoCo draws them.

    verts (v, 3) float64; normals (k, 3) float64 unit; faces (f, 3) int32 vertex indices;
    facenormals (f, 3) int32 normal indices (per face corner).
    """

    verts: np.ndarray
    normals: np.ndarray
    faces: np.ndarray
    facenormals: np.ndarray


def mesh_template(mesh: trimesh.Trimesh) -> LinkTemplate:
    """The link mesh as MuJoCo compiles it (its vertices, smoothed normals and faces),
    brought back from MuJoCo's mesh frame into the link frame."""
    s = mujoco.MjSpec()
    s.add_mesh(name="m", uservert=np.asarray(mesh.vertices, float).ravel().tolist(),
               userface=np.asarray(mesh.faces, np.int64).ravel().tolist())
    s.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="m", contype=0,
                         conaffinity=0, density=0.0)
    with quiet_attach():
        m = s.compile()
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(m.geom_quat[0], float))
    rot = rot.reshape(3, 3)
    v = np.asarray(m.mesh_vert, float) @ rot.T + np.asarray(m.geom_pos[0], float)
    nrm = np.asarray(m.mesh_normal, float) @ rot.T
    return LinkTemplate(v, nrm, np.asarray(m.mesh_face, np.int32).copy(),
                        np.asarray(m.mesh_facenormal, np.int32).copy())


def cap_template(mesh: trimesh.Trimesh, max_verts: int = CAP_MAX_VERTS) -> LinkTemplate:
    """The link's top cap: the convex outline of the mesh seen from above, cut to at most
    ``max_verts`` corners (dropping the corner that loses the least area, one at a time),
    flat at the mesh's top height, facing +z (link frame, mm)."""
    v = np.asarray(mesh.vertices, float)
    xy = v[:, :2]
    ring = xy[ConvexHull(xy).vertices]            # counter-clockwise
    while len(ring) > max(3, max_verts):
        prev, nxt = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
        area = np.abs((ring[:, 0] - prev[:, 0]) * (nxt[:, 1] - prev[:, 1])
                      - (ring[:, 1] - prev[:, 1]) * (nxt[:, 0] - prev[:, 0]))
        ring = np.delete(ring, int(np.argmin(area)), axis=0)
    k = len(ring)
    verts = np.column_stack([ring, np.full(k, v[:, 2].max())])
    faces = np.array([[0, i, i + 1] for i in range(1, k - 1)], dtype=np.int32)
    # one normal per vertex: MuJoCo re-indexes a mesh whose vertices share one normal
    return LinkTemplate(verts, np.tile([0.0, 0.0, 1.0], (k, 1)), faces, faces.copy())


# -- numba kernels ---------------------------------------------------------------------
@njit(cache=True)
def _pose_slots(tv, tn, order, rot, origin, hinge, arm, a_rad, b_rad, out_v, out_n):
    """Vertices and normals of the robots ``order`` (k,) packed into slots 0..k-1.

    tv (v, 3), tn (m, 3): template vertices / normals, link frame; rot (n, 3, 3) and
    origin (n, 3): each robot frame in the world (mm); hinge (3,): the alpha hinge in the
    robot frame; arm (n, 3): the link's offset from the alpha frame before rotating by
    ``b_rad`` (the beta hinge for the beta link, zero for the alpha link); a_rad, b_rad
    (n,): joint angles (b_rad zero for the alpha link). A link point p goes to
    ``origin + R (hinge + Rz(a) (arm + Rz(b) p))``. out_v (>= k v, 3), out_n (>= k m, 3)
    float32 written.
    """
    nv = tv.shape[0]
    nn = tn.shape[0]
    o = np.empty(3)
    mat = np.empty((3, 3))
    for j in range(order.size):
        k = order[j]
        ca, sa = math.cos(a_rad[k]), math.sin(a_rad[k])
        c = a_rad[k] + b_rad[k]
        cc, sc = math.cos(c), math.sin(c)
        tx = hinge[0] + ca * arm[k, 0] - sa * arm[k, 1]
        ty = hinge[1] + sa * arm[k, 0] + ca * arm[k, 1]
        tz = hinge[2] + arm[k, 2]
        r = rot[k]
        for d in range(3):          # o = origin + R t;  M = R Rz(c)
            o[d] = origin[k, d] + r[d, 0] * tx + r[d, 1] * ty + r[d, 2] * tz
            mat[d, 0] = r[d, 0] * cc + r[d, 1] * sc
            mat[d, 1] = r[d, 1] * cc - r[d, 0] * sc
            mat[d, 2] = r[d, 2]
        for i in range(nv):
            for d in range(3):
                out_v[j * nv + i, d] = (o[d] + mat[d, 0] * tv[i, 0] + mat[d, 1] * tv[i, 1]
                                        + mat[d, 2] * tv[i, 2])
        for i in range(nn):
            for d in range(3):
                out_n[j * nn + i, d] = (mat[d, 0] * tn[i, 0] + mat[d, 1] * tn[i, 1]
                                        + mat[d, 2] * tn[i, 2])


@njit(cache=True)
def _composite(rgb, depth, bg_rgb, bg_depth, out):
    """``out`` (h, w, 3) uint8, top row first: the moving-link pixel ``rgb`` where its
    ``depth`` is nearer than the background's, else the background (inputs bottom row
    first, as OpenGL reads them; depths (h, w) float32 in [0, 1])."""
    h, w = depth.shape
    for r in range(h):
        ro = h - 1 - r
        for c in range(w):
            src = rgb if depth[r, c] < bg_depth[r, c] else bg_rgb
            for k in range(3):
                out[ro, c, k] = src[r, c, k]


# -- the renderer ------------------------------------------------------------------------
class MergedFrameRenderer(OffscreenOwner):
    """Draws frames of a large array with one camera into numpy arrays, in a handful of
    draw calls; same interface as :class:`rfp_twin.twin.render.frames.FrameRenderer`.

    Parameters
    ----------
    spec : RobotSpec; layout : Layout
    geometry : RobotGeometry, default :func:`rfp_twin.models.geometry.geometry_for_spec`
    settings : RenderSettings (camera ``top`` or ``oblique``)

    Attributes: ``n_robots``, ``settings``, ``backend``, ``model`` / ``data`` (the
    render-only model), ``caps`` (moving links drawn as top caps), ``sections`` (facets
    per circle). Use as a context manager (or call :meth:`close`): it owns a GL context.
    """

    def __init__(self, spec: RobotSpec, layout: Layout, geometry: RobotGeometry | None = None,
                 settings: RenderSettings | None = None) -> None:
        self._gl = None
        self._con = None
        self.settings = settings = settings or RenderSettings()
        if not settings.wide:
            raise RenderError(f"field 'camera' = {settings.camera!r} for the merged renderer; "
                              "allowed: top, oblique (FrameRenderer draws close-ups)")
        if layout.n_robots == 0:
            raise RenderError(f"layout {layout.name!r}: no robots; allowed: at least one robot")
        self.backend = require_backend()
        geometry = geometry if geometry is not None else geometry_for_spec(spec)
        self.spec, self.layout = spec, layout
        self.n_robots = n = layout.n_robots
        p = geometry.params
        self.base_z_mm = base_z = p.focal_z_mm - p.fiber_z_mm
        # camera pose and level of detail; pitch_px: robot pitch in the frame, px
        cam_pos, distance, fovy, self.pitch_px = wide_camera_setup(spec, layout, p, settings)
        self.sections = lean_sections_for(p, fovy, settings.height, distance) \
            if settings.lean else p.circle_sections
        if self.sections < p.circle_sections:
            geometry = geometry.with_params(circle_sections=self.sections)
        self.geometry = geometry
        self.caps = bool(self.pitch_px < CAP_PITCH_PX)
        corners = 4 if self.pitch_px < QUAD_PITCH_PX else CAP_MAX_VERTS
        # robots
        frames = robot_frames(layout, geometry)
        self._rot = np.ascontiguousarray([quat_to_mat(q) for q in frames.quat])
        self._origin = np.ascontiguousarray(frames.origin + [0.0, 0.0, base_z])
        self._hinge = np.asarray(geometry.link_offset("alpha"), float)
        arm_beta = np.tile(np.asarray(geometry.link_offset("beta"), float), (n, 1))
        arm_beta[:, 0] = frames.alpha_len
        self._arm = {"alpha": np.zeros((n, 3)), "beta": np.ascontiguousarray(arm_beta)}
        # templates
        self._tpl = {link: cap_template(geometry.links[link].visual, corners) if self.caps
                     else mesh_template(geometry.links[link].visual) for link in MOVING}
        self._angles = np.radians(np.tile(np.asarray(spec.fold_deg, float), (n, 1)))
        self.states = np.zeros(n, dtype=np.int8)
        # render-only model
        m = self.model = self._build(spec, layout, geometry, frames, base_z, cam_pos)
        self.data = mujoco.MjData(m)
        mujoco.mj_kinematics(m, self.data)
        mujoco.mj_camlight(m, self.data)
        # what the dynamic meshes show on the GPU: angles (rad) and robots of each state
        self._posed, self._order = np.full((n, 2), np.nan), [None] * len(STATE_NAMES)
        # scene
        self.option = mujoco.MjvOption()
        self.option.sitegroup[:] = 0
        self.option.geomgroup[:] = 0
        self.option.geomgroup[DYNAMIC_GROUP] = 1
        self._cached = bool(settings.lean)
        if not self._cached:
            self.option.geomgroup[STATIC_GROUP] = 1
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self.camera.fixedcamid = int(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA,
                                                       settings.camera))
        self.scene = lean_scene(m, m.ngeom + SCENE_SPARE, settings.lean)
        w, h = settings.width, settings.height
        self._gl, self._con = open_offscreen(self.backend, m, w, h)
        self._rect = mujoco.MjrRect(0, 0, w, h)
        self._buf = np.empty((h, w, 3), dtype=np.uint8)
        self._depth = np.empty((h, w), dtype=np.float32)
        self._bg = self._bg_depth = None
        if self._cached:
            self._bg, self._bg_depth = self._draw_static()

    def _build(self, spec, layout, geometry, frames, base_z, cam_pos) -> mujoco.MjModel:
        """Compile the render-only model: scene, static meshes, dynamic link meshes."""
        n = self.n_robots
        s = mujoco.MjSpec()
        s.modelname = f"rfp-twin-render-{spec.name}-{layout.name}"
        for key, rgba in RGBA.items():
            s.add_material(name=key, rgba=list(rgba))
        vis, _ = add_default_classes(s)
        add_scene(s, spec, layout, geometry.params, base_z, None, vis)
        world = s.worldbody
        shell = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        zero3 = np.zeros(3)
        everyone = np.arange(n, dtype=np.int64)
        no_turn = np.zeros(n)

        def static_mesh(name, verts, faces, material):
            mesh = s.add_mesh(name=name, uservert=verts.ravel().tolist(),
                              userface=faces.ravel().tolist())
            mesh.inertia = shell
            world.add_geom(default=vis, name=name, meshname=name, material=material,
                           group=STATIC_GROUP)

        # fixed bodies, world frame
        body = geometry.links["body"].visual
        bv, bf = np.asarray(body.vertices, float), np.asarray(body.faces, np.int64)
        out_v = np.empty((n * len(bv), 3), np.float32)
        _pose_slots(bv, np.zeros((1, 3)), everyone, self._rot, self._origin, zero3,
                    np.zeros((n, 3)), no_turn, no_turn, out_v, np.empty((n, 3), np.float32))
        static_mesh("bodies", out_v, _tiled(bf, n, len(bv)), "body")
        # fiducial posts (one mesh) and guide-camera walls (boxes)
        obst = obstacle_shapes(spec, layout, geometry, frames.z)
        seg = obst.segment
        if layout.n_fiducials and not seg.all():
            post = geometry.links["fiducial"].visual
            pv, pf = np.asarray(post.vertices, float), np.asarray(post.faces, np.int64)
            at = np.column_stack([obst.a[~seg], base_z + obst.z[~seg]])
            verts = (pv[None] + at[:, None]).reshape(-1, 3)
            static_mesh("fiducials", verts, _tiled(pf, len(at), len(pv)), "fiducial")
        for f in np.flatnonzero(seg):
            centre, half, quat = obst.slab_box(int(f))
            pos = np.array([*obst.a[f], base_z + obst.z[f]]) + centre
            world.add_geom(default=vis, name=f"wall{int(f)}", type=mujoco.mjtGeom.mjGEOM_BOX,
                           size=list(half), pos=list(pos), quat=list(quat), material="fiducial",
                           group=STATIC_GROUP)
        # dynamic meshes: one per (moving link, state), room for every robot
        self._mesh = {}
        for link in MOVING:
            t = self._tpl[link]
            nv, nn = len(t.verts), len(t.normals)
            v0 = np.empty((n * nv, 3), np.float32)
            n0 = np.empty((n * nn, 3), np.float32)
            b = self._angles[:, 1] if link == "beta" else no_turn
            _pose_slots(t.verts, t.normals, everyone, self._rot, self._origin, self._hinge,
                        self._arm[link], self._angles[:, 0], b, v0, n0)
            faces = _tiled(t.faces, n, nv)
            fnorm = _tiled(t.facenormals, n, nn)
            for state, rgba in enumerate(state_colours(link)):
                name = f"{link}_{STATE_NAMES[state]}"
                mesh = s.add_mesh(name=name, uservert=v0.ravel().tolist(),
                                  usernormal=n0.ravel().tolist(),
                                  userface=faces.ravel().tolist(),
                                  userfacenormal=fnorm.ravel().tolist())
                mesh.inertia = shell
                world.add_geom(default=vis, name=name, meshname=name, material=link,
                               rgba=[float(c) for c in rgba], group=DYNAMIC_GROUP)
                self._mesh[link, state] = name
        try:
            with quiet_attach():
                m = s.compile()
        except ValueError as exc:
            raise RenderError(f"MuJoCo could not compile the render model of {layout.name!r}: "
                              f"{exc}") from None
        # the dynamic meshes: world coordinates, geom at the origin, layout as given
        self._slot = {}
        for (link, state), name in self._mesh.items():
            t = self._tpl[link]
            mid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_MESH, name)
            gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)
            nv, nn, nf = len(t.verts), len(t.normals), len(t.faces)
            fa, fn = int(m.mesh_faceadr[mid]), int(m.mesh_facenum[mid])
            if (int(m.mesh_vertnum[mid]) != n * nv or int(m.mesh_normalnum[mid]) != n * nn
                    or fn != n * nf
                    or not np.array_equal(m.mesh_face[fa:fa + fn], _tiled(t.faces, n, nv))
                    or not np.array_equal(m.mesh_facenormal[fa:fa + fn],
                                          _tiled(t.facenormals, n, nn))):
                raise RenderError(f"mesh {name!r}: MuJoCo {mujoco.__version__} re-ordered the "
                                  "merged mesh on compile; allowed: a MuJoCo that keeps the "
                                  "given vertices, normals and faces")
            m.geom_pos[gid] = 0.0
            m.geom_quat[gid] = [1.0, 0.0, 0.0, 0.0]
            va, na = int(m.mesh_vertadr[mid]), int(m.mesh_normaladr[mid])
            self._slot[link, state] = (mid, va, na, nf)
        c = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, self.settings.camera)
        m.cam_pos[c] = m.cam_pos0[c] = cam_pos
        fit_offscreen(m, self.settings)
        return m

    def set_angles(self, angles_deg: np.ndarray) -> None:
        """Pose every robot at (n, 2) deg (layout robot order)."""
        a = np.asarray(angles_deg, dtype=np.float64)
        if a.shape != (self.n_robots, 2):
            raise RenderError(f"angles: shape {a.shape}; allowed: ({self.n_robots}, 2) deg "
                              "(alpha, beta) per robot")
        bad = np.flatnonzero(~np.isfinite(a).all(axis=1))
        if bad.size:
            k = int(bad[0])
            raise RenderError(f"angles: robot {int(self.layout.robot_ids[k])} = "
                              f"{a[k].tolist()}; allowed: finite degrees")
        self._angles = np.radians(a)

    def set_states(self, states: np.ndarray) -> None:
        """Colour the robots by (n,) state codes (WAITING, MOVING, ARRIVED, CONTACT)."""
        s = np.asarray(states)
        if s.shape != (self.n_robots,):
            raise RenderError(f"states: shape {s.shape}; allowed: ({self.n_robots},) state "
                              "codes")
        bad = np.flatnonzero((s < 0) | (s >= len(STATE_NAMES)) | (s != np.round(s)))
        if bad.size:
            k = int(bad[0])
            raise RenderError(f"states: robot {int(self.layout.robot_ids[k])} = {s[k].item()!r}; "
                              f"allowed: 0..{len(STATE_NAMES) - 1} ({', '.join(STATE_NAMES)})")
        self.states = s.astype(np.int8)

    def _upload(self) -> None:
        """Re-pose and upload the dynamic meshes of each state whose robots changed or
        moved since the last upload (robots packed by state)."""
        m = self.model
        a, b = self._angles[:, 0], self._angles[:, 1]
        zero = np.zeros(self.n_robots)
        moved = np.any(self._angles != self._posed, axis=1)
        for state in range(len(STATE_NAMES)):
            order = np.flatnonzero(self.states == state).astype(np.int64)
            if np.array_equal(order, self._order[state]) and not moved[order].any():
                continue                        # same robots, none moved: mesh as uploaded
            self._order[state] = order
            for link in MOVING:
                mid, va, na, nf = self._slot[link, state]
                t = self._tpl[link]
                k = order.size
                if k:
                    _pose_slots(t.verts, t.normals, order, self._rot, self._origin, self._hinge,
                                self._arm[link], a, b if link == "beta" else zero,
                                m.mesh_vert[va:va + k * len(t.verts)],
                                m.mesh_normal[na:na + k * len(t.normals)])
                if k or m.mesh_facenum[mid]:
                    m.mesh_facenum[mid] = k * nf
                    mujoco.mjr_uploadMesh(m, self._con, mid)
        self._posed = self._angles.copy()

    def _draw(self, option: mujoco.MjvOption, depth: np.ndarray | None) -> None:
        mujoco.mjv_updateScene(self.model, self.data, option, None, self.camera,
                               mujoco.mjtCatBit.mjCAT_ALL, self.scene)
        mujoco.mjr_render(self._rect, self.scene, self._con)
        mujoco.mjr_readPixels(self._buf, depth, self._rect, self._con)

    def _draw_static(self) -> tuple[np.ndarray, np.ndarray]:
        """The static part alone (colour, depth; bottom row first)."""
        self._gl.make_current()
        opt = mujoco.MjvOption()
        opt.sitegroup[:] = 0
        opt.geomgroup[:] = 0
        opt.geomgroup[STATIC_GROUP] = 1
        self._draw(opt, self._depth)
        return self._buf.copy(), self._depth.copy()

    def render(self, angles_deg: np.ndarray | None = None, states: np.ndarray | None = None,
               out: np.ndarray | None = None) -> np.ndarray:
        """One frame, (height, width, 3) uint8, top row first. Poses / colours the robots
        first when ``angles_deg`` (n, 2) / ``states`` (n,) are given."""
        self._begin_frame(angles_deg, states)
        self._upload()
        if out is None:
            out = np.empty_like(self._buf)
        if self._cached:
            self._draw(self.option, self._depth)
            _composite(self._buf, self._depth, self._bg, self._bg_depth, out)
        else:
            self._draw(self.option, None)
            np.copyto(out, self._buf[::-1])
        return out

    def project(self, xyz: np.ndarray) -> np.ndarray:
        """Pixel coordinates (k, 2) as (column, row) of world points (k, 3) mm in the
        camera (rows from the top); points behind the camera give NaN."""
        return project_points(self.model, self.data, self.camera.fixedcamid,
                              self.settings.width, self.settings.height, xyz)

    def robot_points(self, link: str = "beta", x_mm: float = 0.0) -> np.ndarray:
        """(n, 3) world points, mm, at the current angles: on each robot's ``link`` frame
        (``alpha`` or ``beta``) axis ``x_mm`` along the arm, at the link's top height."""
        t = self._tpl[link]
        top = float(t.verts[:, 2].max())
        pt = np.array([[x_mm, 0.0, top]])
        out = np.empty((self.n_robots, 3), np.float32)
        b = self._angles[:, 1] if link == "beta" else np.zeros(self.n_robots)
        _pose_slots(pt, pt, np.arange(self.n_robots, dtype=np.int64), self._rot, self._origin,
                    self._hinge, self._arm[link], self._angles[:, 0], b, out,
                    np.empty((self.n_robots, 3), np.float32))
        return out.astype(float)


def _tiled(faces: np.ndarray, copies: int, stride: int) -> np.ndarray:
    """(copies * f, 3) int32: ``faces`` (f, 3) repeated, copy j offset by ``j * stride``."""
    f = np.asarray(faces, np.int64)
    off = (np.arange(copies, dtype=np.int64) * stride)[:, None, None]
    return (f[None] + off).reshape(-1, 3).astype(np.int32)
