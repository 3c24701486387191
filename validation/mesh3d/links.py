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
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import fcl
import numpy as np
from scipy.spatial import ConvexHull

from rfp_twin.models.geometry import LINKS, RobotGeometry
from rfp_twin.validation.mesh3d.bounds import pose
from rfp_twin.validation.numerics import POINT_EPS2, REACH_TOL_MM

#: Links of a robot / of a fiducial, and their kind codes (index into ``LINKS``).
ROBOT_LINKS = ("body", "alpha", "beta")
FIDUCIAL_LINKS = ("fiducial",)
ROBOT_KINDS = tuple(LINKS.index(k) for k in ROBOT_LINKS)
FIDUCIAL_KINDS = tuple(LINKS.index(k) for k in FIDUCIAL_LINKS)


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
    p = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    c = p.mean(axis=0)
    q = p - c
    if len(p) >= 2 and np.ptp(q, axis=0).max() > 0:
        _, _, vt = np.linalg.svd(q, full_matrices=False)
        u = vt[0]
    else:
        u = np.array([1.0, 0.0])
    nrm = np.array([-u[1], u[0]])
    s = q @ u
    w = np.abs(q @ nrm)
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
        area = 2.0 * rad * (s1 - s0) + math.pi * rad * rad
        if best is None or area < best[0] - 1e-12:
            best = (area, seg, rad)
    return best[1], best[2]


def _points_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    dd = float(d @ d)
    t = np.zeros(len(p)) if dd <= POINT_EPS2 else np.clip((p - a) @ d / dd, 0.0, 1.0)
    return np.hypot(*(p - (a + t[:, None] * d)).T)


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

    Built once per geometry (:meth:`from_geometry`); all robots share it.

    Attributes
    ----------
    geometry : RobotGeometry
    kind_ptr : (5,) int64
        Pieces of link kind ``k`` (index into :data:`rfp_twin.models.geometry.LINKS`) are
        ``kind_ptr[k]:kind_ptr[k + 1]``.
    cap : (P, 5) float64
        Capsule of each piece in its link frame: ``x0, y0, x1, y1, radius``, mm.
    zlim : (P, 2) float64
        z interval of each piece in the robot frame, mm.
    rad_alpha, rad_beta : (4,) float64
        Per link kind, the point speed is at most ``rad_alpha |a'| + rad_beta |b'|``
        (rad/s in, mm/s out).
    reach : (4,) float64
        Largest xy distance of a link point from the alpha axis over all angles, mm.
    zrange : (4, 2) float64
        z interval of each link kind in the robot frame, mm.
    offset_z : (4,) float64
        z of each link frame in the robot frame, mm.
    l_alpha : float
        Alpha axis to beta axis, mm.
    bvh : list of fcl.BVHModel, one per piece (link frame)
    hull_eq : list of (m, 4) float64, per piece: ``n . x + d <= 0`` inside (link frame)
    probe : (P, 3) float64
        One vertex of each piece (link frame), for the containment test.
    poly_ptr : (P + 1,) int64; poly_xy : (K, 2) float64
        Convex hull of each piece's vertices projected on the link's xy plane (CCW),
        CSR: piece ``u`` is ``poly_xy[poly_ptr[u]:poly_ptr[u + 1]]``, mm.
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
    hull_eq: list
    probe: np.ndarray
    poly_ptr: np.ndarray
    poly_xy: np.ndarray

    @classmethod
    def from_geometry(cls, geometry: RobotGeometry) -> LinkModels:
        """Capsules, speed radii and FCL models of every collision piece."""
        la = float(geometry.spec.alpha_length_mm)
        kind_ptr = [0]
        caps, zlims, bvhs, eqs, probes, polys = [], [], [], [], [], []
        rad_a, rad_b = np.zeros(4), np.zeros(4)
        reach, zr, offz = np.zeros(4), np.zeros((4, 2)), np.zeros(4)
        for k, name in enumerate(LINKS):
            oz = float(geometry.link_offset("alpha")[2]) if name == "alpha" else 0.0
            if name == "beta":
                oz = float(geometry.link_offset("alpha")[2] + geometry.link_offset("beta")[2])
            offz[k] = oz
            pieces = geometry.links[name].collision
            rmax = 0.0
            zlo, zhi = np.inf, -np.inf
            for piece in pieces:
                v = np.asarray(piece.vertices, dtype=np.float64)
                seg, rad = fit_capsule(v[:, :2])
                caps.append([seg[0, 0], seg[0, 1], seg[1, 0], seg[1, 1], rad])
                z0, z1 = float(v[:, 2].min()) + oz, float(v[:, 2].max()) + oz
                zlims.append([z0, z1])
                zlo, zhi = min(zlo, z0), max(zhi, z1)
                rmax = max(rmax, float(np.hypot(v[:, 0], v[:, 1]).max()),
                           float(np.hypot(seg[:, 0], seg[:, 1]).max()))
                bvhs.append(_bvh(piece))
                eqs.append(np.ascontiguousarray(ConvexHull(v).equations))
                probes.append(v[0])
                xy = v[:, :2]
                try:
                    polys.append(xy[ConvexHull(xy).vertices])
                except Exception:  # noqa: BLE001 (degenerate projection: a segment)
                    polys.append(xy[[int(np.argmin(xy @ (seg[1] - seg[0]))),
                                     int(np.argmax(xy @ (seg[1] - seg[0])))]])
            kind_ptr.append(kind_ptr[-1] + len(pieces))
            zr[k] = (zlo, zhi)
            if name == "alpha":
                rad_a[k], reach[k] = rmax, rmax
            elif name == "beta":
                rad_a[k], rad_b[k], reach[k] = la + rmax, rmax, la + rmax
            else:
                reach[k] = rmax
        return cls(geometry=geometry, kind_ptr=np.asarray(kind_ptr, dtype=np.int64),
                   cap=np.asarray(caps, dtype=np.float64), zlim=np.asarray(zlims, dtype=np.float64),
                   rad_alpha=rad_a, rad_beta=rad_b, reach=reach, zrange=zr, offset_z=offz,
                   l_alpha=la, bvh=bvhs, hull_eq=eqs, probe=np.asarray(probes, dtype=np.float64),
                   poly_ptr=np.concatenate([[0], np.cumsum([len(q) for q in polys])])
                   .astype(np.int64),
                   poly_xy=np.ascontiguousarray(np.vstack(polys), dtype=np.float64))

    def n_pieces(self, kind: int) -> int:
        return int(self.kind_ptr[kind + 1] - self.kind_ptr[kind])

    @property
    def max_piece_pairs(self) -> int:
        """Most piece pairs two links can have (the width of a piece-pair bound row)."""
        return int(max(self.n_pieces(k) for k in range(len(LINKS))) ** 2)

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
