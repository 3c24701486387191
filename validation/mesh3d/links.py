"""Link models of one robot design: capsules, hulls, speed radii, FCL BVH per piece.

FCL sees exactly the meshes MuJoCo collides: the convex collision pieces of every link
of :class:`rfp_twin.models.geometry.RobotGeometry` (``Link.collision``, the pieces
:mod:`rfp_twin.models.mjcf` turns into collision geoms). Each piece becomes one FCL ``BVHModel``
(OBBRSS), built once per link *kind* (``body``, ``alpha``, ``beta``, ``fiducial``):
every robot shares them, only transforms differ. A robot is the links ``body``,
``alpha`` and ``beta``; a fiducial the link ``fiducial``. (The MuJoCo model gives the
fixed body no collision geom; it is checked here too, which can only add findings: with
the procedural meshes it never comes near anything.)

Per link kind, :class:`LinkModels` also holds the z interval (robot frame; rotations
about z keep it), the reach (the largest xy distance of any point from the alpha axis
over all joint angles: ``l_alpha + max |p|`` for the beta link) and the speed radii
``r_a``, ``r_b``: the largest distances of the link's mesh vertices (and of its capsule
segment ends) from the joint axis. For a convex piece the largest distance is reached at
a vertex, so a point of the beta link moves at most ``|a'| (l_alpha + r_b) + |b'| r_b``,
one of the alpha link at most ``|a'| r_a``; body and fiducial do not move. Units: mm,
deg at the public boundary.

Each robot's own geometry (:class:`Placement`, from the layout columns of
:mod:`rfp_twin.models.layout.columns`): its alpha arm ``alpha_len_mm`` sets where its beta
axis is (the alpha link's mesh stays the nominal one: it differs by at most 0.1 mm on the
calibrated instruments), the whole robot is tilted by the smallest rotation ``R_k`` taking z
to its axis ``(kx, ky, kz)`` and stands on that axis with its focal-surface point at the
layout's x, y and ``z_mm`` (frame origin ``fiber_z_mm`` back along the axis,
:func:`rfp_twin.models.layout.columns.robot_frame_origins`): a link's world transform
is ``R_k Rz(theta)`` and ``base + R_k (local offset)`` (:func:`link_frames`), the MuJoCo
model's body poses. Obstacles: a point (fiducial) is the fiducial post at its xy; a segment
(a ``gfa`` row: a guide-camera chip edge) a wall along it (:func:`wall_mesh`, link kind
``gfa``, the MuJoCo model's box: ``2 * fiducial_radius_mm`` thick, ``fiducial_radius_mm``
past each end, over the beta link's z range widened by :data:`WALL_Z_MARGIN_MM`). An
obstacle stands at the ``z_mm`` of the robot nearest to it (the layout has no obstacle
heights; 0 on flat layouts).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import fcl
import numpy as np
import trimesh
from scipy.spatial import ConvexHull

from rfp_twin.models.geometry import LINKS, RobotGeometry
from rfp_twin.models.layout.columns import (obstacle_arrays, robot_axes, robot_column,
                                            robot_frame_origins)
from rfp_twin.validation.mesh3d.bounds import ALPHA, BETA, pose
from rfp_twin.validation.numerics import POINT_EPS2, REACH_TOL_MM

#: Links of a robot / of a fiducial, and their kind codes (index into ``LINKS``).
ROBOT_LINKS = ("body", "alpha", "beta")
FIDUCIAL_LINKS = ("fiducial",)
ROBOT_KINDS = tuple(LINKS.index(k) for k in ROBOT_LINKS)
FIDUCIAL_KINDS = tuple(LINKS.index(k) for k in FIDUCIAL_LINKS)
#: Name of the link kind of a guide-camera wall (kinds after the four of ``LINKS``).
WALL = "gfa"
#: Height added below and above the beta link's z range for a wall, mm (the MuJoCo model's
#: estimate: a 2 deg tilt lifts or sinks a 24 mm arm's tip by 0.8 mm; the wok's height
#: changes along a chip edge).
WALL_Z_MARGIN_MM = 2.0


def fit_capsule(points_xy: np.ndarray, n_radii: int = 24) -> tuple[np.ndarray, float]:
    """A 2D capsule enclosing every point.

    The segment lies on the principal axis of the points; for candidate radii from the
    largest perpendicular offset upwards the shortest segment covering every point is
    found in closed form, and the capsule of smallest area is kept. The returned
    radius is re-measured (largest point-to-segment distance), so every point is
    inside, whatever rounding happened on the way.

    Parameters
    ----------
    points_xy : (k, 2) float, mm

    Returns
    -------
    segment : (2, 2) float64, mm (the two ends; equal for a disk)
    radius : float, mm
    """
    return _capsule_on_axis(points_xy, 2, n_radii,
                            lambda rad, length: 2.0 * rad * length + math.pi * rad * rad)


def _capsule_on_axis(points, dim: int, n_radii: int, size) -> tuple[np.ndarray, float]:
    """The capsule of :func:`fit_capsule` (``dim`` 2) or :func:`fit_capsule_3d` (``dim`` 3):
    segment on the points' principal axis, the candidate radius whose capsule has the
    smallest ``size(radius, segment length)`` (area or volume), radius re-measured."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, dim)
    c = p.mean(axis=0)
    q = p - c
    if len(p) >= 2 and np.ptp(q, axis=0).max() > 0:
        _, _, vt = np.linalg.svd(q, full_matrices=False)
        u = vt[0]
    else:
        u = np.eye(dim)[0]
    s = q @ u
    if dim == 2:
        w = np.abs(q @ np.array([-u[1], u[0]]))
    else:
        w = np.linalg.norm(q - s[:, None] * u, axis=1)
    r_min = float(w.max())
    r_max = max(r_min, float(np.hypot(s, w).max()))
    best = None
    for r in np.linspace(r_min, r_max, n_radii) if r_max > r_min else [r_min]:
        reach = np.sqrt(np.maximum(r * r - w * w, 0.0))
        s1 = float(np.max(s - reach))
        s0 = float(np.min(s + reach))
        if s0 > s1:
            s0 = s1 = 0.5 * (s0 + s1)
        seg = np.array([c + s0 * u, c + s1 * u])
        rad = float(_points_to_segment(p, seg[0], seg[1]).max())
        measure = size(rad, s1 - s0)
        if best is None or measure < best[0] - 1e-12:
            best = (measure, seg, rad)
    return best[1], best[2]


