"""3D validation of a :class:`models.trajectory.Trajectory` against the robot meshes (FCL).

FCL sees exactly the meshes MuJoCo collides: the convex collision pieces of every link
of :class:`models.geometry.RobotGeometry` (``Link.collision``, the pieces
:mod:`models.mjcf` turns into collision geoms). Each piece becomes one FCL
``BVHModel`` (OBBRSS), built once per link *kind* (``body``, ``alpha``, ``beta``,
``fiducial``): every robot shares them, only transforms differ. A robot is the links
``body``, ``alpha`` and ``beta``; a fiducial the link ``fiducial``. (The MuJoCo model
gives the fixed body no collision geom; here it is checked too, which can only add
findings: with the procedural meshes it never comes near anything.)

What is reported (:class:`Check3DReport`)
-----------------------------------------
* For every *pair* that can touch (robot-robot, robot-fiducial: some link of one can
  come within ``min_gap_mm`` of some link of the other for some joint angles), the
  smallest 3D distance over the whole motion (the smallest exact FCL distance sampled,
  an upper bound of the true minimum, within ``distance_tol_mm + distance_rel_tol *
  clearance`` of it), its time and the two links.
* Every 3D collision: time interval, robots / fiducial, links, as
  :class:`Collision3D`. A "collision" is a distance ``<= min_gap_mm`` (default 0:
  contact). Solid overlap counts even when no surfaces cross (a piece inside another):
  the distance used is the *solid* distance (see ``_Exact``).

Candidate pairs
---------------
Per link kind, from the meshes: the z interval (robot frame; rotations about z keep it)
and the reach, the largest xy distance of any point from the alpha axis over all joint
angles (``l_alpha + max |p|`` for the beta link). Links ``A`` of object ``i`` and ``B``
of object ``j`` (``i != j``) can touch only if their z intervals come within
``min_gap_mm`` and ``|b_i - b_j| <= reach_A + reach_B + min_gap_mm``. A robot's own
links are never paired (they are joined by the joints).

Lower bound ``C`` (the broadphase)
----------------------------------
Every convex piece is enclosed twice, in the frame of its link:

* a vertical *capsule prism*: a 2D capsule (segment + radius, fitted to the piece's
  vertices so that every vertex is inside; a capsule is convex, so the whole piece is)
  times the piece's z interval;
* a vertical *hull prism*: the convex hull of the piece's vertices projected on the
  xy plane, times the same z interval. It contains the piece; for the procedural
  pieces (prisms and cylinders) it *is* the piece.

The distance of two product sets ``P x [z]`` and ``Q x [z']`` is exactly
``sqrt(d_xy^2 + d_z^2)`` (``d_xy`` the 2D distance, ``d_z`` the gap of the z
intervals). For capsules ``d_xy = max(0, seg_dist - r_u - r_v)`` (~0.05 us in numba;
when ``d_z = 0`` the signed value is kept); for hulls ``d_xy`` comes from a 2D GJK on
the two polygons, of which every iterate gives a valid lower bound ``v . w / |v|``
(~1 us). The hull value is computed only where the capsule value is within
``_TIGHT_MM`` of what would settle the question. ``C(t)``, the minimum over the piece
pairs of two links, is a lower bound of their true distance ``D(t)`` (on the
procedural SDSS-V meshes equal to it to 1e-12 mm), against ~100-300 us for one FCL BVH
distance on this machine: FCL is called only where ``C`` cannot decide.

Why no collision can slip between samples
-----------------------------------------
*Speed bound.* A point ``p`` of the beta link (beta frame, ``|p| <= r_b``) sits at
``b + l_alpha e(a) + R(a + b) p``; its speed is at most ``|a'| (l_alpha + r_b) +
|b'| r_b``. A point of the alpha link moves at most ``|a'| r_a``; body and fiducial
do not move. ``r_a``, ``r_b`` are the largest distances of the link's mesh vertices
(and of its capsule segment ends) from the joint axis; for a convex piece the largest
distance is reached at a vertex, so the bound holds for every material point. The
trajectory is piecewise linear, so on a window ``|a'|``, ``|b'|`` are at most the
largest breakpoint slope overlapping the window (:func:`_local_rate`; zero outside the
robot's time range). Jumps (two breakpoints at one time with different angles) have no
bound and are refused (:class:`models.errors.TrajectoryError`).

*Lipschitz distance.* With ``V_A``, ``V_B`` those bounds, the distance between two
moving point sets changes at most at ``L = V_A + V_B``: ``|D(t) - D(t')| <= L |t -
t'|``. This holds for the exact distance ``D`` (any two sets) and for the bound ``C`` (capsule
segments and hull vertices move like link points, radii and z intervals are constant,
``sqrt(max(x, 0)^2 + dz^2)`` is 1-Lipschitz in ``x``, and max / min of Lipschitz
functions are Lipschitz with the same constant).

*Interval bound.* On ``[t0, t1]`` (``h = t1 - t0``) with samples ``F0``, ``F1`` of
``F = D`` or ``F = C`` (or any lower bounds of them, e.g. a capsule value where the
hull value was not computed): ``F(t) >= (F0 + F1 - L h) / 2 =: lb``. Since ``D >= C``,
``D(t) >= max(lb_D, lb_C)`` on the interval. An interval is *cleared* (no collision
inside) when that bound is ``> min_gap_mm``. Every part of ``[T0, T1]`` is either
cleared by this bound, or bisected until it is, or reported: as a collision when a
sample is ``<= min_gap_mm``, or (``conservative = True``) when an interval no longer
than ``resolution_s`` still cannot be cleared. No instant is left unexamined, so a
contact, however brief, is either found or covered by a conservative report.

*Solid overlap.* FCL's BVH distance measures surfaces: a piece wholly inside another
has a positive surface distance. Whenever the capsule bound of a piece pair is ``<= 0``
(their enclosing prisms overlap, the only case in which one can contain the other) and
FCL says ``> 0``, one vertex of each piece is tested against the other's convex hull
(half-spaces); containment gives distance 0. So the sampled ``D`` is the solid
distance, which the Lipschitz argument above also covers.

Algorithm
---------
1. *Lower-bound minimum* (numba, every candidate link pair): ``C`` on a uniform grid
   (spacing such that the pair's mean speed moves ``coarse_mm``), then bisection while
   the interval bound can be below the pair's smallest sample minus the tolerance:
   ``Cmin``, its time, and a *certificate* ``cert``: the smallest interval bound of
   the leaves, so ``C(t) >= cert`` on the whole span (``-inf`` if a leaf hit
   ``resolution_s`` first).
2. *Seed* (FCL): per pair (robot-robot or robot-fiducial), exact ``D`` at the time of
   ``Cmin`` of its link pairs, in increasing ``Cmin``, while ``Cmin`` is below the
   pair's best ``D`` so far minus the tolerance. ``best`` = the pair's smallest ``D``.
3. *Suspect intervals* (numba), only for link pairs whose certificate does not already
   exceed both ``min_gap_mm`` and ``cut = best - tol`` (on the SDSS-V meshes: none in a
   collision-free fold): bisection of ``C`` again, keeping what the bound cannot clear;
   emitted intervals are short enough (``L h <= 2 tol``) that exact values at their ends
   usually settle them.
4. *Exact* (FCL): ``D`` at the ends of every suspect interval (batched), then any
   interval still not cleared is bisected with exact values down to ``resolution_s``
   (collision start / end, conservative reports, and the pair minimum). FCL gives no
   penetration depth (``D = 0`` inside a collision), so an interval whose two ends
   collide is reported as colliding throughout: a collision's ``[t_start, t_end]`` may
   contain a brief separation, never a missed contact.

Colliding samples and colliding intervals of one link pair at most ``resolution_s``
apart are merged into one :class:`Collision3D` (start / end accurate to
``resolution_s``). The report splits wall time into *broadphase* (candidate pairs,
lower bounds: steps 1 and 3) and *exact* (FCL calls and their bookkeeping: 2 and 4).

Robots of the layout that the trajectory does not list are not checked. Units: mm,
degrees, seconds at the public boundary (radians inside the kernels).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Optional

import fcl
import numpy as np
from numba import njit
from scipy.spatial import ConvexHull, cKDTree

from models.errors import SpecError, TrajectoryError, field_error
from models.geometry import LINKS, RobotGeometry, geometry_for_spec
from models.layout import Layout
from models.robot import RobotSpec
from models.trajectory import AXES, Trajectory

__all__ = [
    "RobotPair",
    "Check3DReport",
    "Collision3D",
    "LinkModels",
    "PairDistance",
    "validate_trajectory",
    "fit_capsule",
    "link_pose",
]

#: Link kind codes used inside the kernels (index into :data:`models.geometry.LINKS`).
BODY, ALPHA, BETA, FIDUCIAL = (LINKS.index(n) for n in ("body", "alpha", "beta", "fiducial"))
#: Links of a robot / of a fiducial.
ROBOT_LINKS = ("body", "alpha", "beta")
FIDUCIAL_LINKS = ("fiducial",)
#: Squared length (mm^2) below which a segment is a point.
_POINT_EPS2 = 1e-24
#: Tolerance added to reaches and z gaps so that touching counts, mm.
_REACH_TOL_MM = 1e-9
#: Depth of the bisection stack.
_STACK = 256
#: Upper bound on coarse intervals per link pair.
_MAX_COARSE = 1_000_000
#: Samples whose capsule bound is within this of the current cut also get the (slower,
#: tighter) hull-prism bound, mm.
_TIGHT_MM = 1.0
#: Slack (mm) under which a containment test is run (capsule bound <= this).
_CONTAIN_SLACK = 1e-9


# =====================================================================================
# Reports
# =====================================================================================
@dataclass
class Collision3D:
    """One contiguous time interval in which two links are within ``min_gap_mm``.

    Attributes
    ----------
    kind : str
        ``"robot"`` (robot-robot) or ``"fiducial"`` (robot-fiducial).
    robot_a : int
        Robot id.
    link_a : str
        Link of ``robot_a`` (``body``, ``alpha``, ``beta``).
    other : int
        The other robot's id, or the fiducial id.
    link_b : str
        Link of ``other`` (``fiducial`` for a fiducial).
    t_start, t_end : float
        First and last colliding sample (or the ends of a conservative interval), s.
    t_min : float
        Time of the smallest distance found, s.
    min_distance_mm : float
        Smallest 3D distance found, mm (0 = touching or overlapping; for a
        conservative report the lower bound ``max(lb, 0)``).
    conservative : bool
        True when no sample collided but an interval of length ``<= resolution_s``
        could not be cleared (a grazing contact reported to be safe).
    """

    kind: str
    robot_a: int
    link_a: str
    other: int
    link_b: str
    t_start: float
    t_end: float
    t_min: float
    min_distance_mm: float
    conservative: bool = False

    def to_dict(self) -> dict:
        return {"kind": self.kind, "robot_a": int(self.robot_a), "link_a": self.link_a,
                "other": int(self.other), "link_b": self.link_b,
                "t_start": float(self.t_start), "t_end": float(self.t_end),
                "t_min": float(self.t_min), "min_distance_mm": float(self.min_distance_mm),
                "conservative": bool(self.conservative)}


@dataclass
class PairDistance:
    """Smallest 3D distance of one pair over the motion (one row of the report).

    ``kind`` ``"robot"`` / ``"fiducial"``; ``ids`` (robot id, other id); ``links`` the
    two links where it was found; ``min_distance_mm`` (mm) at ``t_min`` (s).
    """

    kind: str
    ids: tuple[int, int]
    links: tuple[str, str]
    min_distance_mm: float
    t_min: float

    def to_dict(self) -> dict:
        return {"kind": self.kind, "ids": [int(self.ids[0]), int(self.ids[1])],
                "links": list(self.links), "min_distance_mm": _num(self.min_distance_mm),
                "t_min": _num(self.t_min)}


def _num(x: float):
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass
class Check3DReport:
    """Result of :func:`validate_trajectory`.

    Attributes
    ----------
    min_gap_mm : float
        Distance at or below which two links count as colliding, mm.
    geometry : str
        Where the meshes came from (preset / TOML file, or "procedural").
    n_robots, n_fiducials : int
        Robots in the trajectory; fiducials of the layout.
    n_pairs, n_link_pairs : int
        Candidate pairs (robot-robot + robot-fiducial) and link pairs checked.
    duration_s : float
        Length of the checked span ``[T0, T1]``, s.
    pairs : list of PairDistance
        Per pair, its smallest 3D distance (sorted by distance).
    min_distance_mm : float
        Smallest 3D distance over all pairs, mm (``inf`` with no pair).
    link_kind_min_mm : dict
        Per link-kind pair (e.g. ``"beta-beta"``), the smallest exact distance
        evaluated, mm. A kind whose link pairs were never the closest of their robot
        pair may be evaluated little or not at all (``inf``); see the lower bound.
    link_kind_lower_bound_mm : dict
        Per link-kind pair, the smallest capsule bound over the motion (a lower
        bound of its true smallest distance, within the tolerance), mm.
    collisions : list of Collision3D
        Sorted by ``t_start``.
    n_capsule_evals, n_exact_evals, n_fcl_calls : int
        Capsule-bound evaluations (link pair x time), exact link-pair distances, and
        FCL distance calls (piece pairs) made.
    seconds_broadphase, seconds_exact, seconds : float
        Wall time of candidate selection + capsule bounds, of FCL work, and in all
        (includes numba compilation / cache loading on a first call), s.
    """

    min_gap_mm: float
    geometry: str
    n_robots: int
    n_fiducials: int
    n_pairs: int
    n_link_pairs: int
    duration_s: float
    pairs: list[PairDistance]
    min_distance_mm: float
    link_kind_min_mm: dict
    link_kind_lower_bound_mm: dict = field(default_factory=dict)
    collisions: list[Collision3D] = field(default_factory=list)
    n_capsule_evals: int = 0
    n_exact_evals: int = 0
    n_fcl_calls: int = 0
    seconds_broadphase: float = 0.0
    seconds_exact: float = 0.0
    seconds: float = 0.0
    settings: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when no 3D collision was found."""
        return not self.collisions

    @property
    def min_clearance_mm(self) -> float:
        """``min_distance_mm - min_gap_mm`` (``> 0`` means clear)."""
        return self.min_distance_mm - self.min_gap_mm

    def to_dict(self) -> dict:
        """JSON-serialisable form (``inf`` becomes ``None``)."""
        return {
            "ok": self.ok,
            "min_gap_mm": float(self.min_gap_mm),
            "geometry": self.geometry,
            "n_robots": int(self.n_robots),
            "n_fiducials": int(self.n_fiducials),
            "n_pairs": int(self.n_pairs),
            "n_link_pairs": int(self.n_link_pairs),
            "duration_s": float(self.duration_s),
            "min_distance_mm": _num(self.min_distance_mm),
            "min_clearance_mm": _num(self.min_clearance_mm),
            "link_kind_min_mm": {k: _num(v) for k, v in self.link_kind_min_mm.items()},
            "link_kind_lower_bound_mm": {k: _num(v) for k, v in
                                         self.link_kind_lower_bound_mm.items()},
            "n_collisions": len(self.collisions),
            "collisions": [c.to_dict() for c in self.collisions],
            "n_capsule_evals": int(self.n_capsule_evals),
            "n_exact_evals": int(self.n_exact_evals),
            "n_fcl_calls": int(self.n_fcl_calls),
            "seconds_broadphase": float(self.seconds_broadphase),
            "seconds_exact": float(self.seconds_exact),
            "seconds": float(self.seconds),
            "settings": dict(self.settings),
            "pairs": [p.to_dict() for p in self.pairs],
        }

    def table(self) -> str:
        """A short plain-text summary for the terminal."""
        md = "-" if not math.isfinite(self.min_distance_mm) else f"{self.min_distance_mm:.4f}"
        kinds = ", ".join(f"{k} {v:.3f}" for k, v in sorted(self.link_kind_min_mm.items())
                          if math.isfinite(v))
        lines = [
            f"3D check (FCL): {'OK' if self.ok else 'COLLISION'}  {self.n_robots} robots, "
            f"{self.n_fiducials} fiducials, {self.n_pairs} pairs ({self.n_link_pairs} link "
            f"pairs), {self.duration_s:.3f} s, min distance {md} mm (gap {self.min_gap_mm} mm)",
            f"  per link pair (mm): {kinds or '-'}",
            f"  {self.n_capsule_evals} capsule bounds, {self.n_exact_evals} exact distances "
            f"({self.n_fcl_calls} FCL calls); broadphase {self.seconds_broadphase:.3f} s, "
            f"exact {self.seconds_exact:.3f} s, total {self.seconds:.3f} s",
        ]
        if self.collisions:
            lines.append(f"{'kind':<9}{'robot':>7}{'link':>7}{'other':>7}{'link':>9}"
                         f"{'t_start':>11}{'t_end':>11}{'t_min':>11}{'min mm':>9}")
            for c in self.collisions:
                lines.append(f"{c.kind:<9}{c.robot_a:>7}{c.link_a:>7}{c.other:>7}{c.link_b:>9}"
                             f"{c.t_start:>11.5f}{c.t_end:>11.5f}{c.t_min:>11.5f}"
                             f"{c.min_distance_mm:>9.4f}" + ("  (bound)" if c.conservative else ""))
        return "\n".join(lines)


