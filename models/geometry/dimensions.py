"""Dimensions of the 3D robot: link frames, the SDSS-V defaults and :class:`GeometryParams`.

A positioner has four kinds of rigid parts ("links"), each in its own frame (mm, z up):

``body``
    The fixed body, a cylinder below the robot frame's z = 0 plane. Robot frame: origin on
    the alpha axis at the top face of the fixed body, x along alpha = 0.
``alpha``
    The rotating upper body: a convex "stadium" around the hub on the alpha axis and the
    housing of the beta motor around the beta axis. Frame: origin on the alpha axis at
    ``alpha_z_mm`` above the robot frame, x towards the beta axis.
``beta``
    The beta arm as it is: a bar ``2 * beta_half_width_mm`` wide and ``beta_height_mm``
    high that starts behind the beta axis (rounded rear end), runs along +x and ends in a
    rounded head cut flat at ``beta_tip_mm`` (flat ``2 * beta_tip_half_width_mm`` wide);
    the fiber ferrule hangs ``ferrule_drop_mm`` below the bar near its tip and the beta
    post (the shaft) joins it to the alpha arm. Frame: origin on the beta axis at the
    bottom face of the bar, ``beta_z_mm`` above the robot frame, x along the arm.
``fiducial``
    A fixed cylinder from the bottom of the fixed bodies up to the focal surface.

``beta_shape`` chooses the beta arm: ``"bar"`` (default) is the estimate bar above;
``"p1"`` is the published P1 prototype (:mod:`rfp_twin.models.geometry.p1`), a tube of
sphere-swept segments rising to a head block 30 mm above the beta frame origin (P1's
z = 0 is placed at the beta frame origin: our reading, the published model gives no
height of its base). With ``"p1"`` the bar, tip and ferrule keys are not used for the
arm's shape (they stay in the table; the ferrule is not built: the fibers sit in the
head).

The fiber tips lie on the focal surface (``focal_z_mm`` in the wok frame; the model is
flat): on the top face of the beta bar, or on the axis of the P1 head
(:attr:`GeometryParams.fiber_height_mm`). Lengths in mm, fibers as ``(name, x_mm, y_mm)``
in the beta frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from rfp_twin.models.geometry.p1 import P1_END_X_MM, P1_HEAD_Z_MM
from rfp_twin.models.robot import RobotSpec

#: Link names, in tree order.
LINKS = ("body", "alpha", "beta", "fiducial")
#: Links that move (have a joint).
MOVING_LINKS = ("alpha", "beta")
#: Values of ``beta_shape``: the estimate bar, the published P1 prototype tube.
BETA_SHAPES = ("bar", "p1")

#: SDSS-V defaults, mm (deg where stated). Source of each number in the comment:
#: "coordio/kaiju" = SDSS-V's coordinate package coordio (defaults) and production
#: planner kaiju 1.4.1; "estimate" = no published figure, chosen to be plausible and
#: self-consistent.
SDSS_V_DEFAULTS: dict[str, Any] = {
    "beta_half_width_mm": 1.5,      # Sayres 2021 Sect. 3.3: physical arm half-width
    "beta_tip_mm": 16.2,            # coordio/kaiju: beta axis to the flat top edge
    "beta_tip_half_width_mm": 0.3,  # coordio/kaiju: flat tip 0.6 mm wide
    "beta_rear_mm": 1.5,            # estimate: rounded rear end centred on the beta axis
    "beta_height_mm": 2.0,          # estimate
    "beta_z_mm": 5.8,               # estimate: alpha top 4.3 + ferrule drop 1.0 + 0.5 clearance
    "post_radius_mm": 0.5,          # coordio/kaiju: beta post radius
    "ferrule_x_mm": 14.64,          # estimate: centred between metrology and BOSS/APOGEE
    "ferrule_y_mm": 0.0,
    "ferrule_radius_mm": 0.9,       # estimate: holds the three fibers, inside the bar outline
    "ferrule_drop_mm": 1.0,         # estimate: hangs below the bar
    "fiber_radius_mm": 0.06,        # estimate: drawn fiber core (visual only)
    "alpha_z_mm": 0.3,              # estimate: gap above the fixed body
    "alpha_height_mm": 4.0,         # estimate
    "alpha_hub_radius_mm": 4.0,     # estimate
    "alpha_housing_radius_mm": 3.2, # estimate: beta motor housing; reach 10.6 < 22.4 / 2
    "body_radius_mm": 5.0,          # estimate: visual only
    "body_length_mm": 20.0,         # estimate: visible length above the focal plate
    "fiducial_radius_mm": 1.0,      # estimate: inside the 1.5 mm fiducial keep-out disk
    "plate_thickness_mm": 5.0,      # estimate: visual only
    "focal_z_mm": 143.1,            # coordio/kaiju: focal surface in the wok frame
    "beta_shape": "bar",            # estimate bar; "p1": the published P1 prototype tube
    "circle_sections": 32,          # facets per full circle of the procedural meshes
    "collision_slabs": 8,           # slabs of a CAD link without given collision pieces
    "density_kg_mm3": 2.7e-6,       # estimate: aluminium, for link masses
    "fibers": (("metrology", 14.314, 0.0),   # coordio/kaiju, beta frame
               ("boss", 14.965, -0.376),
               ("apogee", 14.965, 0.376)),
}


@dataclass(frozen=True)
class GeometryParams:
    """Dimensions of the 3D robot, mm (see the module docstring for frames).

    One field per key of the ``[geometry]`` table; defaults are SDSS-V
    (:data:`SDSS_V_DEFAULTS`, sources there). ``fibers`` is a tuple of
    ``(name, x_mm, y_mm)`` in the beta frame. ``meshes`` maps a link to a CAD file,
    ``collision`` a link to a tuple of convex-piece files. ``beta_shape`` is one of
    :data:`BETA_SHAPES`.
    """

    beta_half_width_mm: float
    beta_tip_mm: float
    beta_tip_half_width_mm: float
    beta_rear_mm: float
    beta_height_mm: float
    beta_z_mm: float
    post_radius_mm: float
    ferrule_x_mm: float
    ferrule_y_mm: float
    ferrule_radius_mm: float
    ferrule_drop_mm: float
    fiber_radius_mm: float
    alpha_z_mm: float
    alpha_height_mm: float
    alpha_hub_radius_mm: float
    alpha_housing_radius_mm: float
    body_radius_mm: float
    body_length_mm: float
    fiducial_radius_mm: float
    plate_thickness_mm: float
    focal_z_mm: float
    circle_sections: int
    collision_slabs: int
    density_kg_mm3: float
    fibers: tuple[tuple[str, float, float], ...]
    meshes: dict[str, str] = field(default_factory=dict)
    collision: dict[str, tuple[str, ...]] = field(default_factory=dict)
    beta_shape: str = "bar"
    source: str = field(default="<memory>", compare=False)

    # -- derived -------------------------------------------------------------
    @property
    def alpha_top_mm(self) -> float:
        """Top of the alpha arm in the robot frame."""
        return self.alpha_z_mm + self.alpha_height_mm

    @property
    def fiber_height_mm(self) -> float:
        """Fiber tips above the beta frame origin: the top of the bar, or the axis of the
        P1 head (30 mm, :data:`rfp_twin.models.geometry.p1.P1_HEAD_Z_MM`)."""
        return P1_HEAD_Z_MM if self.beta_shape == "p1" else self.beta_height_mm

    @property
    def fiber_z_mm(self) -> float:
        """Fiber tips in the robot frame: the focal surface (also the top of the
        fiducial posts)."""
        return self.beta_z_mm + self.fiber_height_mm

    @property
    def beta_end_mm(self) -> float:
        """End of the beta arm's axis along x: :attr:`head_centre_mm` for the bar, the
        polyline's last point (14.7 mm) for P1. Default segment end of
        :meth:`rfp_twin.models.geometry.RobotGeometry.beta_envelope_mm`."""
        return P1_END_X_MM if self.beta_shape == "p1" else self.head_centre_mm

    @property
    def head_centre_mm(self) -> float:
        """Centre of the rounded head along the beta arm: where the flat tip cuts the
        circle of radius ``beta_half_width_mm``."""
        hw, th = self.beta_half_width_mm, self.beta_tip_half_width_mm
        return self.beta_tip_mm - math.sqrt(hw * hw - th * th)


def default_params(spec: RobotSpec) -> dict[str, Any]:
    """Geometry defaults for a spec with no ``[geometry]`` table.

    SDSS-V numbers, with the arm-length-dependent ones moved with the beta length
    (tip, ferrule and fibers keep their distance to the fiber at ``beta_length_mm``) and
    the alpha arm and fixed body shrunk if the pitch is too small for them.
    """
    d = dict(SDSS_V_DEFAULTS)
    shift = spec.beta_length_mm - 15.0
    d["beta_tip_mm"] += shift
    d["ferrule_x_mm"] += shift
    d["fibers"] = tuple((n, x + shift, y) for n, x, y in d["fibers"])
    half = spec.pitch_mm / 2.0
    d["alpha_housing_radius_mm"] = min(d["alpha_housing_radius_mm"],
                                       half - spec.alpha_length_mm - 0.3)
    d["alpha_hub_radius_mm"] = min(d["alpha_hub_radius_mm"], half - 0.3)
    d["body_radius_mm"] = min(d["body_radius_mm"], half - 0.3)
    return d
