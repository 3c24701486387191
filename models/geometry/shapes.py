"""Procedural link meshes: planar outlines, prisms, cylinders and their union (trimesh).

Outlines are ``(k, 2)`` float64 mm, convex and counter-clockwise; meshes are watertight
``trimesh.Trimesh`` in the link frame (mm, z up; frames in
:mod:`rfp_twin.models.geometry.dimensions`). The procedural collision pieces are exact: the beta
bar outline (capsule cut by the flat tip) is convex, so it is one piece; post and
ferrule are cylinders. With ``beta_shape = "p1"`` the beta link is the P1 tube, one
capsule per polyline segment (:mod:`rfp_twin.models.geometry.p1`), and the post.
"""
from __future__ import annotations

import math
import numpy as np
import trimesh
from scipy.spatial import ConvexHull

from rfp_twin.models.geometry.dimensions import GeometryParams
from rfp_twin.models.geometry.p1 import P1_BETA_ARM, p1_pieces
from rfp_twin.models.robot import RobotSpec


def _arc(cx: float, cy: float, r: float, a0: float, a1: float, n: int) -> np.ndarray:
    """Points (n, 2) on a circle from angle a0 to a1 (rad), both ends included."""
    t = np.linspace(a0, a1, max(n, 2))
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])


def _hull2d(points: np.ndarray) -> np.ndarray:
    """Convex hull of 2D points, CCW, (k, 2)."""
    return points[ConvexHull(points).vertices]


def prism(outline: np.ndarray, z0: float, z1: float) -> trimesh.Trimesh:
    """Watertight prism of a convex CCW outline (k, 2) between heights z0 < z1, mm."""
    k = len(outline)
    verts = np.vstack([np.column_stack([outline, np.full(k, z0)]),
                       np.column_stack([outline, np.full(k, z1)])])
    faces = []
    for i in range(1, k - 1):               # caps: fans (outline is convex)
        faces.append((0, i + 1, i))         # bottom, facing -z
        faces.append((k, k + i, k + i + 1))  # top, facing +z
    for i in range(k):                      # sides
        j = (i + 1) % k
        faces.append((i, j, k + j))
        faces.append((i, k + j, k + i))
    mesh = trimesh.Trimesh(verts, np.array(faces), process=True)
    return mesh


def cylinder(x: float, y: float, r: float, z0: float, z1: float, sections: int) -> trimesh.Trimesh:
    """Vertical cylinder (a prism of a regular polygon inscribed in the circle)."""
    return prism(_arc(x, y, r, 0.0, 2 * math.pi, sections + 1)[:-1], z0, z1)


def beta_outline(p: GeometryParams) -> np.ndarray:
    """Planar outline of the beta bar in the beta frame, CCW, (k, 2) mm.

    A capsule of radius ``beta_half_width_mm`` around the segment from
    ``beta_half_width_mm - beta_rear_mm`` to :attr:`GeometryParams.head_centre_mm` on the
    x axis, cut flat at ``x = beta_tip_mm``. Every vertex lies on that capsule.
    """
    hw, n = p.beta_half_width_mm, p.circle_sections
    x_rear = hw - p.beta_rear_mm
    xc = p.head_centre_mm
    rear = _arc(x_rear, 0.0, hw, math.pi / 2, 3 * math.pi / 2, n // 2 + 1)
    a_tip = math.asin(p.beta_tip_half_width_mm / hw)  # angle of the tip corners on the head
    head = _arc(xc, 0.0, hw, -math.pi / 2, -a_tip, n // 4 + 1)
    head = np.vstack([head, _arc(xc, 0.0, hw, a_tip, math.pi / 2, n // 4 + 1)])
    corners = np.array([[p.beta_tip_mm, -p.beta_tip_half_width_mm],
                        [p.beta_tip_mm, p.beta_tip_half_width_mm]])
    return _hull2d(np.vstack([rear, head, corners]))


def alpha_outline(p: GeometryParams, l_alpha: float) -> np.ndarray:
    """Planar outline of the alpha arm (hub + beta housing stadium), CCW, (k, 2) mm."""
    n = p.circle_sections
    pts = np.vstack([_arc(0.0, 0.0, p.alpha_hub_radius_mm, 0, 2 * math.pi, n + 1)[:-1],
                     _arc(l_alpha, 0.0, p.alpha_housing_radius_mm, 0, 2 * math.pi, n + 1)[:-1]])
    return _hull2d(pts)


def procedural_pieces(p: GeometryParams, spec: RobotSpec) -> dict[str, list[trimesh.Trimesh]]:
    """Convex pieces of every link in its own frame.

    Beta link: the bar, the post and the ferrule; or (``beta_shape = "p1"``) the 12 P1
    tube capsules and the post, which rises from the alpha arm's top to the tube's first
    point (inside its base sphere)."""
    n = p.circle_sections
    gap = p.beta_z_mm - p.alpha_top_mm            # between alpha top and beta frame origin
    if p.beta_shape == "p1":
        beta = [*p1_pieces(n), cylinder(0.0, 0.0, p.post_radius_mm, -gap, P1_BETA_ARM[0][1], n)]
    else:
        beta = [prism(beta_outline(p), 0.0, p.beta_height_mm),
                cylinder(0.0, 0.0, p.post_radius_mm, -gap, 0.0, n),
                cylinder(p.ferrule_x_mm, p.ferrule_y_mm, p.ferrule_radius_mm,
                         -p.ferrule_drop_mm, 0.0, n)]
    return {
        "body": [cylinder(0.0, 0.0, p.body_radius_mm, -p.body_length_mm, 0.0, n)],
        "alpha": [prism(alpha_outline(p, spec.alpha_length_mm), 0.0, p.alpha_height_mm)],
        "beta": beta,
        "fiducial": [cylinder(0.0, 0.0, p.fiducial_radius_mm, -p.body_length_mm,
                              p.fiber_z_mm, n)],
    }


def union(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Boolean union (manifold3d) of watertight meshes; one watertight mesh."""
    if len(meshes) == 1:
        return meshes[0].copy()
    return trimesh.boolean.union(meshes, engine="manifold")