# =====================================================================================
# Link models: capsules, speed radii, FCL BVH per convex piece
# =====================================================================================
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
    t = np.zeros(len(p)) if dd <= _POINT_EPS2 else np.clip((p - a) @ d / dd, 0.0, 1.0)
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
        Pieces of link kind ``k`` (index into :data:`models.geometry.LINKS`) are
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

    def can_touch(self, kind_a: int, kind_b: int, base_distance_mm: float,
                  min_gap_mm: float = 0.0) -> bool:
        """True when links of these kinds on bases this far apart can come within
        ``min_gap_mm`` for some angles (z intervals and reaches)."""
        za, zb = self.zrange[kind_a], self.zrange[kind_b]
        dz = max(0.0, za[0] - zb[1], zb[0] - za[1])
        return (dz <= min_gap_mm + _REACH_TOL_MM and
                base_distance_mm <= self.reach[kind_a] + self.reach[kind_b] + min_gap_mm
                + _REACH_TOL_MM)


def link_pose(models: LinkModels, kind: int, base_xy, alpha_deg: float,
              beta_deg: float) -> np.ndarray:
    """Pose of a link frame in the world: ``(theta rad, x, y, z)`` mm.

    World point = ``(x, y, z) + Rz(theta) p`` for ``p`` in the link frame; the same
    transform as ``translate(base) @ RobotGeometry.link_transform(name, alpha, beta)``.
    """
    th, ox, oy = _pose(kind, math.radians(alpha_deg), math.radians(beta_deg), models.l_alpha)
    return np.array([th, base_xy[0] + ox, base_xy[1] + oy, models.offset_z[kind]])


