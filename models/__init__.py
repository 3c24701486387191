"""The instrument as it is: robot specs, layouts, kinematics, collision geometry, trajectories.

The bottom layer of rfp-twin (planners, validation and twin import it, never the other
way). Units: mm, degrees, seconds. Errors are :class:`RfpError` subclasses with one-line
messages. ``import models`` is light: the names below load their module (numba, scipy,
trimesh, mujoco) on first use.

Spec: :class:`RobotSpec`, :func:`load_spec`, :func:`list_presets`.
Layout: :class:`Layout`, :func:`layout_by_name`; flat arrays: :class:`ArrayGeometry`.
Kinematics (Sayres 2021 Eqs. 1-2): :func:`forward`, :func:`inverse`, :func:`sample_patrol_zone`.
Plans: :class:`Trajectory`. 3D robot: :class:`RobotGeometry`, :func:`geometry_for_spec`,
:func:`load_geometry`. MuJoCo: :func:`build_model`, :func:`export_model`, :class:`TwinModel`,
:class:`ModelOptions`.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from rfp_twin.models.errors import (LayoutError, PlanningError, RfpError, SpecError, TargetError,
                           TrajectoryError, UnknownRobotError)
from rfp_twin.models.lazy import lazy_exports
from rfp_twin.models.robot import RobotSpec, list_presets, load_spec

#: Public name -> module that defines it, imported on first access.
_LAZY = {
    "Layout": "rfp_twin.models.layout", "layout_by_name": "rfp_twin.models.layout",
    "ArrayGeometry": "rfp_twin.models.array",
    "forward": "rfp_twin.models.kinematics", "inverse": "rfp_twin.models.kinematics",
    "sample_patrol_zone": "rfp_twin.models.kinematics",
    "Trajectory": "rfp_twin.models.trajectory",
    "RobotGeometry": "rfp_twin.models.geometry", "geometry_for_spec": "rfp_twin.models.geometry",
    "load_geometry": "rfp_twin.models.geometry",
    "ModelOptions": "rfp_twin.models.mjcf", "TwinModel": "rfp_twin.models.mjcf", "build_model": "rfp_twin.models.mjcf",
    "export_model": "rfp_twin.models.mjcf",
}

if TYPE_CHECKING:
    from rfp_twin.models.array import ArrayGeometry
    from rfp_twin.models.geometry import RobotGeometry, geometry_for_spec, load_geometry
    from rfp_twin.models.kinematics import forward, inverse, sample_patrol_zone
    from rfp_twin.models.layout import Layout, layout_by_name
    from rfp_twin.models.mjcf import ModelOptions, TwinModel, build_model, export_model
    from rfp_twin.models.trajectory import Trajectory


__getattr__, __dir__ = lazy_exports(__name__, _LAZY)

__all__ = ["LayoutError", "PlanningError", "RfpError", "SpecError", "TargetError",
           "TrajectoryError", "UnknownRobotError", "RobotSpec", "list_presets", "load_spec",
           *_LAZY]
