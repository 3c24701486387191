"""The published "P1" prototype beta arm of SDSS-V: a sphere-swept polyline (tube).

The only published 3D description of an SDSS-V beta arm is the P1 prototype model in the
early history of SDSS-V's planner kaiju (``python/kaiju/betaArm.cpp``, kaiju commit
479b820, 2019-01-04; removed in July 2019 when kaiju moved to 2D segments). It sweeps a
sphere along a polyline in the beta-arm frame (x along the arm from the beta axis, z up
from the arm's base), one radius per segment: a curved fiber conduit rising to a head
block at z = 30 mm. Every number of it is in :data:`P1_BETA_ARM` below, with its source.

Our reading (not stated in the source)
--------------------------------------
- The published model gives no height of its base, so P1's z = 0 is placed at the
  beta frame origin (on the beta axis, ``beta_z_mm`` above the robot frame; see
  :mod:`rfp_twin.models.geometry.dimensions`). The beta post joins the alpha arm's top to
  the first point of the tube (inside its base sphere).
- The fibers sit in the head, on its axis: fiber tips (and so the focal surface and the
  fiducial posts) at :data:`P1_HEAD_Z_MM` above the beta frame origin. The production
  fibers (metrology at x = 14.314 mm, BOSS/APOGEE at 14.965 mm) lie inside the head's
  rounded end (14.7 + 2.61 mm).
- P1 is a 2018-19 prototype, not the production robot: the production head is narrower
  (flat tip 0.6 mm wide at 16.2 mm, coordio/kaiju 1.4.1).

Each segment becomes one convex collision piece: a capsule of that segment's radius
between its two points (:func:`p1_pieces`), tessellated with ``circle_sections``
longitude facets (the vertices lie on the true surface, so the pieces are inscribed).
Units: mm.
"""
from __future__ import annotations

import numpy as np
import trimesh

#: Source of every number below.
P1_SOURCE = "kaiju python/kaiju/betaArm.cpp, commit 479b820 (2019-01-04), P1 beta arm"

#: P1 polyline: (x mm, z mm, radius mm of the segment that starts at this point; None at
#: the last point), beta-arm frame, y = 0. Source: P1_SOURCE, the polyline table.
P1_BETA_ARM: tuple[tuple[float, float, float | None], ...] = (
    (0.9895, 7.8507, 3.4372),    # point 0: base of the conduit
    (2.3053, 9.0969, 3.3300),    # point 1
    (3.6596, 10.5148, 3.1003),   # point 2
    (5.2536, 12.3113, 2.9949),   # point 3
    (6.5389, 14.0022, 2.9130),   # point 4
    (7.6490, 15.8129, 2.8715),   # point 5
    (8.5728, 17.7255, 2.8414),   # point 6
    (9.3010, 19.7206, 2.8200),   # point 7
    (9.8264, 21.7786, 2.8058),   # point 8
    (10.1438, 23.8787, 2.7977),  # point 9
    (10.25, 26.0, 2.7950),       # point 10: top of the conduit
    (10.25, 30.0, 2.61),         # point 11: head block, radius 2.61
    (14.7, 30.0, None),          # point 12: end; 19.2 flat end - 3.0 beta-axis offset
                                 # - 1.5 machined radius = 14.7 (source comment)
)

#: Height of the head's axis above P1's z = 0 (the last point's z), mm: the fiber tips.
P1_HEAD_Z_MM = P1_BETA_ARM[-1][1]
#: End of the polyline along the arm (centre of the head's rounded end), mm.
P1_END_X_MM = P1_BETA_ARM[-1][0]


def p1_points() -> np.ndarray:
    """Polyline points (13, 3) (x, 0, z), beta frame, mm."""
    return np.array([[x, 0.0, z] for x, z, _ in P1_BETA_ARM], dtype=np.float64)


def p1_radii() -> np.ndarray:
    """Radius of each of the 12 segments, mm."""
    return np.array([r for _, _, r in P1_BETA_ARM[:-1]], dtype=np.float64)


def p1_reach_mm() -> float:
    """Largest planar distance of the tube from the beta axis, mm (14.7 + 2.61)."""
    pts, rad = p1_points(), p1_radii()
    return float(max(np.hypot(pts[k + s, 0], pts[k + s, 1]) + rad[k]
                     for k in range(len(rad)) for s in (0, 1)))


def segment_capsule(p0, p1, radius: float, sections: int) -> trimesh.Trimesh:
    """Watertight convex capsule of ``radius`` around the segment ``p0``-``p1`` (3,) mm,
    ``sections`` facets around its axis and ``sections // 2`` from pole to pole."""
    p0 = np.asarray(p0, dtype=np.float64)
    p1 = np.asarray(p1, dtype=np.float64)
    d = p1 - p0
    length = float(np.linalg.norm(d))
    mesh = trimesh.creation.capsule(height=length, radius=float(radius),
                                    count=[max(2, sections // 2), max(3, sections)])
    lo, hi = mesh.bounds[:, 2]
    mesh.apply_translation([0.0, 0.0, -0.5 * (lo + hi)])      # centre on the origin
    tf = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], d / length) if length > 0 else np.eye(4)
    tf = np.array(tf, dtype=np.float64)
    tf[:3, 3] = 0.5 * (p0 + p1)
    mesh.apply_transform(tf)
    return mesh


def p1_pieces(sections: int) -> list[trimesh.Trimesh]:
    """The 12 convex pieces of the P1 tube (one capsule per segment), beta frame, mm."""
    pts, rad = p1_points(), p1_radii()
    return [segment_capsule(pts[k], pts[k + 1], rad[k], sections) for k in range(len(rad))]


def p1_plan_distance(x: float, y: float) -> float:
    """Planar distance of a point (x, y) of the beta frame from the head's axis segment
    (z = :data:`P1_HEAD_Z_MM`, from point 11 to point 12), mm."""
    (x0, _, _), (x1, _, _) = P1_BETA_ARM[-2], P1_BETA_ARM[-1]
    t = min(max(x, x0), x1)
    return float(np.hypot(x - t, y))