# =====================================================================================
# numba kernels
# =====================================================================================
@njit(cache=True)
def _pose(kind, a, b, la):
    """(theta, ox, oy): link frame rotation and xy offset from the base (rad, mm)."""
    if kind == 1:      # alpha
        return a, 0.0, 0.0
    if kind == 2:      # beta
        return a + b, la * math.cos(a), la * math.sin(a)
    return 0.0, 0.0, 0.0


@njit(cache=True)
def _clamp01(x):
    if x < 0.0:
        return 0.0
    if x > 1.0:
        return 1.0
    return x


@njit(cache=True)
def _seg_dist(p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y):
    """Distance between 2D segments (closest points by clamped line parameters)."""
    ux = p1x - p0x
    uy = p1y - p0y
    vx = q1x - q0x
    vy = q1y - q0y
    wx = p0x - q0x
    wy = p0y - q0y
    a = ux * ux + uy * uy
    e = vx * vx + vy * vy
    f = vx * wx + vy * wy
    if a <= _POINT_EPS2:
        s = 0.0
        t = _clamp01(f / e) if e > _POINT_EPS2 else 0.0
    else:
        c = ux * wx + uy * wy
        if e <= _POINT_EPS2:
            t = 0.0
            s = _clamp01(-c / a)
        else:
            b = ux * vx + uy * vy
            den = a * e - b * b
            s = _clamp01((b * f - c * e) / den) if den > 1e-12 * a * e else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = _clamp01(-c / a)
            elif t > 1.0:
                t = 1.0
                s = _clamp01((b - c) / a)
    dx = wx + ux * s - vx * t
    dy = wy + uy * s - vy * t
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True)
def _support(pxy, k0, k1, c, s, ox, oy, dx, dy):
    """Vertex of polygon pxy[k0:k1] (posed: rotation (c, s), offset (ox, oy)) furthest
    along world direction (dx, dy); returns its world coordinates."""
    lx = c * dx + s * dy            # direction in the link frame
    ly = -s * dx + c * dy
    best = -np.inf
    kb = k0
    for k in range(k0, k1):
        d = pxy[k, 0] * lx + pxy[k, 1] * ly
        if d > best:
            best = d
            kb = k
    return ox + c * pxy[kb, 0] - s * pxy[kb, 1], oy + s * pxy[kb, 0] + c * pxy[kb, 1]


@njit(cache=True)
def _poly_lb(u, v, ca, sa, xa, ya, cb, sb, xb, yb, pptr, pxy):
    """Lower bound of the distance of two posed convex polygons (2D GJK).

    Iterates GJK on the Minkowski difference ``A - B``; at every iteration ``v . w /
    |v|`` (``v`` the current closest point, ``w`` the support point in direction
    ``-v``) bounds the distance from below, whatever the convergence, so the result
    is always a valid lower bound (exact when GJK converges). 0 when they overlap.
    """
    a0, a1, b0, b1 = pptr[u], pptr[u + 1], pptr[v], pptr[v + 1]
    ax, ay = _support(pxy, a0, a1, ca, sa, xa, ya, 1.0, 0.0)
    bx, by = _support(pxy, b0, b1, cb, sb, xb, yb, -1.0, 0.0)
    s0x = ax - bx
    s0y = ay - by
    s1x = 0.0
    s1y = 0.0
    ns = 1
    vx = s0x
    vy = s0y
    lb = 0.0
    for _ in range(64):
        vv = vx * vx + vy * vy
        if vv <= 1e-24:
            return 0.0
        ax, ay = _support(pxy, a0, a1, ca, sa, xa, ya, -vx, -vy)
        bx, by = _support(pxy, b0, b1, cb, sb, xb, yb, vx, vy)
        wx = ax - bx
        wy = ay - by
        vw = vx * wx + vy * wy
        nv = math.sqrt(vv)
        if vw / nv > lb:
            lb = vw / nv
        if vv - vw <= 1e-12 * vv + 1e-18:
            break
        if ns == 1:
            # segment [s0, w]
            ex = wx - s0x
            ey = wy - s0y
            ee = ex * ex + ey * ey
            t = _clamp01(-(s0x * ex + s0y * ey) / ee) if ee > 0.0 else 0.0
            if t <= 0.0:
                vx, vy = s0x, s0y
            elif t >= 1.0:
                s0x, s0y = wx, wy
                vx, vy = wx, wy
            else:
                s1x, s1y = wx, wy
                ns = 2
                vx = s0x + t * ex
                vy = s0y + t * ey
        else:
            # triangle (s0, s1, w): origin inside -> overlap
            c1 = (s1x - s0x) * (wy - s0y) - (s1y - s0y) * (wx - s0x)
            d0 = (s1x - s0x) * (-s0y) - (s1y - s0y) * (-s0x)
            d1 = (wx - s1x) * (-s1y) - (wy - s1y) * (-s1x)
            d2 = (s0x - wx) * (-wy) - (s0y - wy) * (-wx)
            if c1 != 0.0 and d0 * c1 >= 0.0 and d1 * c1 >= 0.0 and d2 * c1 >= 0.0:
                return 0.0
            # keep the closest of the edges (s0, w) and (s1, w) (w is new, so in the edge)
            best = np.inf
            keep_x = 0.0
            keep_y = 0.0
            for e in range(2):
                px = s0x if e == 0 else s1x
                py = s0y if e == 0 else s1y
                ex = wx - px
                ey = wy - py
                ee = ex * ex + ey * ey
                t = _clamp01(-(px * ex + py * ey) / ee) if ee > 0.0 else 0.0
                cx = px + t * ex
                cy = py + t * ey
                dd = cx * cx + cy * cy
                if dd < best:
                    best = dd
                    keep_x, keep_y = px, py
                    vx, vy = cx, cy
            s0x, s0y = keep_x, keep_y
            s1x, s1y = wx, wy
    return max(lb, 0.0)


@njit(cache=True)
def _piece_bound(u, v, tha, xa, ya, thb, xb, yb, cap, zlim, pptr, pxy, tight_below):
    """Lower bound of the distance of pieces u (pose a) and v (pose b), mm.

    Capsule prisms first; where that is below ``tight_below`` the vertical prisms of
    the pieces' xy hulls (GJK lower bound) too, keeping the larger. Both are lower
    bounds of the true distance and Lipschitz in time with the link speed bounds.
    """
    ca = math.cos(tha)
    sa = math.sin(tha)
    cb = math.cos(thb)
    sb = math.sin(thb)
    a0x = xa + ca * cap[u, 0] - sa * cap[u, 1]
    a0y = ya + sa * cap[u, 0] + ca * cap[u, 1]
    a1x = xa + ca * cap[u, 2] - sa * cap[u, 3]
    a1y = ya + sa * cap[u, 2] + ca * cap[u, 3]
    b0x = xb + cb * cap[v, 0] - sb * cap[v, 1]
    b0y = yb + sb * cap[v, 0] + cb * cap[v, 1]
    b1x = xb + cb * cap[v, 2] - sb * cap[v, 3]
    b1y = yb + sb * cap[v, 2] + cb * cap[v, 3]
    dxy = _seg_dist(a0x, a0y, a1x, a1y, b0x, b0y, b1x, b1y) - cap[u, 4] - cap[v, 4]
    dz = max(0.0, zlim[u, 0] - zlim[v, 1], zlim[v, 0] - zlim[u, 1])
    if dz > 0.0:
        x = max(dxy, 0.0)
        out = math.sqrt(x * x + dz * dz)
    else:
        out = dxy
    if out < tight_below:
        lp = _poly_lb(u, v, ca, sa, xa, ya, cb, sb, xb, yb, pptr, pxy)
        f = math.sqrt(lp * lp + dz * dz) if dz > 0.0 else lp
        if f > out:
            out = f
    return out


