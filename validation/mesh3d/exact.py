"""Exact solid distance of two posed links with FCL (mm), pruned by the capsule bounds.

*Solid overlap.* FCL's BVH distance measures surfaces: a piece wholly inside another
has a positive surface distance. Whenever the capsule bound of a piece pair is ``<= 0``
(their enclosing prisms overlap, the only case in which one can contain the other) and
FCL says ``> 0``, one vertex of each piece is tested against the other's convex hull
(half-spaces); containment gives distance 0. So the distance returned is the *solid*
distance, which the Lipschitz argument of :mod:`rfp_twin.validation.mesh3d.broadphase` also
covers. FCL gives no penetration depth: inside a collision the distance is 0.
"""
from __future__ import annotations

import math
import time

import fcl
import numpy as np

from rfp_twin.validation.mesh3d.links import LinkModels

#: Slack (mm) under which a containment test is run (capsule bound <= this).
CONTAIN_SLACK = 1e-9


def _transform(pose, z: float) -> fcl.Transform:
    """FCL transform of a link pose ``(theta, x, y)`` at height ``z``."""
    c, s = math.cos(pose[0]), math.sin(pose[0])
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return fcl.Transform(rot, np.array([pose[1], pose[2], z]))


class _PoseFrame:
    """A link posed upright: ``(theta, x, y)`` at height ``z`` (mm)."""

    def __init__(self, pose, z: float):
        self.pose, self.z = pose, z

    def transform(self) -> fcl.Transform:
        return _transform(self.pose, self.z)

    def to_world(self, p):
        c, s = math.cos(self.pose[0]), math.sin(self.pose[0])
        return np.array([self.pose[1] + c * p[0] - s * p[1], self.pose[2] + s * p[0] + c * p[1],
                         self.z + p[2]])

    def to_local(self, w):
        c, s = math.cos(self.pose[0]), math.sin(self.pose[0])
        dx, dy = w[0] - self.pose[1], w[1] - self.pose[2]
        return np.array([c * dx + s * dy, -s * dx + c * dy, w[2] - self.z])


class _MatrixFrame:
    """A link posed anyhow: world point ``= t + R p`` (R (3, 3), t (3,) mm)."""

    def __init__(self, rot, trans):
        self.rot = np.asarray(rot, dtype=np.float64)
        self.trans = np.asarray(trans, dtype=np.float64)

    def transform(self) -> fcl.Transform:
        return fcl.Transform(self.rot, self.trans)

    def to_world(self, p):
        return self.trans + self.rot @ p

    def to_local(self, w):
        return self.rot.T @ (np.asarray(w) - self.trans)


