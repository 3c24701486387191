"""3D validation of a :class:`rfp_twin.models.trajectory.Trajectory` against the robot meshes (FCL).

Checks every pair of links that can touch against the convex collision pieces MuJoCo
collides, with a bound between samples so that no contact, however brief, can slip
through (mm, deg, s at the public boundary; radians inside the kernels).

Modules
-------
report
    :class:`Check3DReport`, :class:`Collision3D`, :class:`PairDistance`.
links
    :class:`LinkModels` (capsules, hulls, speed radii, FCL models per piece),
    :func:`fit_capsule`, :func:`link_pose`; each robot's own geometry from the layout
    columns (:func:`placement`: alpha arm, height, axis; guide-camera walls) and the
    links' world transforms (:func:`link_frame`).
bounds
    numba lower bounds of the distance of two posed links (capsule and hull prisms).
broadphase
    numba lower bounds over time per link pair: minima and suspect intervals.
exact
    The exact solid distance with FCL, pruned by the bounds.
scene
    Objects of a check and their candidate link pairs (tilted robots posed per pair,
    with slacks).
check
    :func:`validate_trajectory`: the four steps and the report.
pair
    :class:`RobotPair`: two robots, many configurations (buffer calibration).
"""
from rfp_twin.validation.mesh3d.check import validate_trajectory
from rfp_twin.validation.mesh3d.links import (LinkModels, Placement, fit_capsule, link_frame,
                                              link_pose, placement)
from rfp_twin.validation.mesh3d.pair import RobotPair
from rfp_twin.validation.mesh3d.report import Check3DReport, Collision3D, PairDistance

__all__ = [
    "RobotPair",
    "Check3DReport",
    "Collision3D",
    "LinkModels",
    "PairDistance",
    "Placement",
    "validate_trajectory",
    "fit_capsule",
    "link_frame",
    "link_pose",
    "placement",
]