@njit(cache=True)
def _interp(ptr, tt, aa, i, t):
    """Angle (rad) of robot i's axis at time t (held before / after its breakpoints)."""
    lo = ptr[i]
    hi = ptr[i + 1]
    if t <= tt[lo]:
        return aa[lo]
    if t >= tt[hi - 1]:
        return aa[hi - 1]
    k = lo + np.searchsorted(tt[lo:hi], t, side="right") - 1
    dt = tt[k + 1] - tt[k]
    if dt <= 0.0:
        return aa[k + 1]
    return aa[k] + (aa[k + 1] - aa[k]) * (t - tt[k]) / dt


@njit(cache=True)
def _local_rate(ptr, tt, rate, i, a, b):
    """Largest |slope| (rad/s) of robot i's breakpoint segments overlapping [a, b]."""
    lo = ptr[i]
    hi = ptr[i + 1]
    if hi - lo < 2:
        return 0.0
    k0 = lo + np.searchsorted(tt[lo:hi], a, side="right") - 1
    if k0 < lo:
        k0 = lo
    k1 = lo + np.searchsorted(tt[lo:hi], b, side="left")
    if k1 > hi - 1:
        k1 = hi - 1
    m = 0.0
    for k in range(k0, k1):
        if rate[k] > m:
            m = rate[k]
    return m


@njit(cache=True)
def _link_state(o, kind, t, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb, tb, ab):
    r = obj_rob[o]
    a = 0.0
    b = 0.0
    if r >= 0:
        a = _interp(pa, ta, aa, r, t)
        b = _interp(pb, tb, ab, r, t)
    th, ox, oy = _pose(kind, a, b, la)
    return th, obj_x[o] + ox, obj_y[o] + oy


@njit(cache=True)
def _bound_at(p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
              pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight_below):
    """Lower bound C of the distance of link pair p at time t, mm (min over piece
    pairs of :func:`_piece_bound`)."""
    ka = lp_ka[p]
    kb = lp_kb[p]
    tha, xa, ya = _link_state(lp_oa[p], ka, t, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb, tb, ab)
    thb, xb, yb = _link_state(lp_ob[p], kb, t, obj_rob, obj_x, obj_y, la, pa, ta, aa, pb, tb, ab)
    best = np.inf
    for u in range(kptr[ka], kptr[ka + 1]):
        for v in range(kptr[kb], kptr[kb + 1]):
            d = _piece_bound(u, v, tha, xa, ya, thb, xb, yb, cap, zlim, pptr, pxy,
                             tight_below)
            if d < best:
                best = d
    return best


@njit(cache=True)
def _link_speed(o, kind, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b):
    """Point-speed bound (mm/s) of a link of object o on the window [a, b]."""
    r = obj_rob[o]
    if r < 0 or (rad_a[kind] == 0.0 and rad_b[kind] == 0.0):
        return 0.0
    v = 0.0
    if rad_a[kind] > 0.0:
        v += rad_a[kind] * _local_rate(pa, ta, ra, r, a, b)
    if rad_b[kind] > 0.0:
        v += rad_b[kind] * _local_rate(pb, tb, rb, r, a, b)
    return v


@njit(cache=True)
def _n_coarse(span, speed, coarse_mm, resolution):
    if span <= 0.0 or speed <= 0.0:
        return 1
    n = math.ceil(span * speed / coarse_mm)
    cap = math.floor(span / resolution)
    if n > cap:
        n = cap
    if n > _MAX_COARSE:
        n = _MAX_COARSE
    if n < 1:
        n = 1
    return n


@njit(cache=True)
def _capsule_min(lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                 pa, ta, aa, ra, pb, tb, ab, rb, kptr, cap, zlim, pptr, pxy, rad_a, rad_b,
                 vglob, vmean, t_lo, t_hi, coarse_mm, tight_mm, resolution, thr, tol, rel):
    """Per link pair, the smallest lower bound C over [t_lo, t_hi] (within tolerance).

    Returns (cmin (n,), tmin (n,), cert (n,), evaluations). ``cert[p]`` is a value
    that the interval bound of every leaf of the bisection reached, so ``C(t) >=
    cert[p]`` on the whole span (``-inf`` when some leaf was stopped by the
    resolution before it got there).
    """
    n_lp = len(lp_oa)
    cmin = np.empty(n_lp)
    tmin = np.empty(n_lp)
    cert = np.empty(n_lp)
    n_eval = 0
    st_a = np.empty(_STACK)
    st_b = np.empty(_STACK)
    st_fa = np.empty(_STACK)
    st_fb = np.empty(_STACK)
    span = t_hi - t_lo
    for p in range(n_lp):
        oa, ob, ka, kb = lp_oa[p], lp_ob[p], lp_ka[p], lp_kb[p]
        lg = vglob[oa, ka] + vglob[ob, kb]
        n = _n_coarse(span, vmean[oa, ka] + vmean[ob, kb], coarse_mm, resolution)
        if lg == 0.0:
            n = 1
        tbest = t_lo
        prev_t = t_lo
        prev_f = _bound_at(p, t_lo, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                           pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, np.inf)
        n_eval += 1
        best = prev_f
        leaf_min = np.inf
        for g in range(1, n + 1):
            t = t_lo + span * g / n if g < n else t_hi
            f = _bound_at(p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                          pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, best + tight_mm)
            n_eval += 1
            if f < best:
                best = f
                tbest = t
            # refine [prev_t, t] depth first
            top = 0
            st_a[0] = prev_t
            st_b[0] = t
            st_fa[0] = prev_f
            st_fb[0] = f
            top = 1
            while top > 0:
                top -= 1
                a = st_a[top]
                b = st_b[top]
                fa = st_fa[top]
                fb = st_fb[top]
                h = b - a
                want = best - tol - rel * max(best - thr, 0.0)
                lb = 0.5 * (fa + fb - lg * h)
                if lb >= want:
                    leaf_min = min(leaf_min, lb)
                    continue
                loc = (_link_speed(oa, ka, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b)
                       + _link_speed(ob, kb, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b))
                lb = 0.5 * (fa + fb - loc * h)
                if lb >= want or h <= resolution or top + 2 > _STACK:
                    leaf_min = min(leaf_min, lb)
                    continue
                m = a + 0.5 * h
                fm = _bound_at(p, m, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                               pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy,
                               best + tight_mm)
                n_eval += 1
                if fm < best:
                    best = fm
                    tbest = m
                st_a[top] = m
                st_b[top] = b
                st_fa[top] = fm
                st_fb[top] = fb
                st_a[top + 1] = a
                st_b[top + 1] = m
                st_fa[top + 1] = fa
                st_fb[top + 1] = fm
                top += 2
            prev_t = t
            prev_f = f
        cmin[p] = best
        tmin[p] = tbest
        cert[p] = min(leaf_min, best)
    return cmin, tmin, cert, n_eval


@njit(cache=True)
def _grow(buf, n):
    if n < buf.shape[0]:
        return buf
    out = np.empty((2 * buf.shape[0] + 16, buf.shape[1]))
    out[:n] = buf[:n]
    return out


@njit(cache=True)
def _capsule_suspects(lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                      pa, ta, aa, ra, pb, tb, ab, rb, kptr, cap, zlim, pptr, pxy, rad_a, rad_b,
                      vglob, vmean, t_lo, t_hi, coarse_mm, tight_mm, resolution, thr, cut, tolp,
                      sel):
    """Intervals the lower bound C cannot clear against ``max(thr, cut[p])``, for the
    link pairs ``sel``.

    Returns (rows (m, 6): p, a, b, C(a), C(b), local speed bound L; evaluations).
    Rows of one pair are in time order; consecutive rows may share an end.
    """
    out = np.empty((1024, 6))
    n_out = 0
    n_eval = 0
    st_a = np.empty(_STACK)
    st_b = np.empty(_STACK)
    st_fa = np.empty(_STACK)
    st_fb = np.empty(_STACK)
    span = t_hi - t_lo
    for p in sel:
        oa, ob, ka, kb = lp_oa[p], lp_ob[p], lp_ka[p], lp_kb[p]
        lg = vglob[oa, ka] + vglob[ob, kb]
        n = _n_coarse(span, vmean[oa, ka] + vmean[ob, kb], coarse_mm, resolution)
        if lg == 0.0:
            n = 1
        want = cut[p]
        tight = max(want, thr) + tight_mm
        prev_t = t_lo
        prev_f = _bound_at(p, t_lo, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                           pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight)
        n_eval += 1
        for g in range(1, n + 1):
            t = t_lo + span * g / n if g < n else t_hi
            f = _bound_at(p, t, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                          pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight)
            n_eval += 1
            st_a[0] = prev_t
            st_b[0] = t
            st_fa[0] = prev_f
            st_fb[0] = f
            top = 1
            while top > 0:
                top -= 1
                a = st_a[top]
                b = st_b[top]
                fa = st_fa[top]
                fb = st_fb[top]
                h = b - a
                lb = 0.5 * (fa + fb - lg * h)
                if lb > thr and lb >= want:
                    continue
                loc = (_link_speed(oa, ka, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b)
                       + _link_speed(ob, kb, a, b, obj_rob, pa, ta, ra, pb, tb, rb, rad_a, rad_b))
                lb = 0.5 * (fa + fb - loc * h)
                if lb > thr and lb >= want:
                    continue
                if loc * h > 2.0 * tolp[p] and h > resolution and top + 2 <= _STACK:
                    m = a + 0.5 * h
                    fm = _bound_at(p, m, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                                   pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, tight)
                    n_eval += 1
                    st_a[top] = m
                    st_b[top] = b
                    st_fa[top] = fm
                    st_fb[top] = fb
                    st_a[top + 1] = a
                    st_b[top + 1] = m
                    st_fa[top + 1] = fa
                    st_fb[top + 1] = fm
                    top += 2
                    continue
                out = _grow(out, n_out)
                out[n_out, 0] = p
                out[n_out, 1] = a
                out[n_out, 2] = b
                out[n_out, 3] = fa
                out[n_out, 4] = fb
                out[n_out, 5] = loc
                n_out += 1
            prev_t = t
            prev_f = f
    return out[:n_out], n_eval