def _points_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    dd = float(d @ d)
    t = np.zeros(len(p)) if dd <= POINT_EPS2 else np.clip((p - a) @ d / dd, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)


def fit_capsule_3d(points: np.ndarray, n_radii: int = 24) -> tuple[np.ndarray, float]:
    """A 3D capsule (sphere-swept segment) enclosing every point: :func:`fit_capsule` in
    3D (segment on the principal axis, smallest volume over candidate radii, the radius
    re-measured). A convex piece whose vertices it encloses lies inside it.

    Parameters
    ----------
    points : (k, 3) float, mm

    Returns
    -------
    segment : (2, 3) float64, mm
    radius : float, mm
    """
    return _capsule_on_axis(points, 3, n_radii,
                            lambda rad, length: (math.pi * rad * rad * length
                                                 + 4.0 / 3.0 * math.pi * rad ** 3))


def _piece(piece, oz: float) -> dict:
    """Capsule, z interval (shifted by ``oz`` mm), largest xy radius, FCL model, hull
    half-spaces, probe vertex and xy hull of one convex piece."""
    v = np.asarray(piece.vertices, dtype=np.float64)
    seg, rad = fit_capsule(v[:, :2])
    seg3, rad3 = fit_capsule_3d(v)
    xy = v[:, :2]
    try:
        poly = xy[ConvexHull(xy).vertices]
    except Exception:  # noqa: BLE001 (degenerate projection: a segment)
        poly = xy[[int(np.argmin(xy @ (seg[1] - seg[0]))), int(np.argmax(xy @ (seg[1] - seg[0])))]]
    return {"cap": [seg[0, 0], seg[0, 1], seg[1, 0], seg[1, 1], rad,
                    seg3[0, 0], seg3[0, 1], seg3[0, 2] + oz, seg3[1, 0], seg3[1, 1],
                    seg3[1, 2] + oz, rad3],
            "zlim": [float(v[:, 2].min()) + oz, float(v[:, 2].max()) + oz],
            "rmax": max(float(np.hypot(v[:, 0], v[:, 1]).max()),
                        float(np.hypot(seg[:, 0], seg[:, 1]).max())),
            "bvh": _bvh(piece), "hull": _hull(piece),
            "eq": np.ascontiguousarray(ConvexHull(v).equations),
            "probe": v[0], "poly": poly}