class ExactDistance:
    """Exact solid distance of two posed links with FCL, pruned by capsule bounds.

    ``distance(ka, pose_a, kb, pose_b, bounds)`` visits the piece pairs in increasing
    capsule bound and stops once the bound reaches the smallest exact distance found
    (a piece pair whose lower bound is not below it cannot be closer), so the result
    is the exact minimum over all piece pairs. FCL BVH distances are surface
    distances; a positive one whose capsule bound is ``<= 0`` is checked for
    containment (one vertex of each piece against the other's hull), which counts as
    distance 0. Two ``CollisionObject`` per piece (one per side of a pair) share the
    piece's BVH model; two more its convex solid (``upper_above``: GJK upper bounds).
    ``n_calls`` counts BVH distance calls, ``n_hull_calls`` GJK ones.
    """

    def __init__(self, models: LinkModels):
        self.m = models
        self.objs = ([fcl.CollisionObject(b) for b in models.bvh],
                     [fcl.CollisionObject(b) for b in models.bvh])
        self.hulls = ([fcl.CollisionObject(c) for c in models.hull],
                      [fcl.CollisionObject(c) for c in models.hull])
        self.req = fcl.DistanceRequest()
        self._creq = fcl.CollisionRequest()
        self.n_calls = 0
        self.n_hull_calls = 0
        self.n_evals = 0
        self.seconds = 0.0

    def distance(self, ka: int, pose_a, za: float, kb: int, pose_b, zb: float,
                 bounds: np.ndarray, upper_above: float | None = None) -> float:
        """Exact distance, mm. ``pose_*`` = (theta, x, y); ``z*`` the link frame z;
        ``bounds`` the piece-pair capsule bounds, row-major over (u, v); ``upper_above``
        as :meth:`distance_frames`."""
        return self.distance_frames(ka, _PoseFrame(pose_a, za), kb, _PoseFrame(pose_b, zb),
                                    bounds, upper_above)

    def distance_between(self, ka: int, rot_a, trans_a, kb: int, rot_b, trans_b,
                         bounds: np.ndarray, upper_above: float | None = None) -> float:
        """:meth:`distance` of links posed by world transforms ``(R (3, 3), t (3,))``
        (tilted robots; ``bounds`` lower bounds of the piece-pair distances)."""
        return self.distance_frames(ka, _MatrixFrame(rot_a, trans_a), kb,
                                    _MatrixFrame(rot_b, trans_b), bounds, upper_above)

    def distance_frames(self, ka: int, frame_a, kb: int, frame_b, bounds: np.ndarray,
                        upper_above: float | None = None) -> float:
        """Exact distance, mm, of link kind ka posed by ``frame_a`` and kb by ``frame_b``
        (:class:`_PoseFrame` or :class:`_MatrixFrame`).

        With ``upper_above`` set, FCL's GJK on the pieces as convex solids
        (``LinkModels.hull``, ~30x faster than the BVH) gives the value instead: the
        distance of two points of the solids, so never below the exact one, and equal to
        it to 1e-6 mm on most poses (GJK stops early on a few, up to ~0.3 mm above).
        Only a GJK value ``<= upper_above`` (a contact, or a near one) is replaced by the
        exact distance.
        """
        clock = time.perf_counter()
        u0, v0, nb, npp = self._pieces(ka, kb)
        bounds = bounds[:npp]
        order = np.argsort(bounds, kind="stable") if npp > 1 else (0,)
        d = math.inf
        if upper_above is not None:
            d, calls = self._piece_min(order, bounds, u0, v0, nb, frame_a, frame_b,
                                       self.hulls, solid=True)
            self.n_hull_calls += calls
        if upper_above is None or d <= upper_above:
            d, calls = self._piece_min(order, bounds, u0, v0, nb, frame_a, frame_b, self.objs,
                                       solid=False)
            self.n_calls += calls
        self.n_evals += 1
        self.seconds += time.perf_counter() - clock
        return d

    def _piece_min(self, order, bounds, u0, v0, nb, frame_a, frame_b, objs,
                   solid: bool) -> tuple[float, int]:
        """Smallest FCL distance over the piece pairs, in increasing bound, stopping once
        the bound reaches it, and the FCL calls made. ``solid``: the objects are convex
        solids (an overlap has distance 0); otherwise BVH surfaces plus the containment
        test."""
        tf_a = tf_b = None
        set_a: set = set()
        set_b: set = set()
        best = math.inf
        calls = 0
        for j in order:
            bnd = float(bounds[j])
            if bnd >= best:
                break
            u, v = u0 + int(j) // nb, v0 + int(j) % nb
            if tf_a is None:
                tf_a, tf_b = frame_a.transform(), frame_b.transform()
            oa, ob = objs[0][u], objs[1][v]
            if u not in set_a:
                oa.setTransform(tf_a)
                set_a.add(u)
            if v not in set_b:
                ob.setTransform(tf_b)
                set_b.add(v)
            d = float(fcl.distance(oa, ob, self.req, fcl.DistanceResult()))
            calls += 1
            if d < 0.0:
                d = 0.0
            if (not solid and d > 0.0 and bnd <= CONTAIN_SLACK
                    and self._contained(u, frame_a, v, frame_b)):
                d = 0.0
            if d < best:
                best = d
            if best <= 0.0:
                break
        return best, calls

    def collides(self, ka: int, pose_a, za: float, kb: int, pose_b, zb: float,
                 bounds: np.ndarray, min_gap: float = 0.0) -> bool:
        """True when the two posed links are within ``min_gap`` (solid distance).

        Piece pairs whose bound exceeds ``min_gap`` are skipped; with ``min_gap == 0``
        FCL's boolean ``collide`` (much cheaper than ``distance``) decides, plus the
        containment test; otherwise the exact distance is compared.
        """
        clock = time.perf_counter()
        u0, v0, nb, npp = self._pieces(ka, kb)
        hit = False
        tf_a, tf_b = _transform(pose_a, za), _transform(pose_b, zb)
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
            if not hit and float(bounds[j]) <= CONTAIN_SLACK:
                hit = self._contained(u, _PoseFrame(pose_a, za), v, _PoseFrame(pose_b, zb))
            if hit:
                break
        self.n_evals += 1
        self.seconds += time.perf_counter() - clock
        return hit

    def _pieces(self, ka: int, kb: int) -> tuple[int, int, int, int]:
        """First piece of each link kind, pieces of kb, and piece pairs."""
        m = self.m
        u0, v0 = int(m.kind_ptr[ka]), int(m.kind_ptr[kb])
        nb = int(m.kind_ptr[kb + 1]) - v0
        return u0, v0, nb, (int(m.kind_ptr[ka + 1]) - u0) * nb

    def _contained(self, u, frame_a, v, frame_b) -> bool:
        """One piece inside the other (no surface crossing): a vertex of u in hull v, or
        a vertex of v in hull u."""
        m = self.m
        for (x, fx), (y, fy) in (((u, frame_a), (v, frame_b)), ((v, frame_b), (u, frame_a))):
            q = fy.to_local(fx.to_world(m.probe[x]))
            eq = m.hull_eq[y]
            if np.all(eq[:, :3] @ q + eq[:, 3] <= 1e-9):
                return True
        return False