@njit(cache=True)
def _poses_and_bounds(qp, qt, lp_oa, lp_ka, lp_ob, lp_kb, obj_rob, obj_x, obj_y, la,
                      pa, ta, aa, pb, tb, ab, kptr, cap, zlim, pptr, pxy, max_pp):
    """For queries (link pair qp[k], time qt[k]): both link poses (theta, x, y) and the
    capsule bound of every piece pair (row-major u, v; padded with inf)."""
    n = len(qp)
    poses = np.empty((n, 6))
    bounds = np.full((n, max_pp), np.inf)
    for k in range(n):
        p = qp[k]
        t = qt[k]
        ka = lp_ka[p]
        kb = lp_kb[p]
        tha, xa, ya = _link_state(lp_oa[p], ka, t, obj_rob, obj_x, obj_y, la,
                                  pa, ta, aa, pb, tb, ab)
        thb, xb, yb = _link_state(lp_ob[p], kb, t, obj_rob, obj_x, obj_y, la,
                                  pa, ta, aa, pb, tb, ab)
        poses[k, 0] = tha
        poses[k, 1] = xa
        poses[k, 2] = ya
        poses[k, 3] = thb
        poses[k, 4] = xb
        poses[k, 5] = yb
        j = 0
        for u in range(kptr[ka], kptr[ka + 1]):
            for v in range(kptr[kb], kptr[kb + 1]):
                bounds[k, j] = _piece_bound(u, v, tha, xa, ya, thb, xb, yb, cap, zlim,
                                            pptr, pxy, np.inf)
                j += 1
    return poses, bounds


# =====================================================================================
# Exact distances (FCL)
# =====================================================================================
def _rot(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class _Exact:
    """Exact solid distance of two posed links with FCL, pruned by capsule bounds.

    ``distance(ka, pose_a, kb, pose_b, bounds)`` visits the piece pairs in increasing
    capsule bound and stops once the bound reaches the smallest exact distance found
    (a piece pair whose lower bound is not below it cannot be closer), so the result
    is the exact minimum over all piece pairs. FCL BVH distances are surface
    distances; a positive one whose capsule bound is ``<= 0`` is checked for
    containment (one vertex of each piece against the other's hull), which counts as
    distance 0. Two ``CollisionObject`` per piece (one per side of a pair) share the
    piece's BVH model.
    """

    def __init__(self, models: LinkModels):
        self.m = models
        self.objs = ([fcl.CollisionObject(b) for b in models.bvh],
                     [fcl.CollisionObject(b) for b in models.bvh])
        self.req = fcl.DistanceRequest()
        self._creq = fcl.CollisionRequest()
        self.n_calls = 0
        self.n_evals = 0
        self.seconds = 0.0

    def distance(self, ka: int, pose_a, za: float, kb: int, pose_b, zb: float,
                 bounds: np.ndarray) -> float:
        """Exact distance, mm. ``pose_*`` = (theta, x, y); ``z*`` the link frame z;
        ``bounds`` the piece-pair capsule bounds, row-major over (u, v)."""
        clock = time.perf_counter()
        m = self.m
        u0, v0 = int(m.kind_ptr[ka]), int(m.kind_ptr[kb])
        nb = int(m.kind_ptr[kb + 1]) - v0
        npp = (int(m.kind_ptr[ka + 1]) - u0) * nb
        bounds = bounds[:npp]
        order = np.argsort(bounds, kind="stable") if npp > 1 else (0,)
        tf_a = tf_b = None
        set_a: set = set()
        set_b: set = set()
        best = math.inf
        for j in order:
            bnd = float(bounds[j])
            if bnd >= best:
                break
            u, v = u0 + int(j) // nb, v0 + int(j) % nb
            if tf_a is None:
                tf_a = fcl.Transform(_rot(pose_a[0]), np.array([pose_a[1], pose_a[2], za]))
                tf_b = fcl.Transform(_rot(pose_b[0]), np.array([pose_b[1], pose_b[2], zb]))
            oa, ob = self.objs[0][u], self.objs[1][v]
            if u not in set_a:
                oa.setTransform(tf_a)
                set_a.add(u)
            if v not in set_b:
                ob.setTransform(tf_b)
                set_b.add(v)
            d = float(fcl.distance(oa, ob, self.req, fcl.DistanceResult()))
            self.n_calls += 1
            if d < 0.0:
                d = 0.0
            if d > 0.0 and bnd <= _CONTAIN_SLACK and self._contained(u, pose_a, za, v, pose_b, zb):
                d = 0.0
            if d < best:
                best = d
            if best <= 0.0:
                break
        self.n_evals += 1
        self.seconds += time.perf_counter() - clock
        return best

    def collides(self, ka: int, pose_a, za: float, kb: int, pose_b, zb: float,
                 bounds: np.ndarray, min_gap: float = 0.0) -> bool:
        """True when the two posed links are within ``min_gap`` (solid distance).

        Piece pairs whose bound exceeds ``min_gap`` are skipped; with ``min_gap == 0``
        FCL's boolean ``collide`` (much cheaper than ``distance``) decides, plus the
        containment test; otherwise the exact distance is compared.
        """
        clock = time.perf_counter()
        m = self.m
        u0, v0 = int(m.kind_ptr[ka]), int(m.kind_ptr[kb])
        nb = int(m.kind_ptr[kb + 1]) - v0
        npp = (int(m.kind_ptr[ka + 1]) - u0) * nb
        hit = False
        tf_a = fcl.Transform(_rot(pose_a[0]), np.array([pose_a[1], pose_a[2], za]))
        tf_b = fcl.Transform(_rot(pose_b[0]), np.array([pose_b[1], pose_b[2], zb]))
        for j in np.flatnonzero(bounds[:npp] <= min_gap):
            u, v = u0 + int(j) // nb, v0 + int(j) % nb
            oa, ob = self.objs[0][u], self.objs[1][v]
            oa.setTransform(tf_a)
            ob.setTransform(tf_b)
            self.n_calls += 1
            if min_gap > 0.0:
                d = float(fcl.distance(oa, ob, self.req, fcl.DistanceResult()))
                hit = d <= min_gap
            else:
                hit = fcl.collide(oa, ob, self._creq, fcl.CollisionResult()) > 0
            if not hit and float(bounds[j]) <= _CONTAIN_SLACK:
                hit = self._contained(u, pose_a, za, v, pose_b, zb)
            if hit:
                break
        self.n_evals += 1
        self.seconds += time.perf_counter() - clock
        return hit

    def _contained(self, u, pose_a, za, v, pose_b, zb) -> bool:
        """One piece inside the other (no surface crossing): a vertex of u in hull v, or
        a vertex of v in hull u."""
        m = self.m

        def to_world(p, pose, z):
            c, s = math.cos(pose[0]), math.sin(pose[0])
            return np.array([pose[1] + c * p[0] - s * p[1], pose[2] + s * p[0] + c * p[1],
                             z + p[2]])

        def to_local(w, pose, z):
            c, s = math.cos(pose[0]), math.sin(pose[0])
            dx, dy = w[0] - pose[1], w[1] - pose[2]
            return np.array([c * dx + s * dy, -s * dx + c * dy, w[2] - z])

        for (x, px, zx), (y, py, zy) in (((u, pose_a, za), (v, pose_b, zb)),
                                         ((v, pose_b, zb), (u, pose_a, za))):
            q = to_local(to_world(m.probe[x], px, zx), py, zy)
            eq = m.hull_eq[y]
            if np.all(eq[:, :3] @ q + eq[:, 3] <= 1e-9):
                return True
        return False


# =====================================================================================
# Trajectory preparation
# =====================================================================================
def _axis_csr(traj: Trajectory, ax: int):
    """(ptr (n+1,), times (K,), angles rad (K,), |slope| rad/s per breakpoint (K,))."""
    n = traj.n_robots
    counts = np.array([traj.times[ax][i].size for i in range(n)], dtype=np.int64)
    ptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=ptr[1:])
    tt = np.concatenate([np.asarray(traj.times[ax][i], dtype=np.float64) for i in range(n)]) \
        if n else np.zeros(0)
    aa = np.deg2rad(np.concatenate([np.asarray(traj.angles[ax][i], dtype=np.float64)
                                    for i in range(n)])) if n else np.zeros(0)
    rate = np.zeros(tt.size)
    for i in range(n):
        lo, hi = int(ptr[i]), int(ptr[i + 1])
        dt = np.diff(tt[lo:hi])
        da = np.abs(np.diff(aa[lo:hi]))
        jump = (dt <= 0) & (da > 0)
        if jump.any():
            k = int(np.flatnonzero(jump)[0])
            raise TrajectoryError(
                f"robot {int(traj.robot_ids[i])}: axis {AXES[ax]} jumps by "
                f"{math.degrees(float(da[k])):.6g} deg at t = {float(tt[lo + k]):.6g} s with "
                f"no time between breakpoints; allowed: continuous motion (strictly "
                f"increasing times where the angle changes)")
        with np.errstate(divide="ignore", invalid="ignore"):
            rate[lo:hi - 1] = np.where(dt > 0, da / np.where(dt > 0, dt, 1.0), 0.0)
    return ptr, tt, aa, rate