def _piece_fields(pieces: list) -> dict:
    """The per-piece fields of :class:`LinkModels` from :func:`_piece` dicts."""
    polys = [pc["poly"] for pc in pieces]
    return {"cap": np.asarray([pc["cap"] for pc in pieces], dtype=np.float64),
            "zlim": np.asarray([pc["zlim"] for pc in pieces], dtype=np.float64),
            "bvh": [pc["bvh"] for pc in pieces], "hull": [pc["hull"] for pc in pieces],
            "hull_eq": [pc["eq"] for pc in pieces],
            "probe": np.asarray([pc["probe"] for pc in pieces], dtype=np.float64),
            "poly_ptr": np.concatenate([[0], np.cumsum([len(q) for q in polys])]).astype(np.int64),
            "poly_xy": np.ascontiguousarray(np.vstack(polys), dtype=np.float64)}


def _hull(mesh) -> fcl.Convex:
    """The piece as an FCL convex solid (GJK distances: fast, an upper bound)."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    flat = np.hstack([np.full((len(faces), 1), 3, dtype=np.int64), faces]).ravel()
    return fcl.Convex(np.ascontiguousarray(mesh.vertices, dtype=np.float64), len(faces), flat)


def _bvh(mesh) -> fcl.BVHModel:
    model = fcl.BVHModel()
    model.beginModel(len(mesh.vertices), len(mesh.faces))
    model.addSubModel(np.ascontiguousarray(mesh.vertices, dtype=np.float64),
                      np.ascontiguousarray(mesh.faces, dtype=np.int32))
    model.endModel()
    return model


@dataclass
class LinkModels:
    """Everything the 3D check needs about the links of one robot design.

    Built once per geometry (:meth:`from_geometry`); all robots share it. A check on a
    layout with guide-camera walls adds one link kind per wall (:meth:`with_walls`), so
    the per-kind arrays have K = 4 + walls rows.

    Attributes
    ----------
    geometry : RobotGeometry
    kind_ptr : (K + 1,) int64
        Pieces of link kind ``k`` (index into :attr:`kind_names`) are
        ``kind_ptr[k]:kind_ptr[k + 1]``.
    cap : (P, 12) float64
        Two capsules enclosing each piece, in its link frame (z in the robot frame, as
        :attr:`zlim`), mm: columns 0-4 the 2D capsule of its xy projection ``x0, y0, x1,
        y1, radius`` (:func:`fit_capsule`), columns 5-11 a 3D capsule ``x0, y0, z0, x1,
        y1, z1, radius`` (:func:`fit_capsule_3d`; tight for tilted pieces such as P1's
        rising tube, whose xy capsule times its z interval is not).
    zlim : (P, 2) float64
        z interval of each piece in the robot frame, mm.
    rad_alpha, rad_beta : (K,) float64
        Per link kind, the point speed is at most ``rad_alpha |a'| + rad_beta |b'|``
        (rad/s in, mm/s out).
    reach : (K,) float64
        Largest xy distance of a link point from the alpha axis over all angles, mm.
    zrange : (K, 2) float64
        z interval of each link kind in the robot frame, mm.
    offset_z : (K,) float64
        z of each link frame in the robot frame, mm.
    l_alpha : float
        Alpha axis to beta axis, mm.
    bvh : list of fcl.BVHModel, one per piece (link frame)
    hull : list of fcl.Convex, one per piece (link frame): the same vertices as a convex
        solid, for GJK distances (:meth:`ExactDistance.distance_frames` ``upper_above``)
    hull_eq : list of (m, 4) float64, per piece: ``n . x + d <= 0`` inside (link frame)
    probe : (P, 3) float64
        One vertex of each piece (link frame), for the containment test.
    poly_ptr : (P + 1,) int64; poly_xy : (V, 2) float64
        Convex hull of each piece's vertices projected on the link's xy plane (CCW),
        CSR: piece ``u`` is ``poly_xy[poly_ptr[u]:poly_ptr[u + 1]]``, mm.
    kind_names : tuple of K str
        :data:`rfp_twin.models.geometry.LINKS`, then :data:`WALL` per wall.
    """

    geometry: RobotGeometry
    kind_ptr: np.ndarray
    cap: np.ndarray
    zlim: np.ndarray
    rad_alpha: np.ndarray
    rad_beta: np.ndarray
    reach: np.ndarray
    zrange: np.ndarray
    offset_z: np.ndarray
    l_alpha: float
    bvh: list
    hull: list
    hull_eq: list
    probe: np.ndarray
    poly_ptr: np.ndarray
    poly_xy: np.ndarray
    kind_names: tuple = LINKS

    @classmethod
    def from_geometry(cls, geometry: RobotGeometry) -> LinkModels:
        """Capsules, speed radii and FCL models of every collision piece."""
        la = float(geometry.spec.alpha_length_mm)
        kind_ptr = [0]
        pieces_out = []
        rad_a, rad_b = np.zeros(4), np.zeros(4)
        reach, zr, offz = np.zeros(4), np.zeros((4, 2)), np.zeros(4)
        for k, name in enumerate(LINKS):
            oz = float(geometry.link_offset("alpha")[2]) if name == "alpha" else 0.0
            if name == "beta":
                oz = float(geometry.link_offset("alpha")[2] + geometry.link_offset("beta")[2])
            offz[k] = oz
            pieces = [_piece(piece, oz) for piece in geometry.links[name].collision]
            pieces_out += pieces
            rmax = max([pc["rmax"] for pc in pieces], default=0.0)
            zr[k] = (min([pc["zlim"][0] for pc in pieces], default=np.inf),
                     max([pc["zlim"][1] for pc in pieces], default=-np.inf))
            kind_ptr.append(kind_ptr[-1] + len(pieces))
            if name == "alpha":
                rad_a[k], reach[k] = rmax, rmax
            elif name == "beta":
                rad_a[k], rad_b[k], reach[k] = la + rmax, rmax, la + rmax
            else:
                reach[k] = rmax
        return cls(geometry=geometry, kind_ptr=np.asarray(kind_ptr, dtype=np.int64),
                   rad_alpha=rad_a, rad_beta=rad_b, reach=reach, zrange=zr, offset_z=offz,
                   l_alpha=la, **_piece_fields(pieces_out))

    def with_walls(self, meshes) -> LinkModels:
        """A copy with one more link kind (named :data:`WALL`) per wall mesh (one convex
        piece each, in its obstacle's frame: origin at the obstacle's base, z as the robot
        frames); ``self`` when there is none."""
        if not len(meshes):
            return self
        pieces = [_piece(m, 0.0) for m in meshes]
        n = len(pieces)
        old = [{"cap": self.cap[u], "zlim": self.zlim[u], "bvh": self.bvh[u], "hull": self.hull[u],
                "eq": self.hull_eq[u],
                "probe": self.probe[u], "poly": self.poly_xy[self.poly_ptr[u]:self.poly_ptr[u + 1]]}
               for u in range(len(self.cap))]
        return replace(
            self, kind_ptr=np.concatenate([self.kind_ptr, self.kind_ptr[-1] + 1 + np.arange(n)]),
            rad_alpha=np.concatenate([self.rad_alpha, np.zeros(n)]),
            rad_beta=np.concatenate([self.rad_beta, np.zeros(n)]),
            reach=np.concatenate([self.reach, [pc["rmax"] for pc in pieces]]),
            zrange=np.vstack([self.zrange, [pc["zlim"] for pc in pieces]]),
            offset_z=np.concatenate([self.offset_z, np.zeros(n)]),
            kind_names=tuple(self.kind_names) + (WALL,) * n, **_piece_fields(old + pieces))

    def n_pieces(self, kind: int) -> int:
        return int(self.kind_ptr[kind + 1] - self.kind_ptr[kind])

    @property
    def max_piece_pairs(self) -> int:
        """Most piece pairs two links can have (the width of a piece-pair bound row)."""
        return int(max(self.n_pieces(k) for k in range(len(self.kind_ptr) - 1)) ** 2)

    def can_touch(self, kind_a: int, kind_b: int, base_distance_mm: float,
                  min_gap_mm: float = 0.0) -> bool:
        """True when links of these kinds on bases this far apart can come within
        ``min_gap_mm`` for some angles (z intervals and reaches)."""
        za, zb = self.zrange[kind_a], self.zrange[kind_b]
        dz = max(0.0, za[0] - zb[1], zb[0] - za[1])
        return (dz <= min_gap_mm + REACH_TOL_MM and
                base_distance_mm <= self.reach[kind_a] + self.reach[kind_b] + min_gap_mm
                + REACH_TOL_MM)

    def link_pairs(self, kinds_a, kinds_b, base_distance_mm: float,
                   min_gap_mm: float = 0.0) -> list[tuple[int, int]]:
        """The ``(kind_a, kind_b)`` of ``kinds_a x kinds_b`` that :meth:`can_touch`."""
        return [(ka, kb) for ka in kinds_a for kb in kinds_b
                if self.can_touch(ka, kb, base_distance_mm, min_gap_mm)]


def link_pose(models: LinkModels, kind: int, base_xy, alpha_deg: float,
              beta_deg: float) -> np.ndarray:
    """Pose of a link frame in the world: ``(theta rad, x, y, z)`` mm.

    World point = ``(x, y, z) + Rz(theta) p`` for ``p`` in the link frame; the same
    transform as ``translate(base) @ RobotGeometry.link_transform(name, alpha, beta)``.
    """
    th, ox, oy = pose(kind, math.radians(alpha_deg), math.radians(beta_deg), models.l_alpha)
    return np.array([th, base_xy[0] + ox, base_xy[1] + oy, models.offset_z[kind]])


def axis_rotation(k) -> np.ndarray:
    """(3, 3) the smallest rotation taking +z to the unit vector ``k`` (3,) (Rodrigues
    about ``z x k``); the identity, exactly, for ``k = (0, 0, 1)``."""
    kx, ky, kz = (float(v) for v in k)
    if kx == 0.0 and ky == 0.0:
        return np.eye(3)
    vx = np.array([[0.0, 0.0, kx], [0.0, 0.0, ky], [-kx, -ky, 0.0]])   # [z x k]_x
    return np.eye(3) + vx + vx @ vx / (1.0 + kz)


@dataclass(frozen=True)
class Placement:
    """Each robot's and obstacle's own placement, layout order (mm).

    alpha_len : (n,) float64, alpha axis to beta axis
    base : (n, 3) float64, robot frame origin
        (:func:`rfp_twin.models.layout.columns.robot_frame_origins`: the layout's x, y and
        ``z_mm`` for an upright robot)
    rot : (n, 3, 3) float64, ``R_k`` (:func:`axis_rotation`); ``tilted`` (n,) bool where it
        is not the identity
    obs_a, obs_b : (m, 2) float64, obstacle ends (equal for a point)
    obs_z : (m,) float64, obstacle heights (the nearest robot's ``z_mm``)
    """

    alpha_len: np.ndarray
    base: np.ndarray
    rot: np.ndarray
    tilted: np.ndarray
    obs_a: np.ndarray
    obs_b: np.ndarray
    obs_z: np.ndarray

    @property
    def wall(self) -> np.ndarray:
        """(m,) bool, True for a segment obstacle (a wall)."""
        return np.any(self.obs_a != self.obs_b, axis=1)


def placement(layout, models: LinkModels) -> Placement | None:
    """:class:`Placement` of a layout's robots and obstacles; None when every robot is the
    nominal one (spec alpha arm, height 0, axis +z) and every obstacle a point at height 0.

    Raises
    ------
    LayoutError
        An axis ``(kx, ky, kz)`` that is not a unit vector (within
        :data:`rfp_twin.models.layout.columns.AXIS_TOL`).
    """
    la = robot_column(layout, "alpha_len_mm", models.l_alpha)
    z = robot_column(layout, "z_mm", 0.0)
    k = robot_axes(layout)
    rot = np.array([axis_rotation(k[r]) for r in range(len(k))]).reshape(-1, 3, 3)
    tilted = (k[:, 0] != 0.0) | (k[:, 1] != 0.0)
    a, b, _ = obstacle_arrays(models.geometry.spec, layout)
    oz = np.zeros(len(a))
    if len(a) and len(z) and np.any(z != 0.0):
        d2 = ((((a + b) / 2.0)[:, None, :] - layout.robot_xy[None]) ** 2).sum(axis=2)
        oz = z[np.argmin(d2, axis=1)]
    out = Placement(la, robot_frame_origins(layout, models.geometry.params.fiber_z_mm, k), rot,
                    tilted, a, b, oz)
    if np.all(la == models.l_alpha) and not tilted.any() and not z.any() and not oz.any() \
            and not out.wall.any():
        return None
    return out


def wall_mesh(a, b, half_width: float, z_range) -> trimesh.Trimesh:
    """The wall along segment ``a``-``b`` (2,) mm as a box mesh in its obstacle frame
    (origin at ``a``): ``2 half_width`` thick, ``half_width`` past each end, z over
    ``z_range`` (2,) mm."""
    d = np.asarray(b, dtype=np.float64) - np.asarray(a, dtype=np.float64)
    length = float(np.hypot(d[0], d[1]))
    yaw = math.atan2(d[1], d[0])
    c, s = math.cos(yaw), math.sin(yaw)
    tf = np.eye(4)
    tf[:2, :2] = [[c, -s], [s, c]]
    tf[:3, 3] = [d[0] / 2.0, d[1] / 2.0, (z_range[0] + z_range[1]) / 2.0]
    return trimesh.creation.box(extents=[length + 2.0 * half_width, 2.0 * half_width,
                                         z_range[1] - z_range[0]], transform=tf)


def link_frames(models: LinkModels, kinds, base, rot, l_alpha, alpha_rad,
                beta_rad) -> tuple[np.ndarray, np.ndarray]:
    """World transforms of links: rotation ``R_k Rz(theta)`` (n, 3, 3) and translation
    ``base + R_k (x, y, offset_z)`` (n, 3), mm, of link kinds ``kinds`` (n,) of objects with
    frame origins ``base`` (n, 3), axes ``rot`` (n, 3, 3), alpha arms ``l_alpha`` (n,) at
    joint angles ``alpha_rad``, ``beta_rad`` (n,) rad
    (:func:`rfp_twin.validation.mesh3d.bounds.pose`)."""
    kinds = np.asarray(kinds, dtype=np.int64).reshape(-1)
    a = np.asarray(alpha_rad, dtype=np.float64).reshape(-1)
    b = np.asarray(beta_rad, dtype=np.float64).reshape(-1)
    la = np.broadcast_to(np.asarray(l_alpha, dtype=np.float64), a.shape)
    th = np.where(kinds == ALPHA, a, np.where(kinds == BETA, a + b, 0.0))
    local = np.zeros((len(kinds), 3))
    beta = kinds == BETA
    local[beta, 0] = la[beta] * np.cos(a[beta])
    local[beta, 1] = la[beta] * np.sin(a[beta])
    local[:, 2] = models.offset_z[kinds]
    rz = np.zeros((len(kinds), 3, 3))
    c, s = np.cos(th), np.sin(th)
    rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = c, -s, s, c, 1.0
    rot = np.asarray(rot, dtype=np.float64).reshape(-1, 3, 3)
    return rot @ rz, np.asarray(base, dtype=np.float64).reshape(-1, 3) \
        + np.einsum("nij,nj->ni", rot, local)


def link_frame(models: LinkModels, kind: int, base_xyz, alpha_deg: float, beta_deg: float,
               l_alpha: float | None = None, rot=None) -> tuple[np.ndarray, np.ndarray]:
    """World transform ``(R (3, 3), t (3,))`` of one link (:func:`link_frames`): robot
    frame origin ``base_xyz`` (3,) mm, axis rotation ``rot`` (default none), alpha arm
    ``l_alpha`` mm (default the models')."""
    r, t = link_frames(models, [kind], base_xyz, np.eye(3) if rot is None else rot,
                       models.l_alpha if l_alpha is None else l_alpha,
                       math.radians(alpha_deg), math.radians(beta_deg))
    return r[0], t[0]
