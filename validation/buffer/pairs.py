"""What the 2D model is calibrated against: two robots in each neighbour direction (mm, deg).

:class:`MeshPairs`
    The 3D collision meshes of a :class:`rfp_twin.models.geometry.RobotGeometry`, exact
    (:class:`rfp_twin.validation.mesh3d.RobotPair`: numba lower bounds, FCL where they
    cannot decide).
:class:`CapsulePairs`
    The 2D capsule model itself (Sayres et al. 2021, Eq. 3): the robot *is* a capsule of
    radius ``r`` around its beta segment ``[segment_start, spec.segment_end(r)]``. Its
    smallest safe buffer is ``r`` by construction; it is the reference column of a
    comparison (what the paper's analytic buffer describes), computed in 2D alone.

Both answer ``classify(angles, direction index)`` (bool: the two robots touch) and
``distances`` (their surface distance, 0 when they touch), for configurations ``(n, 4)``
deg ``(alpha_A, beta_A, alpha_B, beta_B)``, robot B at ``offsets[direction index]``.
"""
from __future__ import annotations

import numpy as np

from rfp_twin.models.geometry import RobotGeometry
from rfp_twin.models.robot import RobotSpec
from rfp_twin.validation.buffer.model2d import pair_segment_distances
from rfp_twin.validation.mesh3d import LinkModels, RobotPair


class MeshPairs:
    """The 3D meshes of one geometry, one :class:`RobotPair` per direction."""

    kind = "mesh"

    def __init__(self, geometry: RobotGeometry, offsets: np.ndarray):
        self.geometry = geometry
        self.offsets = np.asarray(offsets, dtype=np.float64).reshape(-1, 2)
        self.models = LinkModels.from_geometry(geometry)
        self.pairs = [RobotPair(self.models, o) for o in self.offsets]

    @property
    def n_fcl_calls(self) -> int:
        return int(sum(p.n_fcl_calls for p in self.pairs))

    def classify(self, ang: np.ndarray, dir_idx: np.ndarray) -> np.ndarray:
        """3D collision (exact) per configuration."""
        out = np.zeros(len(ang), dtype=bool)
        for k, pr in enumerate(self.pairs):
            sel = np.flatnonzero(dir_idx == k)
            if sel.size == 0:
                continue
            lb = pr.bounds(ang[sel])
            maybe = sel[lb <= 0.0]
            if maybe.size:
                out[maybe] = pr.collides(ang[maybe])
        return out

    def distances(self, ang: np.ndarray, dir_idx: np.ndarray) -> np.ndarray:
        """Exact 3D (solid) distance per configuration, mm."""
        out = np.empty(len(ang))
        for k, pr in enumerate(self.pairs):
            sel = np.flatnonzero(dir_idx == k)
            if sel.size:
                out[sel] = pr.distances(ang[sel])
        return out

    def contact(self, ang: np.ndarray, k: int) -> tuple[float, str]:
        """3D distance and closest links (``beta-beta``) of one configuration (4,)."""
        d, links = self.pairs[k].distances(np.asarray(ang)[None, :], with_links=True)
        return float(d[0]), "-".join(links[0])

    def envelope_mm(self, seg: tuple[float, float]) -> float:
        return float(self.geometry.beta_envelope_mm(*seg))

    def other_contacts(self, margin_mm: float) -> list[str]:
        """Link pairs other than beta-beta that could come within ``margin_mm`` of each
        other (z intervals overlap and their planar reaches from the two alpha axes
        add up to the pitch less the margin), piece by piece. Empty: only the beta arms
        can touch, even with the robots moved by up to ``margin_mm`` in the plane."""
        g = self.geometry
        la = float(g.spec.alpha_length_mm)
        pitch = float(np.min(np.hypot(self.offsets[:, 0], self.offsets[:, 1])))

        def pieces(name):
            z0 = float(g.link_transform(name)[2, 3])
            extra = la if name == "beta" else 0.0
            return [(m.bounds[0, 2] + z0, m.bounds[1, 2] + z0,
                     extra + float(np.hypot(m.vertices[:, 0], m.vertices[:, 1]).max()))
                    for m in g.links[name].collision]

        out = []
        for la_name, lb_name in self.pairs[0].link_names:
            if (la_name, lb_name) == ("beta", "beta"):
                continue
            for za0, za1, ra in pieces(la_name):
                if any(zb0 <= za1 and za0 <= zb1 and ra + rb + margin_mm >= pitch
                       for zb0, zb1, rb in pieces(lb_name)):
                    out.append(f"{la_name}-{lb_name}")
                    break
        return out


class CapsulePairs:
    """The 2D capsule model as the robot: a capsule of ``radius_mm`` around the beta
    segment ``[segment_start, spec.segment_end(radius)]``."""

    kind = "capsule"
    n_fcl_calls = 0

    def __init__(self, spec: RobotSpec, radius_mm: float, offsets: np.ndarray):
        self.spec = spec
        self.radius = float(radius_mm)
        self.offsets = np.asarray(offsets, dtype=np.float64).reshape(-1, 2)

    def distances(self, ang: np.ndarray, dir_idx: np.ndarray) -> np.ndarray:
        """Surface distance of the two capsules (0 when they overlap), mm."""
        d2 = pair_segment_distances(self.spec, self.offsets[dir_idx], ang, self.radius)
        return np.maximum(d2 - 2.0 * self.radius, 0.0)

    def classify(self, ang: np.ndarray, dir_idx: np.ndarray) -> np.ndarray:
        d2 = pair_segment_distances(self.spec, self.offsets[dir_idx], ang, self.radius)
        return d2 <= 2.0 * self.radius

    def contact(self, ang: np.ndarray, k: int) -> tuple[float, str]:
        return float(self.distances(np.asarray(ang)[None, :], np.array([k]))[0]), "beta-beta"

    def envelope_mm(self, seg: tuple[float, float]) -> float:
        """Farthest capsule point from the segment ``seg`` on the beta axis, mm."""
        s0, s1 = float(self.spec.segment_start_mm), float(self.spec.segment_end(self.radius))
        out = max(0.0, seg[0] - s0, s1 - seg[1])
        return self.radius + out

    def other_contacts(self, margin_mm: float) -> list[str]:
        return []