def _span(traj: Trajectory) -> tuple[float, float]:
    if traj.n_robots == 0:
        return 0.0, 0.0
    t_first = min(float(t[0]) for axis in traj.times for t in axis)
    t_last = max(float(t[-1]) for axis in traj.times for t in axis)
    t_lo = min(0.0, t_first)
    return t_lo, max(t_last, t_lo)


def _positive(value, name: str, allow_zero: bool = False) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    ok = math.isfinite(x) and (x >= 0 if allow_zero else x > 0) and not isinstance(value, bool)
    if not ok:
        raise field_error(SpecError, name, value,
                          f"a finite number {'>=' if allow_zero else '>'} 0", "validate_trajectory")
    return x


# =====================================================================================
# The check
# =====================================================================================
class _Scene:
    """Objects (robots of the trajectory + fiducials), candidate link pairs, kernels' inputs."""

    def __init__(self, traj: Trajectory, layout: Layout, models: LinkModels, min_gap: float):
        ids = np.asarray(traj.robot_ids, dtype=np.int64)
        uniq, counts = np.unique(ids, return_counts=True)
        if (counts > 1).any():
            raise TrajectoryError(f"robot {int(uniq[counts > 1][0])}: appears more than once "
                                  "in the trajectory; allowed: unique robot ids")
        n_r = len(ids)
        base = layout.robot_xy[layout.robot_indices(ids)] if n_r else np.empty((0, 2))
        fid_xy = np.asarray(layout.fiducial_xy, dtype=np.float64).reshape(-1, 2)
        n_f = len(fid_xy)
        self.robot_ids = ids
        self.fiducial_ids = np.asarray(layout.fiducial_ids, dtype=np.int64)
        self.n_robots, self.n_fiducials = n_r, n_f
        self.obj_rob = np.concatenate([np.arange(n_r), np.full(n_f, -1)]).astype(np.int64)
        xy = np.vstack([base, fid_xy]) if n_r + n_f else np.empty((0, 2))
        self.obj_x = np.ascontiguousarray(xy[:, 0])
        self.obj_y = np.ascontiguousarray(xy[:, 1])
        kinds_of = [tuple(LINKS.index(k) for k in ROBOT_LINKS)] * n_r + \
            [tuple(LINKS.index(k) for k in FIDUCIAL_LINKS)] * n_f
        max_reach = 2.0 * float(models.reach.max()) + min_gap + _REACH_TOL_MM
        pairs = cKDTree(xy).query_pairs(r=max_reach, output_type="ndarray") if len(xy) > 1 \
            else np.empty((0, 2), dtype=np.int64)
        pairs = np.sort(pairs.astype(np.int64).reshape(-1, 2), axis=1)
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
        # robot-robot and robot-fiducial pairs only (fiducials never move)
        pairs = pairs[pairs[:, 0] < n_r]
        rows, groups = [], []
        g = 0
        for i, j in pairs:
            d = float(np.hypot(xy[i, 0] - xy[j, 0], xy[i, 1] - xy[j, 1]))
            added = False
            for ka in kinds_of[i]:
                for kb in kinds_of[j]:
                    if models.can_touch(ka, kb, d, min_gap):
                        rows.append((i, ka, j, kb, g))
                        added = True
            if added:
                groups.append((int(i), int(j)))
                g += 1
        arr = np.asarray(rows, dtype=np.int64).reshape(-1, 5)
        self.lp_oa, self.lp_ka, self.lp_ob, self.lp_kb, self.lp_group = (
            np.ascontiguousarray(arr[:, c]) for c in range(5))
        self.groups = np.asarray(groups, dtype=np.int64).reshape(-1, 2)
        self.n_link_pairs = len(arr)

    def pair_ids(self, g: int) -> tuple[str, int, int]:
        i, j = (int(x) for x in self.groups[g])
        if j < self.n_robots:
            return "robot", int(self.robot_ids[i]), int(self.robot_ids[j])
        return "fiducial", int(self.robot_ids[i]), int(self.fiducial_ids[j - self.n_robots])


def validate_trajectory(traj: Trajectory, spec: RobotSpec, layout: Layout,
                        geometry: RobotGeometry | LinkModels | None = None, *,
                        min_gap_mm: float = 0.0, resolution_s: float = 1e-5,
                        distance_tol_mm: float = 0.01, distance_rel_tol: float = 0.05,
                        coarse_mm: float = 4.0,
                        progress: Optional[Callable[[str, int, int], None]] = None
                        ) -> Check3DReport:
    """Check a trajectory against the 3D collision meshes with FCL.

    Parameters
    ----------
    traj : Trajectory
        Robots are matched to the layout by id; layout robots it does not list are
        not checked.
    spec : RobotSpec
        Used for the default geometry (:func:`models.geometry.geometry_for_spec`).
    layout : Layout
        Robot bases and fiducials (fiducials are checked against every robot).
    geometry : RobotGeometry or LinkModels, optional
        The meshes; build :class:`LinkModels` once to reuse them over many checks.
    min_gap_mm : float
        Two links at a 3D distance ``<= min_gap_mm`` collide (default 0: contact).
    resolution_s : float
        Shortest interval bisected; an interval this short that the bounds cannot
        clear is reported as a (conservative) collision. Also the precision of
        collision start / end times.
    distance_tol_mm, distance_rel_tol : float
        Per-pair minima are found to within ``distance_tol_mm + distance_rel_tol *
        (distance - min_gap)``.
    coarse_mm : float
        Spacing of the first grid: the pair's mean point speed times the spacing.
        Sets only where refinement starts, not the guarantee.
    progress : callable(stage, done, total), optional
        Called as stages advance (``"capsule bounds"``, ``"exact distances"``).

    Returns
    -------
    Check3DReport

    Raises
    ------
    UnknownRobotError
        A trajectory robot id that is not a robot of the layout.
    TrajectoryError
        Duplicate robot ids, or an axis that jumps.
    SpecError
        A parameter out of range.
    """
    clock = time.perf_counter()
    thr = _positive(min_gap_mm, "min_gap_mm", allow_zero=True)
    res = _positive(resolution_s, "resolution_s")
    tol = _positive(distance_tol_mm, "distance_tol_mm", allow_zero=True)
    rel = _positive(distance_rel_tol, "distance_rel_tol", allow_zero=True)
    coarse = _positive(coarse_mm, "coarse_mm")
    if res < 1e-12:
        raise field_error(SpecError, "resolution_s", resolution_s, "a finite number >= 1e-12 s",
                          "validate_trajectory")
    if isinstance(geometry, LinkModels):
        models = geometry
    else:
        models = LinkModels.from_geometry(geometry if geometry is not None
                                          else geometry_for_spec(spec))
    report_progress = progress or (lambda stage, done, total: None)

    scene = _Scene(traj, layout, models, thr)
    t_lo, t_hi = _span(traj)
    n_lp = scene.n_link_pairs
    if traj.n_robots:
        pa, ta, aa, ra = _axis_csr(traj, 0)
        pb, tb, ab, rb = _axis_csr(traj, 1)
    else:
        pa = pb = np.zeros(1, dtype=np.int64)
        ta = aa = ra = tb = ab = rb = np.zeros(0)

    # per object and link kind: global and mean point-speed bounds, mm/s
    n_obj = len(scene.obj_rob)
    vglob = np.zeros((n_obj, len(LINKS)))
    vmean = np.zeros((n_obj, len(LINKS)))
    span = t_hi - t_lo
    for r in range(scene.n_robots):
        amax = float(ra[pa[r]:pa[r + 1]].max(initial=0.0))
        bmax = float(rb[pb[r]:pb[r + 1]].max(initial=0.0))
        atrav = float(np.sum(ra[pa[r]:pa[r + 1] - 1] * np.diff(ta[pa[r]:pa[r + 1]])))
        btrav = float(np.sum(rb[pb[r]:pb[r + 1] - 1] * np.diff(tb[pb[r]:pb[r + 1]])))
        vglob[r] = models.rad_alpha * amax + models.rad_beta * bmax
        if span > 0:
            vmean[r] = models.rad_alpha * atrav / span + models.rad_beta * btrav / span

    kern = (scene.lp_oa, scene.lp_ka, scene.lp_ob, scene.lp_kb, scene.obj_rob, scene.obj_x,
            scene.obj_y, models.l_alpha)
    traj_a = (pa, ta, aa, ra, pb, tb, ab, rb)
    geo = (models.kind_ptr, models.cap, models.zlim, models.poly_ptr, models.poly_xy,
           models.rad_alpha, models.rad_beta)

    # -- 1. capsule minimum per link pair ------------------------------------------
    report_progress("capsule bounds", 0, 2)
    n_cap = 0
    if n_lp:
        cmin, tcmin, cert, ne = _capsule_min(*kern, *traj_a, *geo, vglob, vmean, t_lo, t_hi,
                                             coarse, _TIGHT_MM, res, thr, tol, rel)
        n_cap += int(ne)
    else:
        cmin = tcmin = cert = np.zeros(0)
    t_broad = time.perf_counter() - clock
    report_progress("capsule bounds", 1, 2)

    exact = _Exact(models)
    max_pp = int(max(models.n_pieces(k) for k in range(len(LINKS))) ** 2)
    bnd_args = (scene.lp_oa, scene.lp_ka, scene.lp_ob, scene.lp_kb, scene.obj_rob,
                scene.obj_x, scene.obj_y, models.l_alpha, pa, ta, aa, pb, tb, ab,
                models.kind_ptr, models.cap, models.zlim, models.poly_ptr, models.poly_xy, max_pp)
    n_groups = len(scene.groups)
    best = np.full(n_groups, np.inf)
    best_t = np.full(n_groups, np.nan)
    best_lp = np.full(n_groups, -1, dtype=np.int64)
    lp_best = np.full(n_lp, np.inf)
    hits: dict[int, list] = {}      # link pair -> [(t_start, t_end, d, t_d, conservative)]

    def eval_exact(qp: np.ndarray, qt: np.ndarray) -> np.ndarray:
        poses, bounds = _poses_and_bounds(np.asarray(qp, dtype=np.int64),
                                          np.asarray(qt, dtype=np.float64), *bnd_args)
        out = np.empty(len(qp))
        for k in range(len(qp)):
            p = int(qp[k])
            ka, kb = int(scene.lp_ka[p]), int(scene.lp_kb[p])
            d = exact.distance(ka, poses[k, :3], models.offset_z[ka], kb, poses[k, 3:],
                               models.offset_z[kb], bounds[k])
            out[k] = d
            if d < lp_best[p]:
                lp_best[p] = d
            g = int(scene.lp_group[p])
            if d < best[g]:
                best[g], best_t[g], best_lp[g] = d, float(qt[k]), p
            if d <= thr:
                hits.setdefault(p, []).append((float(qt[k]), float(qt[k]), d, float(qt[k]), False))
        return out

    def want(g: int) -> float:
        b = best[g]
        if not math.isfinite(b):
            return math.inf
        return b - tol - rel * max(b - thr, 0.0)

    # -- 2. seed: exact distance at the capsule minimum ---------------------------------
    t0 = time.perf_counter()
    order = np.lexsort((cmin, scene.lp_group))
    for k, p in enumerate(order):
        g = int(scene.lp_group[p])
        if cmin[p] < want(g):
            eval_exact(np.array([p]), np.array([tcmin[p]]))
        if progress is not None and k % 2000 == 0:
            report_progress("exact distances", k, 3 * max(n_lp, 1))
    t_exact = time.perf_counter() - t0

    # -- 3. suspect intervals (capsule bound cannot clear) ------------------------------
    t0 = time.perf_counter()
    if n_lp:
        cut = np.array([want(int(scene.lp_group[p])) for p in range(n_lp)])
        gb = best[scene.lp_group]
        tolp = tol + rel * np.where(np.isfinite(gb), np.maximum(gb - thr, 0.0), 0.0)
        tolp = np.maximum(tolp, 1e-6)
        # step 1 already proved C >= cert[p] everywhere: pairs with cert above both the
        # threshold and their cut need no second pass
        done = (cert > thr) & (cert >= cut - 1e-9 * (1.0 + np.abs(cut)))
        sel = np.flatnonzero(~done).astype(np.int64)
        rows, ne = _capsule_suspects(*kern, *traj_a, *geo, vglob, vmean, t_lo, t_hi, coarse,
                                     _TIGHT_MM, res, thr, cut, tolp, sel)
        n_cap += int(ne)
    else:
        rows = np.zeros((0, 6))
    t_broad += time.perf_counter() - t0
    report_progress("capsule bounds", 2, 2)

    # -- 4. exact values at the ends of the suspect intervals, then refinement ---------
    t0 = time.perf_counter()
    if len(rows):
        ends = np.concatenate([rows[:, [0, 1]], rows[:, [0, 2]]])
        keys, inv = np.unique(ends, axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        vals = np.empty(len(keys))
        chunk = 4096
        for s in range(0, len(keys), chunk):
            vals[s:s + chunk] = eval_exact(keys[s:s + chunk, 0].astype(np.int64),
                                           keys[s:s + chunk, 1])
            report_progress("exact distances", n_lp + int(s * n_lp / max(len(keys), 1)),
                            3 * max(n_lp, 1))
        d_a, d_b = vals[inv[:len(rows)]], vals[inv[len(rows):]]
        for k in range(len(rows)):
            p = int(rows[k, 0])
            a, b, ca, cb, L = rows[k, 1], rows[k, 2], rows[k, 3], rows[k, 4], rows[k, 5]
            _refine(p, a, b, d_a[k], d_b[k], ca, cb, L, thr, res, scene, eval_exact, want, hits,
                    bnd_args)
    t_exact += time.perf_counter() - t0
    report_progress("exact distances", 3, 3)

    # -- report -------------------------------------------------------------------------
    collisions = _merge_hits(hits, scene, res)
    pairs = []
    kind_min: dict[str, float] = {}
    for g in range(n_groups):
        kind, a_id, b_id = scene.pair_ids(g)
        p = int(best_lp[g])
        links = (LINKS[int(scene.lp_ka[p])], LINKS[int(scene.lp_kb[p])]) if p >= 0 else ("", "")
        pairs.append(PairDistance(kind, (a_id, b_id), links, float(best[g]), float(best_t[g])))
    # per link-kind pair: smallest exact distance evaluated, and the capsule lower bound
    kind_lb: dict[str, float] = {}
    for p in range(n_lp):
        key = "-".join(sorted((LINKS[int(scene.lp_ka[p])], LINKS[int(scene.lp_kb[p])]),
                              key=LINKS.index))
        kind_min[key] = min(kind_min.get(key, math.inf), float(lp_best[p]))
        kind_lb[key] = min(kind_lb.get(key, math.inf), float(cmin[p]))
    pairs.sort(key=lambda x: (x.min_distance_mm, x.kind, x.ids))
    min_d = min([pd.min_distance_mm for pd in pairs] + [c.min_distance_mm for c in collisions],
                default=math.inf)
    return Check3DReport(
        min_gap_mm=thr, geometry=str(models.geometry.params.source), n_robots=scene.n_robots,
        n_fiducials=scene.n_fiducials, n_pairs=n_groups, n_link_pairs=n_lp,
        duration_s=t_hi - t_lo, pairs=pairs, min_distance_mm=float(min_d),
        link_kind_min_mm=kind_min, link_kind_lower_bound_mm=kind_lb, collisions=collisions,
        n_capsule_evals=n_cap,
        n_exact_evals=exact.n_evals, n_fcl_calls=exact.n_calls,
        seconds_broadphase=t_broad, seconds_exact=t_exact,
        seconds=time.perf_counter() - clock,
        settings={"resolution_s": res, "distance_tol_mm": tol, "distance_rel_tol": rel,
                  "coarse_mm": coarse})


def _refine(p, a, b, da, db, ca, cb, L, thr, res, scene, eval_exact, want, hits, bnd_args):
    """Settle one suspect interval of link pair p with exact values (bisection).

    Clears sub-intervals whose bound ``max(lb_D, lb_C)`` exceeds both the threshold and
    the pair's refinement cut; records colliding intervals and conservative ones.
    """
    g = int(scene.lp_group[p])
    stack = [(a, b, da, db, ca, cb)]
    while stack:
        a, b, da, db, ca, cb = stack.pop()
        h = b - a
        lb = max(0.5 * (da + db - L * h), 0.5 * (ca + cb - L * h))
        col_a, col_b = da <= thr, db <= thr
        split = unresolved = False
        if col_a and col_b:
            # FCL gives no penetration depth (D = 0 inside), so nothing proves an exit
            # between two colliding samples: the interval is reported as colliding
            hits.setdefault(p, []).append((a, b, min(da, db), a if da <= db else b, False))
        elif col_a or col_b:
            split = h > res
            if not split:
                hits.setdefault(p, []).append((a if col_a else b, a if col_a else b,
                                               da if col_a else db, a if col_a else b, False))
        elif lb <= thr:
            split = h > res
            unresolved = not split
        elif lb < want(g):
            split = h > res
        if split:
            m = a + 0.5 * h
            dm = float(eval_exact(np.array([p]), np.array([m]))[0])
            cm = float(_bound_at(p, m, *bnd_args[:19], np.inf))
            stack.append((m, b, dm, db, cm, cb))
            stack.append((a, m, da, dm, ca, cm))
        elif unresolved:
            hits.setdefault(p, []).append((a, b, max(lb, 0.0), a + 0.5 * h, True))


def _merge_hits(hits: dict, scene: _Scene, res: float) -> list[Collision3D]:
    """Per link pair, merge colliding samples / intervals at most ``res`` apart."""
    out = []
    for p, items in hits.items():
        items = sorted(items)
        any_real = any(not it[4] for it in items)
        if any_real:
            items = [it for it in items if not it[4]]
        runs = []
        for ts, te, d, td, cons in items:
            if runs and ts - runs[-1][1] <= res * (1 + 1e-9):
                r = runs[-1]
                r[1] = max(r[1], te)
                if d < r[2]:
                    r[2], r[3] = d, td
            else:
                runs.append([ts, te, d, td, cons])
        g = int(scene.lp_group[p])
        kind, a_id, b_id = scene.pair_ids(g)
        la, lb = LINKS[int(scene.lp_ka[p])], LINKS[int(scene.lp_kb[p])]
        for ts, te, d, td, cons in runs:
            out.append(Collision3D(kind, a_id, la, b_id, lb, ts, te, td, d, cons))
    out.sort(key=lambda c: (c.t_start, c.kind, c.robot_a, c.other, c.link_a, c.link_b))
    return out


# =====================================================================================
# Two robots, many configurations (buffer calibration, tests)
# =====================================================================================
@njit(cache=True)
def _pair_bounds(ang, ox, oy, lp_ka, lp_kb, la, kptr, cap, zlim, pptr, pxy, tight_below):
    """Lower bounds (n, n_lp) of every link pair of robot A (base at the origin) and
    robot B (base at (ox, oy)) for configurations ``ang`` (n, 4) rad: (aA, bA, aB, bB)."""
    n = ang.shape[0]
    out = np.empty((n, len(lp_ka)))
    for k in range(n):
        for p in range(len(lp_ka)):
            ka = lp_ka[p]
            kb = lp_kb[p]
            tha, xa, ya = _pose(ka, ang[k, 0], ang[k, 1], la)
            thb, xb, yb = _pose(kb, ang[k, 2], ang[k, 3], la)
            best = np.inf
            for u in range(kptr[ka], kptr[ka + 1]):
                for v in range(kptr[kb], kptr[kb + 1]):
                    d = _piece_bound(u, v, tha, xa, ya, thb, xb + ox, yb + oy, cap, zlim,
                                     pptr, pxy, tight_below)
                    if d < best:
                        best = d
            out[k, p] = best
    return out


@njit(cache=True)
def _pair_piece_bounds(ang, ox, oy, ka, kb, la, kptr, cap, zlim, pptr, pxy, max_pp):
    """Poses (n, 6) and piece-pair bounds (n, max_pp) of one link pair (ka of A, kb of B)."""
    n = ang.shape[0]
    poses = np.empty((n, 6))
    bounds = np.full((n, max_pp), np.inf)
    for k in range(n):
        tha, xa, ya = _pose(ka, ang[k, 0], ang[k, 1], la)
        thb, xb, yb = _pose(kb, ang[k, 2], ang[k, 3], la)
        xb += ox
        yb += oy
        poses[k, 0] = tha
        poses[k, 1] = xa
        poses[k, 2] = ya
        poses[k, 3] = thb
        poses[k, 4] = xb
        poses[k, 5] = yb
        j = 0
        for u in range(kptr[ka], kptr[ka + 1]):
            for v in range(kptr[kb], kptr[kb + 1]):
                bounds[k, j] = _piece_bound(u, v, tha, xa, ya, thb, xb, yb, cap, zlim,
                                            pptr, pxy, np.inf)
                j += 1
    return poses, bounds


class RobotPair:
    """Two robots of one design, robot B's base at ``offset_xy`` from robot A's.

    Batches of configurations ``angles`` are ``(n, 4)`` arrays of degrees
    ``(alpha_A, beta_A, alpha_B, beta_B)``. The link pairs compared are those that can
    touch at this base distance (:meth:`LinkModels.can_touch`).

    Methods
    -------
    bounds(angles) : (n,) lower bounds of the 3D distance (hull prisms, numba), mm
    distances(angles) : (n,) exact 3D (solid) distances with FCL, mm
    collides(angles, min_gap_mm) : (n,) bool, exact (bounds first, FCL where undecided)
    """

    def __init__(self, models: LinkModels, offset_xy, min_gap_mm: float = 0.0):
        self.models = models
        self.offset = np.asarray(offset_xy, dtype=np.float64).reshape(2)
        d = float(np.hypot(*self.offset))
        kinds = [LINKS.index(k) for k in ROBOT_LINKS]
        rows = [(ka, kb) for ka in kinds for kb in kinds
                if models.can_touch(ka, kb, d, min_gap_mm)]
        arr = np.asarray(rows, dtype=np.int64).reshape(-1, 2)
        self.lp_ka = np.ascontiguousarray(arr[:, 0])
        self.lp_kb = np.ascontiguousarray(arr[:, 1])
        self.link_names = [(LINKS[a], LINKS[b]) for a, b in rows]
        self._exact = _Exact(models)
        self._max_pp = int(max(models.n_pieces(k) for k in range(len(LINKS))) ** 2)

    @property
    def n_fcl_calls(self) -> int:
        """FCL calls made so far."""
        return self._exact.n_calls

    def _rad(self, angles) -> np.ndarray:
        a = np.ascontiguousarray(np.deg2rad(np.asarray(angles, dtype=np.float64).reshape(-1, 4)))
        if not np.all(np.isfinite(a)):
            raise field_error(SpecError, "angles", "NaN/inf", "finite angles in degrees",
                              "RobotPair")
        return a

    def link_bounds(self, angles) -> np.ndarray:
        """(n, n_link_pairs) lower bounds per link pair, mm."""
        m = self.models
        if len(self.lp_ka) == 0:
            return np.full((len(np.asarray(angles).reshape(-1, 4)), 0), np.inf)
        return _pair_bounds(self._rad(angles), float(self.offset[0]), float(self.offset[1]),
                            self.lp_ka, self.lp_kb, m.l_alpha, m.kind_ptr, m.cap, m.zlim,
                            m.poly_ptr, m.poly_xy, np.inf)

    def bounds(self, angles) -> np.ndarray:
        """(n,) lower bound of the 3D distance of the two robots, mm."""
        lb = self.link_bounds(angles)
        return lb.min(axis=1) if lb.shape[1] else np.full(lb.shape[0], np.inf)

    def _per_link(self, angles, fn):
        ang = self._rad(angles)
        lb = self.link_bounds(angles)
        m = self.models
        n = len(ang)
        out = [None] * n
        for p in range(len(self.lp_ka)):
            ka, kb = int(self.lp_ka[p]), int(self.lp_kb[p])
            poses, pb = _pair_piece_bounds(ang, float(self.offset[0]), float(self.offset[1]),
                                           ka, kb, m.l_alpha, m.kind_ptr, m.cap, m.zlim,
                                           m.poly_ptr, m.poly_xy, self._max_pp)
            for k in range(n):
                out[k] = fn(out[k], k, p, ka, kb, poses[k], pb[k], lb[k])
        return out

    def distances(self, angles, with_links: bool = False):
        """Exact 3D distances (FCL, solid), mm, (n,); with ``with_links`` also the
        closest link pair ``(link_a, link_b)`` of each configuration."""
        m = self.models

        def fn(state, k, p, ka, kb, pose, pb, lb_row):
            best, arg = state if state is not None else (math.inf, -1)
            if lb_row[p] >= best:
                return best, arg
            d = self._exact.distance(ka, pose[:3], m.offset_z[ka], kb, pose[3:],
                                     m.offset_z[kb], pb)
            return (d, p) if d < best else (best, arg)

        res = self._per_link(angles, fn)
        d = np.array([r[0] if r is not None else math.inf for r in res])
        if with_links:
            return d, [self.link_names[r[1]] if r is not None and r[1] >= 0 else ("", "")
                       for r in res]
        return d

    def collides(self, angles, min_gap_mm: float = 0.0) -> np.ndarray:
        """(n,) bool: the robots are within ``min_gap_mm`` (solid) at each configuration."""
        m = self.models
        gap = float(min_gap_mm)

        def fn(state, k, p, ka, kb, pose, pb, lb_row):
            if state or lb_row[p] > gap:
                return bool(state)
            return self._exact.collides(ka, pose[:3], m.offset_z[ka], kb, pose[3:],
                                        m.offset_z[kb], pb, gap)

        return np.array([bool(r) for r in self._per_link(angles, fn)], dtype=bool)
